"""Timing-only sweeps (emulator.net.sweep): the engines' own timing on numpy arrays, proven equal
to the ordinary ``simulate`` on sampled cells, and equal to the paper's formulas on thousands."""

from __future__ import annotations

import numpy as np
import pytest

from emulator.errors import TopologyError
from emulator.model.params import PAPER, PRESETS, WIRE
from emulator.model.sweep import analytic_grid
from emulator.model.tables import cycle_tables
from emulator.model.units import PS_PER_US
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.ecat import EcatTiming, frames_for, per_slave_frame_lengths
from emulator.net.epl import EplEngine
from emulator.net.faults import parse_fault
from emulator.net.sweep import cycle_ps_row
from skinframes import ethercat

TABLES = ("epl", "ecat", "ecat_closed_ring")


def simulated_ps(table: str, nodes: int, data_bytes: int, name: str) -> int:
    """One cycle of the ordinary engine (frames, ESC model and all), in ps."""
    params = PRESETS[name]
    if table == "epl":
        r = simulate_epl(nodes, data_bytes, params, cycles=1)
    else:
        r = simulate_ecat(
            nodes, data_bytes, params, closed_ring=table == "ecat_closed_ring", cycles=1
        )
    (ps,) = r.durations
    return ps


def test_frame_lengths_are_the_frames_the_engine_sends() -> None:
    rng = np.random.default_rng(4)
    for n, b in [(1, 1), (1, 1486), (239, 1486), (107, 2), (108, 2), (3, 737), (4, 738)] + [
        (int(n), int(b))
        for n, b in zip(rng.integers(1, 240, 60), rng.integers(1, 1487, 60), strict=True)
    ]:
        lengths = per_slave_frame_lengths(n, np.array([b]))[:, 0]
        sent = [len(ethercat.frame(f).to_bytes()) for f in frames_for(n, b)]
        assert lengths[lengths > 0].tolist() == sent and (lengths[len(sent) :] == 0).all()


# small and edge cells of every table (one frame, many frames, padded frames), both presets
CELLS = [(1, 1), (2, 33), (7, 46), (13, 1486), (60, 123), (107, 2), (108, 2), (131, 738)]


@pytest.mark.parametrize("name", sorted(PRESETS))
@pytest.mark.parametrize("table", TABLES)
def test_sweep_equals_the_ordinary_simulate(table: str, name: str) -> None:
    for n in sorted({n for n, _ in CELLS}):
        sizes = np.array(sorted({b for m, b in CELLS if m == n} | {1, 46, 1486}))
        row = cycle_ps_row(table, n, sizes, PRESETS[name])
        assert row.tolist() == [simulated_ps(table, n, int(b), name) for b in sizes]


def test_sweep_equals_simulate_at_the_largest_cells() -> None:
    sizes = np.array([2, 192, 1486])
    for table in TABLES:
        row = cycle_ps_row(table, 239, sizes, PAPER)
        assert row.tolist() == [simulated_ps(table, 239, int(b), "paper") for b in sizes]


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_thousands_of_random_cells_agree_with_the_formulas(name: str) -> None:
    """12,000 seeded random cells (40 node counts x 100 sizes x 3 tables): emulated = analytic
    within 0.01 us (in fact to the picosecond; docs/paper-notes.md)."""
    params = PRESETS[name]
    rng = np.random.default_rng(2026)
    for table in TABLES:
        nodes = rng.choice(np.arange(1, 240), 40, replace=False)
        sizes = np.sort(rng.choice(np.arange(1, 1487), 100, replace=False))
        grid = analytic_grid(table, nodes.tolist(), sizes.tolist(), params)
        for n, expected in zip(nodes.tolist(), grid, strict=True):
            emulated = cycle_ps_row(table, n, sizes, params) / PS_PER_US
            assert np.abs(emulated - expected).max() <= 0.01, (table, n)
            assert np.round(emulated, 6).tolist() == np.round(expected, 6).tolist()


def test_where_the_wire_rules_bind_emulated_and_formula_part() -> None:
    """The formulas charge D_CN after each PReq; the wire preset's engine waits at least an IFG
    between two frames (802.3 4.2.3.2.1). With D_CN below the IFG the engine is slower by
    n x (IFG - D_CN) exactly; with both presets' D_CN = 1 us > 0.96 us the rule never binds."""
    fast_cn = WIRE.with_changes(epl_cn_delay_ps=500_000)
    sizes = np.array([2, 192, 1486])
    for n in (1, 10, 239):
        emulated = cycle_ps_row("epl", n, sizes, fast_cn)
        analytic = analytic_grid("epl", [n], sizes.tolist(), fast_cn)[0]
        extra_us = n * (fast_cn.ifg_ps - 500_000) / PS_PER_US
        assert emulated / PS_PER_US == pytest.approx(analytic + extra_us, abs=1e-6)


def test_sweeps_are_of_healthy_networks_only() -> None:
    with pytest.raises(TopologyError):
        EcatTiming(4, PAPER, faults=(parse_fault("cable:2@1"),)).cycle_ps(np.ones((1, 1), np.int64))
    with pytest.raises(TopologyError):
        EplEngine(4, 0, PAPER, asnd=True).cycle_ps(np.ones(2, np.int64))
    with pytest.raises(TopologyError):
        cycle_ps_row("ecat", 4, np.array([1487]), PAPER)


def test_tables_emulated_over_processes_is_the_analytic_table() -> None:
    nodes, sizes = [1, 2, 239, 240, 1025], [0, 1, 192, 1486, 1487]
    seen: list[int] = []
    emulated = cycle_tables("emulated", PAPER, nodes, sizes, jobs=2, progress=seen.append)
    analytic = cycle_tables("analytic", PAPER, nodes, sizes)
    assert sum(seen) == 3 * len(nodes) * len(sizes)
    for table in TABLES:
        for n in map(str, nodes):
            for b in map(str, sizes):
                if n == "1025" and table != "epl":  # the emulated chain ends at 1024 slaves
                    assert emulated[table][n][b] is None
                    assert analytic[table][n][b] is not None or b in ("0", "1487")
                else:
                    assert emulated[table][n][b] == analytic[table][n][b]
    assert emulated["not_applicable"]["ecat"] == [
        "EtherCAT (emulated): 1025 slaves (1..1024)",
        "EtherCAT (emulated): 0 bytes per slave (1..1486)",
        "EtherCAT (emulated): 1487 bytes per slave (1..1486)",
    ]
