"""The command line keeps the conventions of the tools its users know (issue "A newcomer's day",
item "Pipes and conventions"; docs/interface.md, Conventions).

Expected values come from outside the code under test: the version from pyproject.toml, the
alias's meaning from the same run under the protocol's own name, pipes from tshark reading them.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from skinframes_cli import build_parser

ROOT = Path(__file__).resolve().parent.parent


def skinframes(*argv: str, stdin: bytes | None = None) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(
        [sys.executable, "-m", "skinframes", *argv],
        input=stdin,
        capture_output=True,
        timeout=300,
        check=False,
        cwd=ROOT,
    )


# --- --version ------------------------------------------------------------------------------------
def test_version_prints_the_packaged_version() -> None:
    pyproject = (ROOT / "pyproject.toml").read_text()
    version = re.search(r'^version = "([^"]+)"$', pyproject, re.MULTILINE)
    assert version
    result = skinframes("--version")
    assert result.returncode == 0, result.stderr
    assert result.stdout.decode() == f"skinframes {version.group(1)}\n"
    assert result.stderr == b""


# --- ethercat is ecat ------------------------------------------------------------------------------
def test_simulate_ethercat_is_simulate_ecat() -> None:
    runs = [
        skinframes("simulate", name, "--nodes", "3", "--bytes", "8", "--cycles", "2", "--json")
        for name in ("ecat", "ethercat")
    ]
    for r in runs:
        assert r.returncode == 0, r.stderr
    docs = [json.loads(r.stdout) for r in runs]
    assert docs[0]["protocol"] == "ecat"
    assert docs[1] == docs[0]


@pytest.mark.parametrize(
    ("argv", "dest"),
    [
        (["simulate", "ethercat", "--nodes", "1", "--bytes", "1"], "protocol"),
        (["serve", "ethercat", "--iface", "x", "--nodes", "1", "--bytes", "1"], "protocol"),
        (["can", "convert", "x.asc", "--to", "ethercat", "--pcap", "x.pcap"], "target"),
    ],
)
def test_every_protocol_argument_takes_ethercat(argv: list[str], dest: str) -> None:
    assert getattr(build_parser().parse_args(argv), dest) == "ecat"


@pytest.mark.parametrize("name", ["EtherCAT", "ether", "epl2"])
def test_other_protocol_names_stay_usage_errors(name: str) -> None:
    result = skinframes("simulate", name, "--nodes", "1", "--bytes", "1")
    assert result.returncode == 2 and result.stdout == b""
    (line,) = result.stderr.decode().splitlines()
    assert line.startswith("skinframes: error: ")


# --- `-` is standard output for a capture ----------------------------------------------------------
SIM = ["simulate", "ecat", "--nodes", "3", "--bytes", "8", "--closed-ring", "--cycles", "3"]
PCAPNG_SHB = b"\x0a\x0d\x0d\x0a"  # draft-ietf-opsawg-pcapng 4.1: Section Header Block type


def test_simulate_pcap_dash_streams_the_file_bytes_to_stdout(tmp_path: Path) -> None:
    """The stream is byte for byte the .pcapng the same run writes to a file, and nothing else
    (the report moves to stderr)."""
    piped = skinframes(*SIM, "--pcap", "-", "--json")
    assert piped.returncode == 0, piped.stderr
    path = tmp_path / "same.pcapng"
    filed = skinframes(*SIM, "--pcap", str(path), "--json")
    assert filed.returncode == 0, filed.stderr
    assert piped.stdout[:4] == PCAPNG_SHB
    assert piped.stdout == path.read_bytes()
    report = json.loads(piped.stderr)
    assert report["pcap"] == "-"
    assert {k: v for k, v in report.items() if k != "pcap"} == {
        k: v for k, v in json.loads(filed.stdout).items() if k != "pcap"
    }
    assert not (ROOT / "-").exists() and not (tmp_path / "-").exists()


def test_tshark_reads_the_stream_from_a_pipe(tshark: str) -> None:
    """``skinframes simulate ... --pcap - | tshark -r -``: every frame, no warning, both ports."""
    sim = subprocess.Popen(
        [sys.executable, "-m", "skinframes", *SIM, "--pcap", "-", "--json"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    shark = subprocess.run(
        [tshark, "-n", "-r", "-", "-T", "fields", "-e", "frame.interface_name", "-e", "_ws.malformed",
         "-e", "_ws.expert.severity"],
        stdin=sim.stdout,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )  # fmt: skip
    assert sim.stdout is not None
    sim.stdout.close()
    assert sim.wait(timeout=300) == 0
    frames = json.loads(sim.stderr.read())["frames"]  # type: ignore[union-attr]
    assert shark.returncode == 0, shark.stderr
    rows = [line.split("\t") for line in shark.stdout.splitlines()]
    assert len(rows) == frames == 2 * 3 * 2  # 2 ports x 3 cycles x (sent, arrived at the other)
    assert {r[0] for r in rows} == {"master port 0", "master port 1"}
    assert all(r[1] == "" and r[2] == "" for r in rows)  # not malformed, no expert item


def test_a_reader_that_leaves_ends_the_stream_quietly() -> None:
    """``--pcap - | head -c 100``: exit 0 (docs/interface.md: a reader that goes away), no
    traceback, no error line, and no file named ``-``."""
    sim = subprocess.Popen(
        [sys.executable, "-m", "skinframes", *SIM[:-1], "200000", "--pcap", "-"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert sim.stdout is not None and sim.stderr is not None
    head = sim.stdout.read(100)
    sim.stdout.close()
    assert sim.wait(timeout=300) == 0
    assert head[:4] == PCAPNG_SHB
    assert sim.stderr.read() == b""
    assert not (ROOT / "-").exists()


def test_a_capture_is_not_written_to_a_terminal() -> None:
    import os
    import pty

    leader, follower = pty.openpty()
    try:
        result = subprocess.run(
            [sys.executable, "-m", "skinframes", *SIM, "--pcap", "-"],
            cwd=ROOT,
            stdout=follower,
            stderr=subprocess.PIPE,
            timeout=300,
            check=False,
        )
    finally:
        os.close(follower)
        os.close(leader)
    assert result.returncode == 2
    (line,) = result.stderr.decode().splitlines()
    assert line.startswith("skinframes: error: --pcap -: standard output is a terminal")


def test_can_convert_pcap_dash_streams_the_file_bytes(tmp_path: Path) -> None:
    from skinframes.canbus import TimedSample, TriangleSample, sample_frames
    from skinframes.canbus.log import write_can_log

    log = tmp_path / "skin.asc"
    samples = [TimedSample(i * 50_000_000, TriangleSample(14, t, (t,) * 12), i * 50_000_000 + 130_000)
               for i in range(3) for t in range(16)]  # fmt: skip
    write_can_log(log, sorted(sample_frames(samples), key=lambda f: f.time_ns))
    path = tmp_path / "same.pcapng"
    argv = ["can", "convert", str(log), "--to", "ethercat"]
    filed = skinframes(*argv, "--pcap", str(path))
    piped = skinframes(*argv, "--pcap", "-")
    assert filed.returncode == piped.returncode == 0, piped.stderr
    assert piped.stdout == path.read_bytes()
    assert piped.stderr.decode().startswith("3 samples of 1 boards")


def test_analyze_reads_standard_input(tmp_path: Path) -> None:
    path = tmp_path / "x.pcapng"
    assert skinframes(*SIM, "--pcap", str(path)).returncode == 0
    piped = skinframes("analyze", "-", "--json", stdin=path.read_bytes())
    filed = skinframes("analyze", str(path), "--json")
    assert piped.returncode == filed.returncode == 0, piped.stderr
    a, b = json.loads(piped.stdout), json.loads(filed.stdout)
    assert a.pop("path") == "-" and b.pop("path") == str(path)
    assert a == b


class _FakeSocket:
    """emulator.live.RawSocket's interface for serve: ``frames`` received, then SIGINT."""

    def __init__(self, frames: list[bytes]) -> None:
        import socket

        self.inbox = list(frames)
        self.r, self.w = socket.socketpair()
        self.w.send(b"x")  # always readable

    def __enter__(self) -> _FakeSocket:
        return self

    def __exit__(self, *exc: object) -> None:
        self.r.close()
        self.w.close()

    def fileno(self) -> int:
        return self.r.fileno()

    def receive(self) -> tuple[bytes, int] | None:
        if not self.inbox:
            import signal

            signal.raise_signal(signal.SIGINT)  # serve's own handler: stop serving
            return None
        frame = self.inbox.pop(0)
        return frame, len(frame)

    def send(self, frame: bytes) -> None:
        pass


