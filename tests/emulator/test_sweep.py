"""emulator.model.sweep and the streamed tables: the whole grid at once equals the scalar model."""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest
from data.paper_tables import BYTES, NODES, PAPER_TABLES

from emulator.errors import TopologyError
from emulator.model import analytic
from emulator.model.cycle_time import TABLES, cycle_us
from emulator.model.params import PAPER, PRESETS, WIRE
from emulator.model.sweep import analytic_grid, cell_reason, reasons, rows
from emulator.model.tables import cycle_tables, iter_csv, iter_json

ALL_NODES = list(range(1, 241))
ALL_BYTES = list(range(0, 1492))


@pytest.mark.parametrize("name", sorted(PRESETS))
@pytest.mark.parametrize("table", TABLES)
def test_grid_equals_the_scalar_model_on_sampled_cells(name: str, table: str) -> None:
    params = PRESETS[name]
    grid = analytic_grid(table, ALL_NODES, ALL_BYTES, params)
    rng = np.random.default_rng(15)
    picks = zip(
        rng.integers(0, len(ALL_NODES), 400), rng.integers(0, len(ALL_BYTES), 400), strict=True
    )
    for i, j in picks:
        n, b = ALL_NODES[i], ALL_BYTES[j]
        reason = cell_reason(table, n, b)
        if reason is None:
            assert grid[i, j] == cycle_us(table, n, b, params)  # exactly: the same formulas
        else:
            assert math.isnan(grid[i, j])
            with pytest.raises(TopologyError, match=reason.replace("(", r"\(").replace(")", r"\)")):
                cycle_us(table, n, b, params)


def test_grid_is_the_papers_tables() -> None:
    for table, printed in PAPER_TABLES.items():
        grid = analytic_grid(table, NODES, BYTES, PAPER)
        for i, n in enumerate(NODES):
            for j, b in enumerate(BYTES):
                assert grid[i, j] == pytest.approx(printed[n][b], abs=0.006)


def test_the_formulas_broadcast_a_column_of_nodes_against_a_row_of_bytes() -> None:
    n, b = np.array([[1], [160], [239]]), np.array([[2, 192, 1486]])
    epl = analytic.epl_cycle_us(n, b, WIRE)
    ring = analytic.ecat_cycle_us(n, b, WIRE, closed_ring=True)
    assert epl.shape == ring.shape == (3, 3)
    assert epl[1, 1] == float(analytic.epl_cycle_us(160, 192, WIRE))
    assert ring[2, 0] == float(analytic.ecat_cycle_us(239, 2, WIRE, closed_ring=True))


def test_cells_beyond_a_protocol_are_not_applicable_with_the_reason() -> None:
    doc = cycle_tables("analytic", WIRE, [239, 240], [1486, 1487])
    assert doc["epl"]["240"] == {"1486": None, "1487": None}
    assert doc["epl"]["239"]["1487"] is not None  # EPL carries up to 1490 bytes
    assert doc["ecat"]["240"]["1487"] is None and doc["ecat"]["240"]["1486"] is not None
    assert doc["not_applicable"] == {
        "epl": ["EPL: 240 CNs (1..239)"],
        "ecat": ["EtherCAT: 1487 bytes per slave (1..1486)"],
        "ecat_closed_ring": ["EtherCAT: 1487 bytes per slave (1..1486)"],
        "ecat_redundant": ["EtherCAT: 1487 bytes per slave (1..1486)"],  # its old name
    }
    assert reasons("ecat", [5], [0, 1487, 1490]) == [
        "EtherCAT: 0 bytes per slave (1..1486)",
        "EtherCAT: 1487..1490 bytes per slave (1..1486)",
    ]
    assert "not_applicable" not in cycle_tables("analytic", PAPER, NODES, BYTES)


@pytest.mark.parametrize(("nodes", "sizes"), [([0, 3], [8]), ([3], [-1, 8])])
def test_nonsense_values_are_refused(nodes: list[int], sizes: list[int]) -> None:
    with pytest.raises(TopologyError):
        rows("analytic", PAPER, nodes, sizes)
    with pytest.raises(TopologyError):
        next(iter_json("analytic", PAPER, nodes, sizes))


@pytest.mark.parametrize(("nodes", "sizes"), [(NODES, BYTES), ([1, 239, 240, 1000], [0, 46, 1487])])
def test_streamed_json_is_the_document(nodes: list[int], sizes: list[int]) -> None:
    text = "".join(iter_json("analytic", WIRE, nodes, sizes))
    doc = cycle_tables("analytic", WIRE, nodes, sizes)
    assert text == json.dumps(doc, indent=2) + "\n"


def test_csv_has_one_line_per_cell_with_the_reason() -> None:
    nodes, sizes = [2, 240], [0, 192, 1487]
    lines = list(csv.DictReader(io.StringIO("".join(iter_csv("analytic", PAPER, nodes, sizes)))))
    assert len(lines) == 3 * len(nodes) * len(sizes)
    doc = cycle_tables("analytic", PAPER, nodes, sizes)
    for line in lines:
        t, n, b = line["table"], int(line["nodes"]), int(line["bytes"])
        value = doc[t][str(n)][str(b)]
        if value is None:
            assert line["cycle_us"] == "" and line["not_applicable"] == cell_reason(t, n, b)
        else:
            assert float(line["cycle_us"]) == value and line["not_applicable"] == ""
    assert lines[0] == {
        "table": "epl",
        "nodes": "2",
        "bytes": "0",
        "cycle_us": str(round(cycle_us("epl", 2, 0, PAPER), 6)),
        "not_applicable": "",
    }
