"""The cycle-time model: constants, units, limits and the paper's formulas, and the entry points
that turn them into cycle times, tables and plans.

Two layers live here. Below the engine (:mod:`emulator.net` imports them): :mod:`.params` (every
timing constant), :mod:`.units`, :mod:`.limits` (which networks can exist), :mod:`.analytic` (the
paper's eqs. 3-19) and :mod:`.paper_tables` (Tables I-III as printed). Above it (they run it):
:mod:`.cycle_time` (one cycle time, analytic or emulated), :mod:`.tables` and :mod:`.plan`. This
file therefore imports nothing: importing it must not pull in the engine.
"""
