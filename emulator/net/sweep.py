"""Timing-only sweeps: one steady-state cycle per cell, no frame bytes, many cells per call.

The engines' own timing code runs on numpy time arrays: for one node count, the frames of every
payload size walk the chain together (:meth:`emulator.net.ecat.EcatTiming.cycle_ps`) or the
polls run once with a PRes time per size (:meth:`emulator.net.epl.EplEngine.cycle_ps`). No ESC
register model and no frame bytes are built, so a cell costs microseconds instead of the
milliseconds of ``simulate`` (which tests prove equal on sampled cells).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import numpy.typing as npt

from emulator.model.limits import check_emulated_ecat, check_epl
from emulator.model.names import EPL, is_closed_ring, table_name
from emulator.model.params import TimingParams
from emulator.net.ecat import EcatTiming, per_slave_frame_lengths
from emulator.net.epl import EplEngine, pres_length

__all__ = ["cycle_ps_row", "ecat_cycle_ps", "epl_cycle_ps"]


def _wire_ps(lengths: npt.NDArray[np.int64], params: TimingParams) -> npt.NDArray[np.int64]:
    """Wire time of each frame length (0 stays 0: no frame), by ``params.frame_ps``."""
    uniq, inverse = np.unique(lengths, return_inverse=True)
    times = np.array([params.frame_ps(int(n)) if n else 0 for n in uniq], dtype=np.int64)
    return times[inverse].reshape(lengths.shape)


def ecat_cycle_ps(
    nodes: int, sizes: npt.NDArray[np.int64], params: TimingParams, *, closed_ring: bool
) -> npt.NDArray[np.int64]:
    """Cycle time in ps of a healthy EtherCAT chain of ``nodes`` slaves (one LRD each, the
    ``per-slave`` layout), one per size in ``sizes``."""
    for b in (int(sizes.min()), int(sizes.max())):
        check_emulated_ecat(nodes, b)
    wire = _wire_ps(per_slave_frame_lengths(nodes, sizes), params)
    return EcatTiming(nodes, params, closed_ring=closed_ring).cycle_ps(wire)


@lru_cache(maxsize=4096)
def _pres_length(data_bytes: int) -> int:
    return pres_length(data_bytes)


def epl_cycle_ps(
    nodes: int, sizes: npt.NDArray[np.int64], params: TimingParams
) -> npt.NDArray[np.int64]:
    """Cycle time in ps of a healthy EPL network of ``nodes`` CNs, one per size in ``sizes``."""
    for b in (int(sizes.min()), int(sizes.max())):
        check_epl(nodes, b)
    lengths = np.array([_pres_length(int(b)) for b in sizes.tolist()], dtype=np.int64)
    return EplEngine(nodes, 0, params).cycle_ps(_wire_ps(lengths, params))


def cycle_ps_row(
    table: str, nodes: int, sizes: npt.NDArray[np.int64], params: TimingParams
) -> npt.NDArray[np.int64]:
    """Cycle times in ps of ``table`` (emulator.model.names: "epl", "ecat", "ecat_closed_ring"
    or an old name) with ``nodes`` nodes, one per size in ``sizes``."""
    if table_name(table) == EPL:
        return epl_cycle_ps(nodes, sizes, params)
    return ecat_cycle_ps(nodes, sizes, params, closed_ring=is_closed_ring(table))