def test_serve_pcap_dash_streams_every_frame_and_reports_on_stderr(
    monkeypatch: pytest.MonkeyPatch, capsysbinary: pytest.CaptureFixture[bytes], tshark: str,
    tmp_path: Path,
) -> None:  # fmt: skip
    """``serve ecat --pcap -``: the frames in and out as a pcapng on stdout (tshark reads it:
    two BRDs in, two answers out), the summary on stderr; a stand-in socket, no root needed."""

    import emulator.live
    from skinframes import ethercat
    from skinframes.ethercat import Command, Datagram, EcatFrame
    from skinframes_cli import main

    brd = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x0130, bytes(2)),))).to_bytes()

    monkeypatch.setattr(emulator.live, "RawSocket", lambda iface: _FakeSocket([brd, brd]))
    argv = ["serve", "ethercat", "--iface", "fake0", "--nodes", "2", "--bytes", "4"]
    assert main([*argv, "--pcap", "-", "--json"]) == 0
    out, err = capsysbinary.readouterr()
    summary = json.loads(err.splitlines()[-1])  # after the "serving ..." line
    assert summary["frames_in"] == 2 and summary["pcap"] == "-"
    path = tmp_path / "served.pcapng"
    path.write_bytes(out)
    from tshark_util import fields

    rows = fields(tshark, path, ["ecat.cmd", "frame.p2p_dir", "ecat.cnt"])
    got = [tuple(int(r[n][0], 0) for n in ("ecat.cmd", "frame.p2p_dir", "ecat.cnt")) for r in rows]
    # BRD 0x07 in (p2p_dir 1: received) with WKC 0, out (0: sent) with 1 per slave
    assert got == [(0x07, 1, 0), (0x07, 0, 2)] * 2


