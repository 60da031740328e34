"""Cycle-time tables in the layout of the paper's Tables I-III (``skinframes tables``).

One cell per network, node count and payload: EPL (Table I), EtherCAT open ring (Table II) and
closed ring (Table III), by the analytic model or the frame-level emulator.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any, Final

from emulator.model.cycle_time import TABLES, cycle_us
from emulator.model.params import TimingParams

__all__ = ["Cell", "cycle_tables"]

Cell = tuple[str, int, int]  # (table, nodes, data_bytes)
DECIMALS: Final = 6  # cycle times in the document are rounded to a picosecond (1e-6 us)


def cycle_tables(
    model: str,
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    *,
    progress: Callable[[list[Cell]], Iterable[Cell]] | None = None,
) -> dict[str, Any]:
    """The ``skinframes tables --json`` document.

    ``{"model", "preset", "unit": "us", "epl": {"<nodes>": {"<bytes>": us}}, "ecat": ...,
    "ecat_redundant": ...}``, keys as strings in the order given.

    Args:
        model: ``"analytic"`` or ``"emulated"`` (:data:`emulator.model.cycle_time.MODELS`).
        progress: wraps the list of cells to compute, e.g. in a progress bar; it must yield
            every cell once.

    Raises:
        TopologyError: a cell's network cannot exist, or an unknown model.
    """
    doc: dict[str, Any] = {"model": model, "preset": params.name, "unit": "us"}
    cells = [(t, n, b) for t in TABLES for n in nodes for b in sizes]
    for table in TABLES:
        doc[table] = {str(n): {} for n in nodes}
    for table, n, b in cells if progress is None else progress(cells):
        doc[table][str(n)][str(b)] = round(cycle_us(table, n, b, params, model), DECIMALS)
    return doc
