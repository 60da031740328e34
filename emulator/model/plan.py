"""The fastest frame layout per network, and its distance to the physical limit (``skinframes plan``).

For EPL (one layout: a PReq/PRes pair per CN) and EtherCAT in open and closed ring (one LRD per
slave, or one contiguous logical process image), every layout is emulated for one cycle and the
fastest is kept. The physical limit is the time the taxel bytes alone take on one 100 Mbit/s link,
``nodes x data_bytes x byte time``: no protocol, no header, no gap.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.model.cycle_time import simulate, validate
from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL, TABLES, with_old_keys
from emulator.model.params import WIRE, TimingParams
from emulator.model.sweep import analytic_grid, cell_reason
from emulator.model.units import PS_PER_US
from emulator.net.ecat import LAYOUTS

__all__ = ["LAYOUTS_IN_ALL", "LayoutOption", "NetworkPlan", "Plan", "limit_us", "plan"]

Num = npt.ArrayLike
PER_SLAVE: Final = "per-slave"
TABLE_LAYOUTS: Final[dict[str, tuple[str, ...]]] = {
    EPL: (PER_SLAVE,),  # EPL has one layout: each CN answers its PReq with its own PRes
    ECAT: LAYOUTS,
    ECAT_CLOSED_RING: LAYOUTS,
}
LAYOUTS_IN_ALL: Final = sum(len(layouts) for layouts in TABLE_LAYOUTS.values())


@dataclass(frozen=True, slots=True)
class LayoutOption:
    """One emulated layout: its cycle time and the frames the master sends per cycle."""

    layout: str
    cycle_us: float
    frames_per_cycle: int

    def to_json(self) -> dict[str, Any]:
        """``{"layout", "cycle_us", "frames_per_cycle"}``."""
        return {
            "layout": self.layout,
            "cycle_us": self.cycle_us,
            "frames_per_cycle": self.frames_per_cycle,
        }


@dataclass(frozen=True, slots=True)
class NetworkPlan:
    """The fastest layout of one network and how far it is from the physical limit.

    Attributes:
        best: the layout with the shortest cycle (the first one on a tie).
        overhead_us: ``best.cycle_us - limit_us``: what the protocol costs beyond the taxels.
        efficiency: ``limit_us / best.cycle_us`` (1.0 = the link carries nothing but taxels).
        alternatives: every layout emulated, ``best`` among them, in the order tried.
        analytic_us: the paper's eqs. (3)-(19) for the same cell (its per-slave layout).
    """

    best: LayoutOption
    overhead_us: float
    efficiency: float
    alternatives: tuple[LayoutOption, ...]
    analytic_us: float = float("nan")

    def to_json(self) -> dict[str, Any]:
        """The best layout's fields, then ``overhead_us``, ``efficiency``, ``alternatives``,
        ``analytic_us``."""
        return {
            **self.best.to_json(),
            "overhead_us": self.overhead_us,
            "efficiency": self.efficiency,
            "alternatives": [o.to_json() for o in self.alternatives],
            "analytic_us": self.analytic_us,
        }


@dataclass(frozen=True, slots=True)
class Plan:
    """The plan for ``nodes`` x ``data_bytes`` under one preset.

    Attributes:
        networks: keyed by table name (``epl``, ``ecat``, ``ecat_closed_ring``), in that order:
            those that can have ``nodes`` x ``data_bytes``.
        not_applicable: the others, each with the reason (e.g. ``"EPL: 500 CNs (1..239)"``).
    """

    nodes: int
    data_bytes: int
    preset: str
    limit_us: float
    networks: dict[str, NetworkPlan]
    epl_cn_response_us: float = 1.0  # D_CN of the timing constants (TimingParams)
    not_applicable: dict[str, str] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The ``skinframes plan --json`` document (docs/interface.md): a network that cannot
        have the cell null, and its reason under ``not_applicable`` (as ``tables --json``);
        the closed ring also under its old name ``ecat_redundant``."""
        networks = {t: n.to_json() if (n := self.networks.get(t)) else None for t in TABLES}
        na = {t: [reason] for t, reason in self.not_applicable.items()}
        return {
            "nodes": self.nodes,
            "bytes": self.data_bytes,
            "preset": self.preset,
            "epl_cn_response_us": self.epl_cn_response_us,
            "limit_us": self.limit_us,
            **with_old_keys(networks),
            **({"not_applicable": with_old_keys(na)} if na else {}),
        }


def limit_us(nodes: Num, data_bytes: Num, params: TimingParams) -> Any:
    """The physical limit: ``nodes x data_bytes`` taxel bytes back to back on one link, in us
    (scalars, or numpy arrays that broadcast: a float or an array)."""
    return np.asarray(nodes) * np.asarray(data_bytes) * params.byte_ps / PS_PER_US


def plan(
    nodes: int,
    data_bytes: int,
    params: TimingParams = WIRE,
    *,
    progress: Callable[[int], None] | None = None,
    skip_impossible: bool = False,
) -> Plan:
    """Emulate every layout of every network for one cycle and keep the fastest of each.
    A network that cannot have ``nodes`` nodes of ``data_bytes`` (e.g. > 239 EPL CNs) raises;
    with ``skip_impossible`` (``skinframes plan``) it is left out instead, its reason in
    :attr:`Plan.not_applicable` (as :func:`emulator.model.sweep.cell_reason` says for the
    emulated model).

    ``progress`` is called with the layouts done (or passed over) since its last call, of
    :data:`LAYOUTS_IN_ALL` (a thousand slaves of 1486 bytes take a minute or two).

    Raises:
        TopologyError: a network cannot have them (with ``skip_impossible``: none can).
    """
    limit = float(limit_us(nodes, data_bytes, params))
    networks: dict[str, NetworkPlan] = {}
    na: dict[str, str] = {}
    for table in TABLES:
        if not skip_impossible:
            validate(table, nodes, data_bytes)
        reason = cell_reason(table, nodes, data_bytes, "emulated")
        if reason is not None:
            na[table] = reason
            if progress is not None:
                progress(len(TABLE_LAYOUTS[table]))
            continue
        options = []
        for layout in TABLE_LAYOUTS[table]:
            options.append(_emulate(table, nodes, data_bytes, params, layout))
            if progress is not None:
                progress(1)
        best = min(options, key=lambda o: o.cycle_us)
        networks[table] = NetworkPlan(
            best=best,
            overhead_us=best.cycle_us - limit,
            efficiency=limit / best.cycle_us,
            alternatives=tuple(options),
            analytic_us=round(float(analytic_grid(table, [nodes], [data_bytes], params)[0, 0]), 6),
        )
    if not networks:
        raise TopologyError("; ".join(dict.fromkeys(na.values())))  # (one line per cause)
    return Plan(nodes, data_bytes, params.name, limit, networks, params.epl_cn_response_us, na)


def _emulate(
    table: str, nodes: int, data_bytes: int, params: TimingParams, layout: str
) -> LayoutOption:
    """One fault-free cycle of ``table`` in ``layout``: its time and frames sent per cycle."""
    r = simulate(table, nodes, data_bytes, params, layout=layout, cycles=1)
    frames = r.frames_sent_per_cycle if table != EPL else r.frames // r.cycles
    return LayoutOption(layout, r.cycle_us()["median"], frames)
