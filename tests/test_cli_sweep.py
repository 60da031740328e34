"""``tables`` over large grids: cells beyond a protocol, --csv, nonsense values (exit 2), a
signal to the whole process group while the emulated model's workers run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from emulator.model.cycle_time import cycle_us
from emulator.model.params import WIRE
from skinframes_cli import main

ROOT = Path(__file__).resolve().parent.parent


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


def test_jobs_with_the_formulas_is_noted_as_ignored(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tables", "--nodes", "130", "--bytes", "2", "--jobs", "2"]) == 0
    assert capsys.readouterr().err == (
        "note: --jobs: with --model emulated only (the formulas run in one process); ignored\n"
    )
    assert (
        main(["tables", "--model", "emulated", "--nodes", "3", "--bytes", "2", "--jobs", "1"]) == 0
    )
    assert "note:" not in capsys.readouterr().err


def test_one_printed_cell_is_one_cell(capsys: pytest.CaptureFixture[str]) -> None:
    """130 nodes x 2 bytes is a cell of each of the paper's Tables I-III."""
    assert main(["tables", "--nodes", "130", "--bytes", "2"]) == 0
    assert capsys.readouterr().out.count("      1 cell printed in the paper; largest") == 3


def _workers(pid: int) -> list[int]:
    """The pool workers ``pid`` started (Linux /proc: its children that run spawn_main)."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            stat = (entry / "stat").read_text()
            ppid = int(stat.rpartition(")")[2].split()[1])
            if ppid == pid and b"spawn_main" in (entry / "cmdline").read_bytes():
                found.append(int(entry.name))
        except (OSError, ValueError):  # not a process, or one that ended meanwhile
            continue
    return found


def _still_running(pid: int) -> bool:
    """A worker that still runs (an exited one has no command line, an unknown pid no entry)."""
    try:
        return b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("moment", ["started", "computing"])
@pytest.mark.parametrize(
    ("sig", "line"),
    [
        (signal.SIGINT, "skinframes: interrupted (SIGINT); no file was left half-written"),
        (signal.SIGTERM, "skinframes: terminated (SIGTERM); no file was left half-written"),
    ],
)
def test_a_signal_to_the_whole_group_ends_the_emulated_workers_quietly(
    tmp_path: Path, moment: str, sig: signal.Signals, line: str
) -> None:
    """A Ctrl-C reaches the terminal's whole process group, the pool's workers too: they leave
    it to the command (one line, none of their tracebacks) and end with it, as they do for a
    SIGTERM to the group (a worker killed while it waited for a task left the lock behind that
    the pool's terminate() waited for). Sent as soon as both workers exist (still starting
    Python), or once their first rows are in the temporary file."""
    target = tmp_path / "grid.csv"
    target.write_text("previous")
    argv = [sys.executable, "-m", "skinframes", "tables", "--model", "emulated", "--nodes",
            "1:1000:1", "--bytes", "1:10:1", "--csv", str(target), "--jobs", "2"]  # fmt: skip
    proc = subprocess.Popen(
        argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    try:
        workers: list[int] = []
        while proc.poll() is None and len(workers) < 2:  # wait for the workers, not the clock
            workers = _workers(proc.pid)
            time.sleep(0.002)
        assert len(workers) == 2, "the run ended before its workers started"
        written = moment == "started"
        while proc.poll() is None and not written:
            written = any(p.stat().st_size for p in tmp_path.glob(".grid.csv.*.tmp"))
            time.sleep(0.002)
        os.killpg(proc.pid, sig)  # the whole group, as a terminal's Ctrl-C
        _out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 128 + sig, err
    assert err.decode().splitlines() == [line]
    assert [pid for pid in workers if _still_running(pid)] == []
    assert target.read_text() == "previous"
    assert list(tmp_path.iterdir()) == [target]
