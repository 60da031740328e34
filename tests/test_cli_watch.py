"""``skinframes watch``: the terminal view in a pseudo-terminal, the plain lines in a pipe.

Expected figures come from the emulator's own accounting of the run that made the capture
(``simulate --json``: the cycle time, and the PRes its fault plan dropped per CN), never from
the monitor under test.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from pty_util import ROOT, Terminal


@pytest.fixture(scope="module")
def epl_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, object]]:
    """4 CNs x 192 bytes, 3000 cycles, 1 % of frames dropped on link 2 (CNs 3 and 4 behind it)."""
    path = tmp_path_factory.mktemp("watch") / "epl.pcap"
    argv = ["simulate", "epl", "--nodes", "4", "--bytes", "192", "--cycles", "3000",
            "--fault", "drop:2:0.01", "--seed", "1", "--pcap", str(path), "--json"]  # fmt: skip
    done = subprocess.run([sys.executable, "-m", "skinframes", *argv], capture_output=True,
                          text=True, timeout=300, check=True, cwd=ROOT)  # fmt: skip
    return path, json.loads(done.stdout)


def lost(doc: dict[str, object]) -> dict[int, int]:
    out = {}
    for line in doc["diagnosis"]:  # type: ignore[attr-defined]
        m = re.match(r"CN (\d+): (\d+) of \d+ PRes lost", line)
        if m:
            out[int(m[1])] = int(m[2])
    return out


def test_the_view_shows_the_emulators_figures_and_obeys_its_keys(
    epl_run: tuple[Path, dict[str, object]],
) -> None:
    path, run = epl_run
    term = Terminal("watch", str(path))
    screen = term.read_until("[end of capture]")
    period = run["cycle_us"]["median"]  # type: ignore[index]
    assert f"3000 cycles; SoC period median {period:.1f} us" in screen, screen
    rows = {int(m[1]): m for m in re.finditer(r"^ *(\d) +(\S+) +(\d+) +(\d+) ", screen, re.M)}
    assert set(rows) == {1, 2, 3, 4}
    assert {n: int(m[4]) for n, m in rows.items()} == {1: 0, 2: 0, **lost(run)}
    assert all(m[2] == "OPERATIONAL" and m[3] == "3000" for m in rows.values())
    assert "Taxels: triangles in contact per patch" in screen
    term.out = ""
    term.press("p")
    assert "[paused]" in term.read_until("[paused]")
    term.out = ""
    term.press("p")
    term.read_until("[end of capture]")
    term.press("q")
    assert term.wait() == 0
    assert "Traceback" not in term.out


def test_ctrl_c_ends_the_view_with_0(epl_run: tuple[Path, dict[str, object]]) -> None:
    path, _ = epl_run
    term = Terminal("watch", str(path), "--speed", "0.001")  # 380 ms of capture in 6 minutes
    term.read_until("[watching]")
    os.kill(term.pid, signal.SIGINT)
    assert term.wait() == 0
    assert "Traceback" not in term.out


def test_plain_lines_when_stdout_is_a_pipe(epl_run: tuple[Path, dict[str, object]]) -> None:
    path, run = epl_run
    done = subprocess.run(
        [sys.executable, "-m", "skinframes", "watch", str(path), "--speed", "0", "--interval",
         "0.1"], capture_output=True, text=True, timeout=300, check=False, cwd=ROOT,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    # 3000 cycles of 126.8 us: 0.38 s of capture time, a line at 0.1, 0.2 and 0.3 s, then the end
    # (by capture time, however fast the file is read)
    assert len(lines) == 4 and lines[-1].endswith("(end)") and "\x1b" not in done.stdout
    period = run["cycle_us"]["median"]  # type: ignore[index]
    assert f"epl: period {period:.1f} us" in lines[-1]
    assert f"4 CNs, missing {sum(lost(run).values())}, OPERATIONAL 4" in lines[-1]
    times = [float(line.split()[1]) for line in lines]
    assert times == sorted(times)


def test_ecat_plain_line(tmp_path: Path) -> None:
    path = tmp_path / "ecat.pcap"
    argv = ["simulate", "ecat", "--nodes", "8", "--bytes", "192", "--cycles", "50",
            "--pcap", str(path), "--json"]  # fmt: skip
    run = json.loads(subprocess.run([sys.executable, "-m", "skinframes", *argv],
                     capture_output=True, text=True, timeout=300, check=True, cwd=ROOT).stdout)  # fmt: skip
    done = subprocess.run([sys.executable, "-m", "skinframes", "watch", str(path), "--speed", "0"],
                          capture_output=True, text=True, timeout=300, check=True, cwd=ROOT)  # fmt: skip
    last = done.stdout.splitlines()[-1]
    assert f"period {run['cycle_us']['median']:.1f} us jitter 0.0 us" in last, last
    assert "sent 50 lost 0, wkc 1 deviations 0" in last
    assert "contact: " in last and " of 8 patches" in last


def test_closed_ring_in_classic_pcap_plain_line_is_analyzes(tmp_path: Path) -> None:
    """A closed ring in classic pcap (no interfaces): the second port's unprocessed copy is the
    return of its send, as analyze pairs it; every frame of a fault-free run returns."""
    path = tmp_path / "ring.pcap"
    argv = ["simulate", "ecat", "--nodes", "8", "--bytes", "192", "--closed-ring", "--cycles",
            "200", "--pcap", str(path)]  # fmt: skip
    subprocess.run([sys.executable, "-m", "skinframes", *argv], capture_output=True, timeout=300,
                   check=True, cwd=ROOT)  # fmt: skip
    analyzed = subprocess.run([sys.executable, "-m", "skinframes", "analyze", str(path), "--json"],
                              capture_output=True, text=True, timeout=300, check=True, cwd=ROOT)  # fmt: skip
    busiest = json.loads(analyzed.stdout)["ecat"]["patterns"][0]
    done = subprocess.run([sys.executable, "-m", "skinframes", "watch", str(path), "--speed", "0"],
                          capture_output=True, text=True, timeout=300, check=True, cwd=ROOT)  # fmt: skip
    last = done.stdout.splitlines()[-1]
    assert f"round trip {busiest['round_trip']['median_ns'] / 1000:.1f} us" in last, last
    assert "sent 200 lost 0, wkc 1 deviations 0" in last, last


def test_a_second_ctrl_c_ends_plain_lines_into_a_pipe_nobody_reads(
    epl_run: tuple[Path, dict[str, object]],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``--plain`` into a pipe that is full and whose reader does not read: the first Ctrl-C
    stops the reading and the command waits to write its lines; a second ends it at once, 130
    and the interrupted line (before, it waited for as long as the reader did). In process;
    the stand-in reader reads after 60 s at the latest, when a watch deaf to the second Ctrl-C
    ends with 0."""
    import fcntl
    import threading

    from skinframes.helper_threads import leave_signals_to_main
    from skinframes_cli import main, watch

    path, _ = epl_run
    r, w = os.pipe()
    fcntl.fcntl(w, fcntl.F_SETPIPE_SZ, 4096)
    assert os.write(w, bytes(4096)) == 4096  # full: no line of the watch gets in
    out = open(w, "w", encoding="utf-8")  # noqa: SIM115 (closed below, once the reader is done)
    monkeypatch.setattr("sys.stdout", out)
    started, halted, done = threading.Event(), threading.Event(), threading.Event()
    start, halt = watch.Feed.start, watch.Feed.halt

    def starting(feed: watch.Feed) -> None:  # (the watch's Ctrl-C handler is in place)
        start(feed)
        started.set()

    def halting(feed: watch.Feed) -> None:  # (called by the handler of the first Ctrl-C)
        halt(feed)
        halted.set()

    monkeypatch.setattr(watch.Feed, "start", starting)
    monkeypatch.setattr(watch.Feed, "halt", halting)

    def drain() -> None:
        while os.read(r, 1 << 16):
            pass

    def interrupt() -> None:
        leave_signals_to_main()  # (the kernel gives the signal to a thread that takes it)
        if started.wait(60):
            os.kill(os.getpid(), signal.SIGINT)
        if halted.wait(60):
            os.kill(os.getpid(), signal.SIGINT)
        if not done.wait(60):
            drain()

    sender = threading.Thread(target=interrupt, daemon=True)
    sender.start()
    try:
        code = main(["watch", str(path), "--plain", "--speed", "0", "--interval", "0.001"])
    finally:
        done.set()
        reader = threading.Thread(target=drain, daemon=True)
        reader.start()  # the reader reads at last: the feed's write returns, and it stops
        for thread in threading.enumerate():
            if thread.name == "watch-feed":
                thread.join(60)
        sender.join(60)
        out.close()
        reader.join(60)
        os.close(r)
    assert code == 130
    assert capsys.readouterr().err.splitlines()[-1] == (
        "skinframes: interrupted (SIGINT); no file was left half-written"
    )


