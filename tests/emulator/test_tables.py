"""emulator.model.tables: the tables document, checked against the paper's cells (typed in by the tests)."""

from __future__ import annotations

import pytest
from data.paper_tables import BYTES, NODES, OLD_NAMES, PAPER_TABLES

from emulator.model.params import PAPER, WIRE
from emulator.model.tables import cycle_tables


def test_analytic_paper_preset_is_the_papers_tables() -> None:
    doc = cycle_tables("analytic", PAPER, NODES, BYTES)
    keys = ["model", "preset", "unit", "epl_cn_response_us", "epl", "ecat", "ecat_closed_ring"]
    keys.append("ecat_redundant")
    assert list(doc) == keys
    assert (doc["model"], doc["preset"], doc["unit"]) == ("analytic", "paper", "us")
    assert doc["epl_cn_response_us"] == 1.0  # the paper's D_cn (after its eq. 7)
    tables = {**PAPER_TABLES, **{old: PAPER_TABLES[new] for old, new in OLD_NAMES.items()}}
    for table, rows in tables.items():
        assert list(doc[table]) == [str(n) for n in NODES]
        for n, row in rows.items():
            assert list(doc[table][str(n)]) == [str(b) for b in BYTES]
            for b, printed in row.items():
                assert doc[table][str(n)][str(b)] == pytest.approx(printed, abs=0.006)


def test_progress_counts_every_cell_once() -> None:
    seen: list[int] = []
    doc = cycle_tables("emulated", WIRE, [3], [8, 16], progress=seen.append, jobs=1)
    assert sum(seen) == 3 * 2
    assert doc["preset"] == "wire"
    assert doc["ecat"]["3"]["16"] > doc["ecat"]["3"]["8"] > 0
