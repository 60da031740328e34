"""Timing-only sweeps: one steady-state cycle per cell, no frame bytes."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.model.params import TimingParams
from emulator.net.api import simulate_ecat, simulate_epl

__all__ = ["cycle_ps_row"]


def cycle_ps_row(
    table: str, nodes: int, sizes: npt.NDArray[np.int64], params: TimingParams
) -> npt.NDArray[np.int64]:
    """Cycle times in ps of ``table`` with ``nodes`` nodes, one per size in ``sizes``."""
    out = np.empty(len(sizes), dtype=np.int64)
    for i, b in enumerate(sizes.tolist()):
        if table == "epl":
            r = simulate_epl(nodes, b, params, cycles=1)
        elif table in ("ecat", "ecat_redundant"):
            r = simulate_ecat(nodes, b, params, closed_ring=table == "ecat_redundant", cycles=1)
        else:
            raise TopologyError(f"unknown table {table!r}")
        out[i] = next(iter(r.durations))
    return out
