"""The analytic model against the paper's printed tables and hand-computed terms."""

from __future__ import annotations

import math

import pytest
from data.paper_tables import BYTES, NODES, PAPER_TABLES

from emulator import analytic
from emulator.model.params import PAPER, WIRE

CELLS = [(t, n, b) for t in PAPER_TABLES for n in NODES for b in BYTES]


@pytest.mark.parametrize(("table", "nodes", "size"), CELLS)
def test_paper_preset_reproduces_every_cell(table: str, nodes: int, size: int) -> None:
    if table == "epl":
        ours = float(analytic.epl_cycle_us(nodes, size, PAPER))
    else:
        ours = float(analytic.ecat_cycle_us(nodes, size, PAPER, closed_ring=table != "ecat"))
    assert ours == pytest.approx(PAPER_TABLES[table][nodes][size], abs=0.006)


def test_hand_computed_terms() -> None:
    # eq. 4 and 10: (46 + 26) bytes x 0.08 us + 0.96 us
    assert analytic.t_st(PAPER) == pytest.approx(6.72)
    assert analytic.t_soa(PAPER) == pytest.approx(6.72)
    # eq. 16: (26 + 12) x 0.08 us
    assert analytic.t_eth(PAPER) == pytest.approx(3.04)
    # eq. 15: floor(1498 / 14) and floor(1498 / 204)
    assert int(analytic.max_tgram(2)) == 107
    assert int(analytic.max_tgram(192)) == 7
    assert int(analytic.n_fr(160, 192)) == 23
    # eq. 8 for n = 1: 2 (0.3 + 0.0005) + 2 x 1 x (0.3005)
    assert float(analytic.d_nk(1, PAPER)) == pytest.approx(4 * 0.3005)
    # eq. 19: one 2-byte datagram, D_ECAT = 2 + 14 = 16 bytes, 30 bytes of padding
    assert float(analytic.t_pad(1, 2, PAPER)) == pytest.approx(30 * 0.08)


def test_printed_eq14_cannot_give_the_tables() -> None:
    """ceil(max_tgram / n), as printed, is 1 frame for every cell; the tables need more."""
    for n in NODES:
        for b in BYTES:
            printed = math.ceil(int(analytic.max_tgram(b)) / n)
            assert printed == 1
    # Table II, 160 nodes x 256 bytes: with one frame the cycle would be 22 x 3.04 us shorter
    assert int(analytic.n_fr(160, 256)) == 160 // 5 + (160 % 5 > 0)  # max_tgram(256) = 5


def test_wire_preset_is_slower_for_epl() -> None:
    """Class II hubs (460 ns) instead of 300 ns: the quadratic hub term grows by ~53 %."""
    assert analytic.epl_cycle_us(160, 192, WIRE) > 1.3 * analytic.epl_cycle_us(160, 192, PAPER)