def test_the_feed_leaves_sigint_and_sigterm_to_the_main_thread() -> None:
    """The reader thread blocks both: a Ctrl-C the kernel gave it would reach the main thread
    only once that thread next ran Python code, which a wait for a reader may put off for
    ever."""
    from skinframes_cli.watch import Feed

    masks: list[set[signal.Signals]] = []

    def records() -> Iterator[object]:  # read by the feed's thread
        masks.append(signal.pthread_sigmask(signal.SIG_BLOCK, []))
        yield from ()

    feed = Feed(records(), 0, None)
    feed.start()
    feed.thread.join(60)
    assert feed.error is None
    assert masks and {signal.SIGINT, signal.SIGTERM} <= masks[0]
    assert not {signal.SIGINT, signal.SIGTERM} & signal.pthread_sigmask(signal.SIG_BLOCK, [])


@pytest.mark.parametrize("how", ["cut", "gzip"])
def test_a_damaged_capture_reports_its_skipped_records(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, how: str
) -> None:
    """As analyze (and decode) report them: once, watch said nothing of the records lost."""
    from test_cli_analyze import damaged

    from skinframes.pcap import read_capture
    from skinframes_cli import main
    from skinframes_cli.watch import Feed, render

    path, whole, lost = damaged(capsys, tmp_path, how)
    assert main(["watch", str(path), "--speed", "0"]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[-1].startswith(f"t 0.000 s  frames {whole} ")
    lines = err.splitlines()
    assert [line.split(":")[0] for line in lines[:-1]] == [f"skipped frame {f}" for f in lost]
    assert lines[-1] == f"{whole + len(lost)} records: {whole} decoded, {len(lost)} skipped"
    feed = Feed(read_capture(path), 0, None)  # the view
    feed.start()
    feed.thread.join(60)
    doc = feed.snapshot()
    assert doc["skipped"] == len(lost)
    line = f"skipped: {len(lost)} records could not be read (listed on stderr at the end)"
    assert line in str(render(doc, str(path), paused=False, ended=True).renderables[1])
