"""One word per thing: the closed ring is ``ecat_closed_ring``, and its old name ``ecat_redundant``
gives the same results everywhere it is accepted (issue 10, item 7; docs/interface.md, Old names).

The names are typed here, not imported from the code under test.
"""

from __future__ import annotations

import csv
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest
from data.paper_tables import PAPER_TABLES

from emulator import PAPER, WIRE, PresetError, TopologyError, analytic
from emulator.model.cycle_time import cycle_us, simulate, validate
from emulator.model.paper_tables import paper_value
from emulator.model.sweep import analytic_grid, cell_reason, reasons
from emulator.net.sweep import cycle_ps_row
from skinframes_cli import main
from skinframes_cli.demo import output_names

NEW, OLD = "ecat_closed_ring", "ecat_redundant"
DOC = Path(__file__).resolve().parent.parent / "docs" / "interface.md"


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


def test_tables_json_carries_the_closed_ring_under_both_keys(
    capsys: pytest.CaptureFixture[str],
) -> None:
    doc = run_json(capsys, "tables", "--nodes", "160,240", "--bytes", "128,1487", "--json")
    keys = list(doc)
    assert keys.index(OLD) == keys.index(NEW) + 1  # the old key right after the new one
    assert doc[OLD] == doc[NEW]
    assert doc[NEW]["160"]["128"] == pytest.approx(PAPER_TABLES[NEW][160][128], abs=0.006)
    assert doc[NEW] != doc["ecat"]  # the closed ring, not the open one
    assert (
        doc["not_applicable"][OLD]
        == doc["not_applicable"][NEW]
        == ["EtherCAT: 1487 bytes per slave (1..1486)"]
    )


def test_tables_emulated_json_carries_both_keys(capsys: pytest.CaptureFixture[str]) -> None:
    doc = run_json(
        capsys, "tables", "--model", "emulated", "--nodes", "3", "--bytes", "8", "--jobs", "1",
        "--json",
    )  # fmt: skip
    assert doc[OLD] == doc[NEW]
    assert doc[NEW]["3"]["8"] == pytest.approx(analytic.ecat_cycle_us(3, 8, PAPER, True), abs=0.01)


def test_tables_csv_keeps_the_old_name_in_its_table_column(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["tables", "--nodes", "160", "--bytes", "128", "--csv"]) == 0
    lines = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert [line["table"] for line in lines] == ["epl", "ecat", OLD]
    assert float(lines[2]["cycle_us"]) == pytest.approx(PAPER_TABLES[NEW][160][128], abs=0.006)


def test_plan_json_carries_the_closed_ring_under_both_keys(
    capsys: pytest.CaptureFixture[str],
) -> None:
    doc = run_json(capsys, "plan", "--nodes", "4", "--bytes", "16", "--json")
    keys = list(doc)
    assert keys[-3:] == ["ecat", NEW, OLD]
    assert doc[OLD] == doc[NEW]
    ring = round(float(analytic.ecat_cycle_us(4, 16, WIRE, closed_ring=True)), 6)
    assert doc[NEW]["analytic_us"] == ring


def test_the_python_table_names_are_equal() -> None:
    for n, b in [(1, 1), (160, 192), (200, 256)]:
        assert cycle_us(OLD, n, b, PAPER) == cycle_us(NEW, n, b, PAPER)
        assert paper_value(OLD, n, b) == paper_value(NEW, n, b)
    assert paper_value(NEW, 160, 128) == PAPER_TABLES[NEW][160][128]
    grid_old = analytic_grid(OLD, [1, 160, 70000], [0, 192], WIRE)
    grid_new = analytic_grid(NEW, [1, 160, 70000], [0, 192], WIRE)
    assert grid_old.tobytes() == grid_new.tobytes()  # NaN where not applicable, in both
    assert reasons(OLD, [70000], [0]) == reasons(NEW, [70000], [0])
    assert cell_reason(OLD, 3, 1487) == cell_reason(NEW, 3, 1487) is not None
    sizes = np.array([2, 192])
    assert cycle_ps_row(OLD, 5, sizes, WIRE).tolist() == cycle_ps_row(NEW, 5, sizes, WIRE).tolist()
    a = simulate(OLD, 5, 16, WIRE, cycles=1)
    b = simulate(NEW, 5, 16, WIRE, cycles=1)
    assert a.topology == b.topology == "closed" and a.durations == b.durations


