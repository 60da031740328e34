"""One entry point for a cycle time: analytic (the paper's formulas) or emulated (real frames)."""

from __future__ import annotations

import os
from typing import Final

from emulator.errors import PresetError
from emulator.model import analytic
from emulator.model.limits import check_ecat, check_epl
from emulator.model.names import EPL, TABLES, is_closed_ring, table_name
from emulator.model.params import TimingParams
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.result import SimResult

__all__ = ["MODELS", "TABLES", "cycle_us", "simulate", "validate"]

MODELS: Final = ("analytic", "emulated")


def simulate(
    table: str,
    nodes: int,
    data_bytes: int,
    params: TimingParams,
    *,
    layout: str = "per-slave",
    cycles: int = 2,
    seed: int = 0,
    pcap: str | os.PathLike[str] | None = None,
) -> SimResult:
    """Emulate one configuration named as the paper's tables name them (``pcap``: write the
    frames there as they come)."""
    if table_name(table) == EPL:
        return simulate_epl(nodes, data_bytes, params, cycles=cycles, seed=seed, pcap=pcap)
    return simulate_ecat(
        nodes,
        data_bytes,
        params,
        closed_ring=is_closed_ring(table),
        layout=layout,
        cycles=cycles,
        seed=seed,
        pcap=pcap,
    )


def validate(table: str, nodes: int, data_bytes: int) -> None:
    """Raise TopologyError unless the network can exist (the emulators check the same);
    PresetError for an unknown table."""
    if table_name(table) == EPL:
        check_epl(nodes, data_bytes)
    else:
        check_ecat(nodes, data_bytes)


def cycle_us(
    table: str, nodes: int, data_bytes: int, params: TimingParams, model: str = "analytic"
) -> float:
    """Cycle time in us of ``table`` (:data:`TABLES`, or an old name) by ``model``."""
    validate(table, nodes, data_bytes)
    if model == "analytic":
        if table_name(table) == EPL:
            return float(analytic.epl_cycle_us(nodes, data_bytes, params))
        return float(
            analytic.ecat_cycle_us(nodes, data_bytes, params, closed_ring=is_closed_ring(table))
        )
    if model == "emulated":
        return simulate(table, nodes, data_bytes, params, cycles=1).cycle_us()["median"]
    raise PresetError(f"unknown model {model!r}; choose from {list(MODELS)}")