@pytest.mark.parametrize("again", [True, False], ids=["signal-again", "reader-reads"])
def test_serve_says_why_it_waits_for_the_reader_and_a_second_sigint_stops_it(
    again: bool, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``serve ecat --pcap -`` into a pipe whose reader does not read: the first SIGINT ends
    serving and serve waits to hand over its capture. A second SIGINT ends it at once, with 130
    and the interrupted line (it waited for the reader for as long as the reader waited);
    without one, serve says on stderr why it waits, and once the reader reads it ends as usual.
    A stand-in socket and stdout, no root needed; the stand-in reader reads after 60 s at the
    latest (serve without the second signal's effect then ends with 0; without the line, the
    reader waits for it that long)."""
    import io
    import os
    import signal
    import threading

    import emulator.live
    import skinframes_cli.serve
    from skinframes import ethercat
    from skinframes.ethercat import Command, Datagram, EcatFrame
    from skinframes.helper_threads import leave_signals_to_main
    from skinframes_cli import main

    brd = ethercat.frame(EcatFrame((Datagram(Command.BRD, 0, 0x0130, bytes(2)),))).to_bytes()
    entered, release, noted = threading.Event(), threading.Event(), threading.Event()
    masks: list[set[signal.Signals]] = []
    note = "stopping: the capture is not all written yet, waiting for its reader; "

    class Unread(io.RawIOBase):  # a pipe's writing end whose reader reads when released
        def writable(self) -> bool:
            return True

        def write(self, data: object) -> int:
            masks.append(signal.pthread_sigmask(signal.SIG_BLOCK, []))  # the writer's
            entered.set()
            release.wait(60)
            return len(memoryview(data))  # type: ignore[arg-type]

    class Stdout:
        buffer = Unread()

        def isatty(self) -> bool:
            return False

        def flush(self) -> None:
            pass

    class Stderr:  # capsys's, and whether the line came
        def __init__(self, stream: object) -> None:
            self.stream = stream

        def write(self, text: str) -> int:
            if text.startswith(note):
                noted.set()
            return self.stream.write(text)  # type: ignore[attr-defined, no-any-return]

        def flush(self) -> None:
            self.stream.flush()  # type: ignore[attr-defined]

    def second() -> None:  # once the capture's thread is inside its write
        leave_signals_to_main()  # (the kernel gives the signal to a thread that takes it)
        if not entered.wait(60):
            return
        if again:
            os.kill(os.getpid(), signal.SIGINT)
        elif noted.wait(60):
            release.set()

    monkeypatch.setattr(emulator.live, "RawSocket", lambda iface: _FakeSocket([brd, brd]))
    monkeypatch.setattr("sys.stdout", Stdout())
    monkeypatch.setattr("sys.stderr", Stderr(sys.stderr))
    if not again:
        monkeypatch.setattr(skinframes_cli.serve, "CLOSE_NOTE_S", 0.0)  # (the line at once)
    sender = threading.Thread(target=second, daemon=True)
    sender.start()
    try:
        code = main(["serve", "ecat", "--iface", "fake0", "--nodes", "2", "--bytes", "4",
                     "--pcap", "-"])  # fmt: skip
    finally:
        release.set()
        sender.join()
    # the capture's thread blocks them: a signal it took would not end a wait for it
    assert masks and all({signal.SIGINT, signal.SIGTERM} <= mask for mask in masks)
    lines = capsys.readouterr().err.splitlines()
    if again:
        assert code == 130
        assert lines[-1] == "skinframes: interrupted (SIGINT); no file was left half-written"
        return
    assert code == 0
    assert lines[1] == note + "SIGINT/SIGTERM again drops the rest and stops at once"
    assert lines[2].startswith("served 2 of 2 frames")


# --- -q/--quiet: information off, errors on ------------------------------------------------------
def _skin_log(tmp_path: Path) -> Path:
    from skinframes.canbus import TimedSample, TriangleSample, sample_frames
    from skinframes.canbus.log import write_can_log

    log = tmp_path / "skin.asc"
    samples = [TimedSample(i * 50_000_000, TriangleSample(14, t, (t,) * 12), i * 50_000_000 + 130_000)
               for i in range(3) for t in range(16)]  # fmt: skip
    write_can_log(log, sorted(sample_frames(samples), key=lambda f: f.time_ns))
    return log


@pytest.mark.parametrize("flag", ["-q", "--quiet"])
def test_quiet_drops_the_information_and_keeps_the_results(tmp_path: Path, flag: str) -> None:
    log = _skin_log(tmp_path)
    capture = tmp_path / "x.pcap"
    assert (
        skinframes(*SIM[:2], "--nodes", "2", "--bytes", "4", "--pcap", str(capture)).returncode == 0
    )
    for argv in (["can", "decode", str(log)], ["decode", str(capture)], ["check", str(capture)]):
        loud = skinframes(*argv)
        info = loud.stderr.decode().splitlines()
        assert info and not any(line.startswith("skinframes: error:") for line in info)
        # before the command, and (new) after it, as users type it
        for quiet in (skinframes(flag, *argv), skinframes(*argv, flag)):
            assert loud.returncode == quiet.returncode == 0, quiet.stderr
            assert quiet.stdout == loud.stdout
            assert quiet.stderr == b""


def test_quiet_keeps_the_error_line() -> None:
    result = skinframes("-q", "decode", str(ROOT / "no-such.pcap"))
    assert result.returncode == 2 and result.stdout == b""
    (line,) = result.stderr.decode().splitlines()
    assert line.startswith("skinframes: error: ")


def test_debug_after_the_command_shows_the_traceback() -> None:
    result = skinframes("decode", str(ROOT / "no-such.pcap"), "--debug")
    assert result.returncode == 1  # Python's own exit for an exception that escaped
    assert b"Traceback (most recent call last)" in result.stderr
    assert b"PcapFormatError" in result.stderr


# --- output folders: one rule ---------------------------------------------------------------------
def _folder_argv(command: str, folder: Path, capture: Path) -> list[str]:
    return {
        "vectors": ["vectors", "--out", str(folder)],
        "analyze": ["analyze", str(capture), "--csv", str(folder)],
        "demo": ["demo", "--out", str(folder), "--no-plot"],
    }[command]


@pytest.fixture(scope="module")
def epl_capture(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cap") / "epl.pcap"
    assert (
        skinframes(
            "simulate", "epl", "--nodes", "2", "--bytes", "4", "--pcap", str(path)
        ).returncode
        == 0
    )
    return path


@pytest.mark.parametrize("command", ["vectors", "analyze"])
def test_a_missing_output_folder_is_created_when_its_parent_exists(
    tmp_path: Path, command: str, epl_capture: Path
) -> None:
    folder = tmp_path / "new"
    result = skinframes(*_folder_argv(command, folder, epl_capture))
    assert result.returncode == 0, result.stderr
    written = {p.name for p in folder.iterdir()}
    assert written >= ({"vectors.pcap", "vectors.jsonl"} if command == "vectors" else
                       {"config.csv", "epl_soc_period.csv", "epl_nodes.csv"})  # fmt: skip


@pytest.mark.parametrize("command", ["vectors", "analyze", "demo"])
@pytest.mark.parametrize("case", ["missing-parent", "a-file"])
def test_output_folders_are_refused_alike(
    tmp_path: Path, command: str, case: str, epl_capture: Path
) -> None:
    if case == "missing-parent":
        folder = tmp_path / "no" / "such"
        expected = f"skinframes: error: {folder}: directory {folder.parent} does not exist"
    else:
        folder = tmp_path / "plain"
        folder.write_text("mine")
        expected = f"skinframes: error: {folder}: exists and is not a directory"
    result = skinframes(*_folder_argv(command, folder, epl_capture))
    assert result.returncode == 2 and result.stdout == b""
    assert result.stderr.decode().splitlines() == [expected]
    assert not (tmp_path / "no").exists()
    if case == "a-file":
        assert folder.read_text() == "mine"


FILE_ONLY = [  # outputs no pipe carries (folders, pictures, numpy files)
    ["decode", "CAPTURE", "--taxels", "-"],
    ["analyze", "CAPTURE", "--csv", "-"],
    ["analyze", "CAPTURE", "--plot", "-"],
    ["compare", "skin.asc", "--plot", "-"],
    ["plot", "--out", "-"],
    ["demo", "--no-plot", "--out", "-"],
    ["vectors", "--out", "-"],
]


@pytest.mark.parametrize("argv", FILE_ONLY, ids=[" ".join(a[::2]) for a in FILE_ONLY])
def test_file_only_outputs_refuse_dash_when_the_arguments_are_read(
    argv: list[str],
    tmp_path: Path,
    epl_capture: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from skinframes_cli import main

    monkeypatch.chdir(tmp_path)
    assert main([str(epl_capture) if a == "CAPTURE" else a for a in argv]) == 2
    captured = capsys.readouterr()
    option = argv[-2]
    assert captured.err.splitlines() == [
        f"skinframes: error: argument {option}: '-': this output is written to files only, "
        f"not to standard output (./- names a file called -) (see 'skinframes {argv[0]} --help')"
    ]
    assert captured.out == "" and not (tmp_path / "-").exists()


EMPTY_INPUTS = [  # every file a command reads: "" is refused by its option type
    (["decode", ""], "PATH"),
    (["check", ""], "PATH"),
    (["analyze", ""], "PATH"),
    (["watch", ""], "PATH"),
    (["sii", ""], "FILE"),
    (["can", "decode", ""], "LOG"),
    (["can", "convert", "", "--to", "ecat", "--pcap", "o.pcap"], "LOG"),
    (["compare", ""], "LOG"),
    (["simulate", "ecat", "--nodes", "1", "--bytes", "4", "--esi", ""], "--esi"),
    (["simulate", "ecat", "--nodes", "1", "--bytes", "4", "--esi-inputs", ""], "--esi-inputs"),
    (["serve", "ecat", "--iface", "lo", "--nodes", "1", "--bytes", "4", "--esi", ""], "--esi"),
    (["serve", "epl", "--mn", "--iface", "lo", "--cdc", ""], "--cdc"),
]


@pytest.mark.parametrize(("argv", "name"), EMPTY_INPUTS, ids=[n for _, n in EMPTY_INPUTS])
def test_an_empty_input_name_is_refused_naming_the_argument(
    argv: list[str],
    name: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from skinframes_cli import main

    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    prog = " ".join(argv[: 2 if argv[0] == "can" else 1])
    assert capsys.readouterr().err.splitlines() == [
        f"skinframes: error: argument {name}: an empty file name (see 'skinframes {prog} --help')"
    ]


# --- a huge pcap is refused before it is written ---------------------------------------------------
BIG = ["simulate", "ecat", "--nodes", "160", "--bytes", "192", "--closed-ring"]


def test_a_pcap_estimated_above_4_gb_needs_allow_large_pcap(tmp_path: Path) -> None:
    one = tmp_path / "one.pcap"
    assert skinframes(*BIG, "--cycles", "1", "--pcap", str(one)).returncode == 0
    big = tmp_path / "big.pcap"
    result = skinframes(*BIG, "--cycles", "1000000", "--pcap", str(big))
    assert result.returncode == 2 and result.stdout == b""
    (line,) = result.stderr.decode().splitlines()
    gb = one.stat().st_size * 1_000_000 / 1e9  # what a million of these cycles would take
    assert line == (
        f"skinframes: error: --pcap {big}: about {gb:.1f} GB (1000000 cycles of "
        f"{one.stat().st_size} bytes), more than 4 GB; --allow-large-pcap writes it"
    )
    assert list(tmp_path.iterdir()) == [one]  # nothing written, no temporary file


def test_allow_large_pcap_and_a_stream_skip_the_estimate() -> None:
    from skinframes_cli.simulate import check_pcap_size

    def must_not_run(**kw: object) -> None:
        raise AssertionError("estimated although it need not be")

    check_pcap_size("x.pcap", 10**6, True, 2, must_not_run)  # --allow-large-pcap
    check_pcap_size("-", 10**6, False, 2, must_not_run)  # a pipe: the reader stops it
    argv = ["simulate", "epl", "--nodes", "1", "--bytes", "1", "--allow-large-pcap"]
    assert build_parser().parse_args(argv).allow_large_pcap is True


def test_the_estimate_names_the_users_pcap_in_its_errors(tmp_path: Path) -> None:
    """Every frame across link 0 corrupted: the one-cycle estimate already meets a CRC mark a
    classic pcap cannot carry, and its error names the user's file, not the byte counter's -."""
    bits = tmp_path / "bits.pcap"
    argv = ["simulate", "ecat", "--nodes", "2", "--bytes", "8", "--fault", "biterr:0:1"]
    result = skinframes(*argv, "--cycles", "2", "--pcap", str(bits))
    assert result.returncode == 2 and result.stdout == b""
    assert result.stderr.decode().splitlines() == [
        f"skinframes: error: {bits}: classic pcap cannot carry CRC marks or comments; "
        "name the file .pcapng"
    ]
    assert list(tmp_path.iterdir()) == []  # nothing written, no temporary file


# --- information is not prefixed like an error ----------------------------------------------------
ESI = b"""<?xml version="1.0"?>
<EtherCATInfo><Vendor><Id>2</Id><Name>Two</Name></Vendor><Descriptions><Devices>
<Device><Type ProductCode="#x10" RevisionNo="1">A-1</Type><Name>first</Name>
<Eeprom><ByteSize>256</ByteSize></Eeprom></Device></Devices></Descriptions></EtherCATInfo>
"""


def test_no_information_line_starts_like_an_error(tmp_path: Path) -> None:
    log = _skin_log(tmp_path)
    capture = tmp_path / "x.pcap"
    esi = tmp_path / "a.xml"
    esi.write_bytes(ESI)
    runs = [
        [*SIM[:2], "--nodes", "2", "--bytes", "192", "--pcap", str(capture)],
        ["decode", str(capture)],
        ["decode", str(capture), "--taxels", str(tmp_path / "t.npy")],
        ["check", str(capture)],
        ["analyze", str(capture)],
        ["can", "decode", str(log)],
        ["can", "convert", str(log), "--to", "ecat", "--pcap", str(tmp_path / "c.pcap")],
        ["compare", str(log)],
        ["wireshark-plugin", "--out", str(tmp_path / "s.lua")],
        ["sii", str(esi), "--out", str(tmp_path / "a.bin")],
        ["vectors", "--out", str(tmp_path / "v")],
    ]
    for argv in runs:
        result = skinframes(*argv)
        assert result.returncode == 0, (argv, result.stderr)
        lines = result.stderr.decode().splitlines()
        assert not [line for line in lines if line.startswith("skinframes")], (argv, lines)
    # the lines a script matched keep their words after the prefix (docs/interface.md)
    decoded = skinframes("decode", str(capture))
    n = _pcap_records(capture.read_bytes())
    assert decoded.stderr.decode().splitlines()[-1] == f"{n} records: {n} decoded, 0 skipped"


def _pcap_records(data: bytes) -> int:
    """Records of a classic pcap, walked by its headers (24-byte file header, 16-byte record
    header whose third word is the captured length; little-endian here)."""
    import struct

    at, n = 24, 0
    while at < len(data):
        (incl,) = struct.unpack_from("<I", data, at + 8)
        at, n = at + 16 + incl, n + 1
    return n


# --- - is stdout for every output a pipe carries, stdin for every input ---------------------------
def test_wireshark_plugin_and_sii_out_dash_write_to_stdout(tmp_path: Path) -> None:
    lua = tmp_path / "s.lua"
    assert skinframes("wireshark-plugin", "--out", str(lua)).returncode == 0
    piped = skinframes("wireshark-plugin", "--out", "-")
    assert piped.returncode == 0 and piped.stdout == lua.read_bytes() and piped.stderr == b""
    esi = tmp_path / "a.xml"
    esi.write_bytes(ESI)
    image = tmp_path / "a.bin"
    assert skinframes("sii", str(esi), "--out", str(image)).returncode == 0
    piped = skinframes("sii", "-", "--out", "-", stdin=ESI)  # ESI from stdin, image to stdout
    assert piped.returncode == 0, piped.stderr
    assert piped.stdout == image.read_bytes()
    decoded_file = skinframes("sii", str(image), "--json")
    decoded_pipe = skinframes("sii", "-", "--json", stdin=image.read_bytes())
    assert decoded_pipe.returncode == 0 and decoded_pipe.stdout == decoded_file.stdout
    assert not (ROOT / "-").exists()


def test_can_logs_and_taxels_read_standard_input(tmp_path: Path) -> None:
    log = _skin_log(tmp_path)
    from_file = skinframes("can", "decode", str(log), "--json")
    from_pipe = skinframes("can", "decode", "-", "--log-format", "asc", "--json",
                           stdin=log.read_bytes())  # fmt: skip
    assert from_pipe.returncode == 0, from_pipe.stderr
    assert from_pipe.stdout == from_file.stdout and from_pipe.stderr == from_file.stderr
    cmp_file = skinframes("compare", str(log), "--json")
    cmp_pipe = skinframes("compare", "-", "--log-format", "asc", "--json", stdin=log.read_bytes())
    assert cmp_pipe.returncode == 0 and cmp_pipe.stdout == cmp_file.stdout
    garbage = skinframes("can", "decode", "-", "--log-format", "asc", stdin=b"garbage\n")
    assert garbage.returncode == 2  # the error names the input as given, not its copy
    assert garbage.stderr.decode().startswith("skinframes: error: -: not a readable .asc CAN log")
    bare = skinframes("can", "decode", "-", stdin=log.read_bytes())
    assert bare.returncode == 2
    assert bare.stderr.decode().splitlines() == [
        "skinframes: error: LOG -: standard input has no suffix; --log-format FMT names it"
    ]
    capture = tmp_path / "x.pcap"
    assert (
        skinframes(*SIM[:2], "--nodes", "2", "--bytes", "192", "--pcap", str(capture)).returncode
        == 0
    )
    a, b = tmp_path / "a.npy", tmp_path / "b.npy"
    assert skinframes("decode", str(capture), "--taxels", str(a)).returncode == 0
    piped = skinframes("decode", "-", "--taxels", str(b), stdin=capture.read_bytes())
    assert piped.returncode == 0, piped.stderr
    assert a.read_bytes() == b.read_bytes()


def test_decode_taxels_of_a_capture_without_skin_data_is_an_error(
    tmp_path: Path, shared_captures: Path
) -> None:
    # real terminals' start-up and cyclic data (SOURCES.md): no 16 x 12 taxels anywhere; it
    # used to give 255 samples, every one missing, and exit 0
    capture = shared_captures / "ethercrab_replay-ek1100-el2828-el2889.pcapng"
    out = tmp_path / "t.npy"
    result = skinframes("decode", str(capture), "--taxels", str(out))
    assert result.returncode == 2
    (line,) = result.stderr.decode().splitlines()
    assert line.startswith("skinframes: error: capture of 3578 records: no skin taxels: "), line
    assert "nothing written" in line
    assert list(tmp_path.iterdir()) == []


# --- can convert: the size estimate of simulate --------------------------------------------------
def test_can_convert_refuses_a_pcap_over_the_limit_before_writing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from skinframes_cli import main, simulate

    log = _skin_log(tmp_path)  # 3 samples of one board
    one = tmp_path / "one.pcap"  # one cycle of the same network, written by simulate
    assert skinframes("simulate", "ecat", "--nodes", "1", "--bytes", "192", "--cycles", "1",
                      "--pcap", str(one)).returncode == 0  # fmt: skip
    monkeypatch.setattr(simulate, "LARGE_PCAP_BYTES", 2 * one.stat().st_size)
    out = tmp_path / "c.pcap"
    assert main(["can", "convert", str(log), "--to", "ecat", "--pcap", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    gb = 3 * one.stat().st_size / 1e9
    assert line == (
        f"skinframes: error: --pcap {out}: about {gb:.1f} GB (3 cycles of {one.stat().st_size} "
        f"bytes), more than {2 * one.stat().st_size / 1e9:g} GB; --allow-large-pcap writes it"
    )
    assert not out.exists()
    argv = ["can", "convert", str(log), "--to", "ecat", "--pcap", str(out), "--allow-large-pcap"]
    assert main(argv) == 0 and out.exists()


@pytest.mark.tshark
@pytest.mark.parametrize(
    ("name", "count"),
    [("ethercrab_replay-ek1100-el2828-el2889.pcapng", 500), ("epl-viz_EPL_Example.cap", 77)],
)
@pytest.mark.parametrize("command", ["check", "analyze"])
def test_count_on_a_file_reads_its_first_frames_as_tshark_c(
    tshark: str, shared_captures: Path, tmp_path: Path, name: str, count: int, command: str
) -> None:
    """``-c N`` on a file: the report of the first N frames, the same as of the file tshark
    writes with ``-c N`` (same format: ``-F``), stdin too."""
    path = shared_captures / name
    first = tmp_path / ("first" + path.suffix)
    fmt = "pcapng" if path.suffix == ".pcapng" else "pcap"
    done = subprocess.run([tshark, "-r", str(path), "-c", str(count), "-F", fmt, "-w", str(first)],
                          capture_output=True, timeout=120, check=False)  # fmt: skip
    assert done.returncode == 0, done.stderr

    def report(*argv: str, stdin: bytes | None = None) -> dict[str, object]:
        doc: dict[str, object] = json.loads(
            skinframes(command, *argv, "--json", stdin=stdin).stdout
        )
        doc.pop("path")
        return doc

    want = report(str(first))
    assert want["records"] == count
    assert report(str(path), "-c", str(count)) == want
    assert report("-", "--count", str(count), stdin=path.read_bytes()) == want
    assert report(str(path)) != want  # the whole file says more