def test_analytic_takes_closed_ring_and_its_old_name() -> None:
    ring = float(analytic.ecat_cycle_us(160, 192, PAPER, closed_ring=True))
    assert ring == pytest.approx(2792.8805, abs=1e-4)  # the README's figure (eq. 12)
    assert float(analytic.ecat_cycle_us(160, 192, PAPER, redundant=True)) == ring
    assert float(analytic.ecat_cycle_us(160, 192, PAPER, True)) == ring  # positional, as before
    assert float(analytic.ecat_cycle_us(160, 192, PAPER, True, redundant=True)) == ring
    assert float(analytic.ecat_cycle_us(160, 192, PAPER)) != ring  # the open ring by default
    with pytest.raises(TopologyError, match="disagree"):
        analytic.ecat_cycle_us(160, 192, PAPER, closed_ring=True, redundant=False)


def test_an_unknown_table_is_one_kind_of_error() -> None:
    for call in (
        lambda: validate("ecat_closed", 3, 8),
        lambda: cycle_us("redundant", 3, 8, PAPER),
        lambda: analytic_grid("ring", [3], [8], PAPER),
        lambda: paper_value("ecat_ring", 160, 128),
    ):
        with pytest.raises(PresetError, match="unknown table"):
            call()
    with pytest.raises(PresetError, match="unknown model"):
        cycle_us("epl", 3, 8, PAPER, model="guess")


def test_demo_keeps_its_file_names() -> None:
    names = output_names(plots=False)
    assert names[:6] == [
        "epl_160x192_paper.pcap",
        "epl_160x192_wire.pcap",
        "ecat_160x192_paper.pcap",
        "ecat_160x192_wire.pcap",
        "ecat_redundant_160x192_paper.pcap",
        "ecat_redundant_160x192_wire.pcap",
    ]


def test_the_interface_doc_lists_old_and_new_names() -> None:
    text = DOC.read_text()
    section = text[text.index("### Old names") : text.index("### `skinframes demo`")]
    row = next(line for line in section.splitlines() if "JSON key" in line)
    assert f"`{NEW}`" in row and f"`{OLD}`" in row
    assert "`--closed-ring`" in section and "`--redundant`" in section
    assert "`closed_ring=`" in section and "`redundant=`" in section
    for command in ("tables", "plan"):
        body = text[text.index(f"### `skinframes {command}`") :]
        body = body[: body.index("\n### ", 1)]
        assert re.search(rf'"{NEW}".*"{OLD}"', body, flags=re.S), command


def test_streamed_json_copies_the_closed_ring_through_a_file(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The old key's copy goes to disk beyond SPOOL_BYTES and comes back in blocks: the text is
    still the document json.dumps writes."""
    from emulator.model import tables

    monkeypatch.setattr(tables, "SPOOL_BYTES", 1)
    monkeypatch.setattr(tables, "COPY_BLOCK_CHARS", 7)
    nodes, sizes = [1, 2, 239, 240, 70000], [0, 46, 1487]
    text = "".join(tables.iter_json("analytic", WIRE, nodes, sizes))
    doc = tables.cycle_tables("analytic", WIRE, nodes, sizes)
    assert text == json.dumps(doc, indent=2) + "\n"
    assert json.loads(text)[OLD] == json.loads(text)[NEW] != {}


@pytest.mark.parametrize("command", ["tables", "plan"])
def test_help_names_the_old_key(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert NEW in text and OLD in text


def test_can_log_format_error_keeps_its_old_name() -> None:
    from skinframes import cantrace, errors
    from skinframes.canbus import log

    assert errors.TraceFormatError is errors.CanLogFormatError
    assert log.TraceFormatError is log.CanLogFormatError is errors.CanLogFormatError
    assert cantrace.TraceFormatError is errors.CanLogFormatError
    with pytest.raises(errors.TraceFormatError, match="unknown CAN log format"):
        log.can_log_format("skin.unknown_suffix")
