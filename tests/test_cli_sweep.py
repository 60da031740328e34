"""``tables`` over large grids: cells beyond a protocol, --csv, nonsense values (exit 2)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from emulator.model.cycle_time import cycle_us
from emulator.model.params import WIRE
from skinframes_cli import main


def test_tables_beyond_epl_shows_not_applicable(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tables", "--preset", "wire", "--nodes", "1:240:1", "--bytes", "192"]) == 0
    out = capsys.readouterr().out
    assert "  240          n/a" in out and "n/a: EPL: 240 CNs (1..239)" in out
    assert (
        main(["tables", "--preset", "wire", "--nodes", "239:240", "--bytes", "192", "--json"]) == 0
    )
    doc = json.loads(capsys.readouterr().out)
    assert doc["epl"]["240"]["192"] is None
    assert doc["ecat"]["240"]["192"] == round(cycle_us("ecat", 240, 192, WIRE), 6)
    assert doc["not_applicable"] == {"epl": ["EPL: 240 CNs (1..239)"]}


def test_tables_csv_to_a_file_and_to_stdout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "t.csv"
    assert main(["tables", "--nodes", "3,4", "--bytes", "8,1487", "--csv", str(out)]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    lines = out.read_text().splitlines()
    assert lines[0] == "table,nodes,bytes,cycle_us,not_applicable"
    assert len(lines) == 1 + 3 * 2 * 2
    assert "ecat,4,1487,,EtherCAT: 1487 bytes per slave (1..1486)" in lines
    assert main(["tables", "--nodes", "3,4", "--bytes", "8,1487", "--csv"]) == 0
    assert capsys.readouterr().out.splitlines() == lines


@pytest.mark.parametrize(
    "argv",
    [
        ["tables", "--nodes", "0:3"],
        ["tables", "--bytes", "-4"],
        ["tables", "--bytes", "x"],
        ["tables", "--json", "--csv"],
        ["tables", "--csv", "/no/such/folder/t.csv"],
        ["tables", "--model", "emulated", "--jobs", "0"],
    ],
)
def test_nonsense_is_one_error_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    assert main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error:")
    assert captured.out == ""


def test_one_printed_cell_is_one_cell(capsys: pytest.CaptureFixture[str]) -> None:
    """130 nodes x 2 bytes is a cell of each of the paper's Tables I-III."""
    assert main(["tables", "--nodes", "130", "--bytes", "2"]) == 0
    assert capsys.readouterr().out.count("      1 cell printed in the paper; largest") == 3
