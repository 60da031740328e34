"""One entry point for a cycle time: analytic (the paper's formulas) or emulated (real frames)."""

from __future__ import annotations

import os
from typing import Final

from emulator.errors import TopologyError
from emulator.model import analytic
from emulator.model.limits import check_ecat, check_epl
from emulator.model.params import TimingParams
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.result import SimResult

__all__ = ["MODELS", "TABLES", "cycle_us", "simulate", "validate"]

TABLES: Final = ("epl", "ecat", "ecat_redundant")  # paper Tables I, II, III
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
    if table == "epl":
        return simulate_epl(nodes, data_bytes, params, cycles=cycles, seed=seed, pcap=pcap)
    if table in ("ecat", "ecat_redundant"):
        return simulate_ecat(
            nodes,
            data_bytes,
            params,
            closed_ring=table == "ecat_redundant",
            layout=layout,
            cycles=cycles,
            seed=seed,
            pcap=pcap,
        )
    raise TopologyError(f"unknown table {table!r}; choose from {list(TABLES)}")


def validate(table: str, nodes: int, data_bytes: int) -> None:
    """Raise TopologyError unless the network can exist (the emulators check the same)."""
    if table == "epl":
        check_epl(nodes, data_bytes)
    elif table in ("ecat", "ecat_redundant"):
        check_ecat(nodes, data_bytes)
    else:
        raise TopologyError(f"unknown table {table!r}; choose from {list(TABLES)}")


def cycle_us(
    table: str, nodes: int, data_bytes: int, params: TimingParams, model: str = "analytic"
) -> float:
    """Cycle time in us of ``table`` ("epl", "ecat", "ecat_redundant") by ``model``."""
    validate(table, nodes, data_bytes)
    if model == "analytic":
        if table == "epl":
            return float(analytic.epl_cycle_us(nodes, data_bytes, params))
        if table in ("ecat", "ecat_redundant"):
            return float(
                analytic.ecat_cycle_us(
                    nodes, data_bytes, params, redundant=table == "ecat_redundant"
                )
            )
        raise TopologyError(f"unknown table {table!r}; choose from {list(TABLES)}")
    if model == "emulated":
        return simulate(table, nodes, data_bytes, params, cycles=1).cycle_us()["median"]
    raise TopologyError(f"unknown model {model!r}; choose from {list(MODELS)}")
