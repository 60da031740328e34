"""``skinframes can decode`` and the CAN records of ``skinframes decode`` (docs/interface.md).

Expected values: the samples we put into the traces, the frame counts of the third-party logs
(can.md 3), and hand computation (a data frame of id 0 and DLC 0 is 47 + 6 stuff bits = 53).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from skinframes.canbus import CanFrame, TimedSample, TriangleSample, sample_frames
from skinframes.canbus.log import write_can_log
from skinframes_cli import main

ROOT = Path(__file__).resolve().parent.parent
SAMPLE_KEYS = {"time_ns", "board", "triangle", "taxels", "error", "out_of_range"}


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("skinframes: error: "), lines
    assert "Traceback" not in err
    return lines[0]


SAMPLES = [
    TimedSample(0, TriangleSample(14, 0, [240] * 12), 130_000),
    TimedSample(260_000, TriangleSample(14, 1, list(range(12)), 0x801, 2), 390_000),
    TimedSample(520_000, TriangleSample(13, 15, [0, 255] * 6, 0, 1), 650_000),
]


def skin_trace(tmp_path: Path, suffix: str, extra: list[CanFrame] | None = None) -> Path:
    frames = sample_frames(SAMPLES) + (extra or [])
    frames.sort(key=lambda f: f.time_ns)
    path = tmp_path / f"skin{suffix}"
    write_can_log(path, frames)
    return path


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf", ".trc", ".csv", ".pcap"])
def test_can_decode_json_lines(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], suffix: str
) -> None:
    extra = [CanFrame(0x064, b"\x01", time_ns=700_000), CanFrame(0x064, b"\x02", time_ns=800_000)]
    path = skin_trace(tmp_path, suffix, extra)
    code, out, err = run(["can", "decode", str(path), "--json"], capsys)
    assert code == 0
    objs = [json.loads(line) for line in out.splitlines()]
    assert all(o.keys() == SAMPLE_KEYS for o in objs)
    assert objs == [
        {
            "time_ns": s.time_ns,
            "board": s.sample.board,
            "triangle": s.sample.triangle,
            "taxels": list(s.sample.taxels),
            "error": s.sample.error,
            "out_of_range": s.sample.out_of_range,
        }
        for s in SAMPLES
    ]
    lines = err.splitlines()
    assert lines[0] == (
        "8 frames: 3 skin samples (6 frames), 2 not skin data, 0 error frames, "
        "0 orphan heads, 0 orphan tails, 0 malformed, 0 skipped"
    )
    assert lines[1] == "not skin data by id: 0x64: 2"


def test_can_decode_text(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["can", "decode", str(skin_trace(tmp_path, ".asc"))], capsys)
    assert code == 0
    lines = out.splitlines()
    assert len(lines) == 3
    assert "board 14 triangle  1  00 01 02 03 04 05 06 07 08 09 0a 0b" in lines[1]
    assert lines[1].endswith("error 2 out_of_range 0x801")


def test_can_decode_third_party_log(
    shared_captures: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = shared_captures / "can" / "logfile_errorframes.asc"
    code, out, err = run(["can", "decode", "--json", str(path)], capsys)
    assert code == 0 and out == ""
    lines = err.splitlines()
    assert lines[0].startswith("12 frames: 0 skin samples (0 frames), 9 not skin data")
    assert "3 error frames" in lines[0]
    assert lines[1] == ("not skin data by id: 0x18ebff00x: 6, 0x200: 1, 0x300: 1, 0x6f8: 1")


def test_can_decode_legacy_class_and_board_filter(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    legacy = [TimedSample(0, TriangleSample(9, 2, [1] * 12, skin_class=3), 130_000)]
    strain = CanFrame(0x3A0, bytes.fromhex("40 01 02 03 04 05 06 07"), time_ns=50_000)
    path = tmp_path / "legacy.log"
    write_can_log(path, sorted([*sample_frames(legacy), strain], key=lambda f: f.time_ns))
    code, out, _ = run(["can", "decode", "--json", str(path)], capsys)
    assert (code, out) == (0, "")  # class 4 by default
    code, out, err = run(
        ["can", "decode", "--json", "--skin-class", "3", "--boards", "7:9", str(path)], capsys
    )
    assert code == 0
    (obj,) = [json.loads(line) for line in out.splitlines()]
    assert (obj["board"], obj["triangle"], obj["taxels"]) == (9, 2, [1] * 12)
    assert "1 not skin data" in err.splitlines()[0]  # the strain gauge frame 0x3A0


def test_can_decode_reports_malformed_and_orphans(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (ident, head), (_, tail) = SAMPLES[0].sample.can_frames()
    frames = [
        CanFrame(ident, tail, time_ns=0),  # orphan tail
        CanFrame(ident, b"\x40\x00", time_ns=1),  # DLC 2
        CanFrame(ident, head, time_ns=2),  # orphan head at the end
    ]
    path = tmp_path / "bad.log"
    write_can_log(path, frames)
    code, out, err = run(["can", "decode", str(path)], capsys)
    assert code == 0 and out == ""
    lines = err.splitlines()
    assert "1 orphan heads, 1 orphan tails, 1 malformed" in lines[0]
    assert lines[1] == ("malformed skin frame 1 (0x4e0): DLC 2, skin frames have 8 data bytes")


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["can", "decode", "trace.txt"], "unknown CAN log format"),
        (["can", "decode", "missing.asc"], "cannot read"),
        (["can", "decode", "junk.log"], "not a readable .log CAN log"),
        (["can"], "CAN_COMMAND"),
        (["can", "decode"], "LOG"),
        (["can", "decode", "x.asc", "--skin-class", "5"], "invalid choice"),
        (["can", "frobnicate"], "invalid choice"),
    ],
)
def test_can_decode_bad_input(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    argv: list[str],
    needle: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "trace.txt").write_text("0.0 1 410 Rx d 8 40 00 00 00 00 00 00 00\n")
    (tmp_path / "junk.log").write_text("not candump at all\n")
    code, out, err = run(argv, capsys)
    assert code == 2 and out == ""
    assert needle in one_error_line(err)


@pytest.mark.parametrize(
    "argv",
    [
        ["can", "decode"],
        ["can", "convert", "--to", "epl", "--pcap", "out.pcap"],
        ["compare"],
    ],
)
@pytest.mark.parametrize("folder", ["logs", "logs.asc"])
def test_a_folder_as_can_log_is_said_to_be_one(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    argv: list[str],
    folder: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / folder).mkdir()
    code, out, err = run([*argv[:2], folder, *argv[2:]], capsys)
    assert code == 2 and out == ""
    assert one_error_line(err) == f"skinframes: error: {folder}: cannot read (is a directory)"
    assert not (tmp_path / "out.pcap").exists()


def test_python_m_skinframes_can_decode(tmp_path: Path) -> None:
    path = skin_trace(tmp_path, ".blf")
    result = subprocess.run(
        [sys.executable, "-m", "skinframes", "can", "decode", "--json", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert [json.loads(line)["triangle"] for line in result.stdout.splitlines()] == [0, 1, 15]


def test_decode_reports_socketcan_records_as_can(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    extra = [
        CanFrame(0, b"", time_ns=700_000),  # by hand: 47 + 6 stuff bits
        CanFrame(0x18EBFF00, b"\x01\x02", time_ns=710_000, extended=True),
        CanFrame(0x123, b"", time_ns=720_000, remote=True, dlc=5),
        CanFrame(0, b"", time_ns=730_000, error=True),
    ]
    path = skin_trace(tmp_path, ".pcap", extra)
    code, out, _ = run(["decode", "--json", str(path)], capsys)
    assert code == 0
    objs = [json.loads(line) for line in out.splitlines()]
    assert [o["protocol"] for o in objs] == ["can"] * 10
    first = objs[0]
    assert (first["can_id"], first["dlc"], first["data"], first["length"]) == (
        0x4E0,
        8,
        "40" + "f0" * 7,
        16,
    )
    assert (first["extended"], first["remote"], first["error_frame"], first["findings"]) == (
        False,
        False,
        False,
        [],
    )
    zero, ext, rtr, err = objs[6:]
    assert (zero["can_id"], zero["dlc"], zero["wire_bits"]) == (0, 0, 53)
    assert (ext["can_id"], ext["extended"], ext["data"]) == (0x18EBFF00, True, "0102")
    assert (rtr["can_id"], rtr["remote"], rtr["dlc"], rtr["data"]) == (0x123, True, 5, "")
    assert err["error_frame"] and err["wire_bits"] is None
    code, out, _ = run(["decode", str(path)], capsys)
    assert "CAN 4e0 data [8] 40 f0 f0" in out.splitlines()[0]
    assert "CAN 18ebff00 data [2] 01 02" in out.splitlines()[7]


def test_can_decode_of_a_capture_without_can_records_says_so_once(
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = Path(__file__).resolve().parent.parent / "pcaps" / "ecat_23_slaves.pcap"
    code, out, err = run(["can", "decode", str(path)], capsys)
    assert code == 2 and out == ""
    line = one_error_line(err)
    assert "no CAN frames" in line and "linktype 1 record, not SocketCAN" in line


def test_can_decode_reports_records_and_boards(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from can_hand_log import hand_built_log

    path = hand_built_log(tmp_path, ".asc")
    code, out, err = run(["can", "decode", str(path)], capsys)
    assert code == 0 and len(out.splitlines()) == 25
    lines = err.splitlines()
    header = 5 + 1  # date, base, internal events, Begin/End Triggerblock; Start of measurement
    assert f"{51 + header} records: 51 decoded, {header} skipped (" in err
    assert lines[-3:] == [
        "board 10: 0 complete samples (4 triangles), 1 incomplete, 0 stray frames",
        "board 13: 2 complete samples (4 triangles), 1 incomplete, 1 stray frames (0x4d2: 1)",
        "board 14: 3 complete samples (4 triangles), 0 incomplete, 2 stray frames (0x4e1: 2)",
    ]


def test_decode_lines_are_formatted_as_json_dumps_and_the_text_layout() -> None:
    from skinframes_cli.can import sample_json, sample_text

    s = TimedSample(
        1_234_567_891,
        TriangleSample(14, 3, [0, 1, 255, 16, 9, 10, 11, 12, 13, 14, 15, 240], 0xABC, 7),
        0,
    )
    assert sample_json(s) == json.dumps(s.to_json()) + "\n"
    assert sample_text(s) == (
        "       1.234567891  board 14 triangle  3  00 01 ff 10 09 0a 0b 0c 0d 0e 0f f0"
        "  error 7 out_of_range 0xabc\n"
    )


@pytest.mark.parametrize("suffix", [".asc", ".log", ".trc", ".csv", ".pcap"])
def test_can_decode_stdin_streams(tmp_path: Path, suffix: str) -> None:
    """``can decode -`` reads standard input as it comes: with the writer still there (no EOF),
    the first samples are out (each sample we put in, board 14, triangle t, taxels all t); at the
    end, what the same log gives as a file."""
    import select

    samples = [TimedSample(i * 50_000_000 + t * 260_000, TriangleSample(14, t, [t] * 12),
                           i * 50_000_000 + t * 260_000 + 130_000)
               for i in range(100) for t in range(16)]  # fmt: skip
    log = tmp_path / f"skin{suffix}"
    write_can_log(log, sample_frames(samples))
    data = log.read_bytes()
    proc = subprocess.Popen(
        [sys.executable, "-m", "skinframes", "can", "decode", "-", "--log-format", suffix, "--json"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT,
        bufsize=0,  # unbuffered: readline takes no more than the line, communicate the rest
    )  # fmt: skip
    assert proc.stdin is not None and proc.stdout is not None
    try:
        # the first 16 KiB of text (a pcap: 80 kB; its reader takes 64 KiB at a time), no more
        # than the pipes hold; the pipe stays open
        head = 80_000 if suffix == ".pcap" else 16384
        proc.stdin.write(data[:head])
        proc.stdin.flush()
        ready, _, _ = select.select([proc.stdout], [], [], 120)
        assert ready, "no sample before the end of the input"
        line = proc.stdout.readline()
        first = json.loads(line)
        assert (first["board"], first["triangle"], first["taxels"]) == (14, 0, [0] * 12)
        assert proc.poll() is None  # still reading: the input has not ended
        rest, err = proc.communicate(data[head:], timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    whole = subprocess.run([sys.executable, "-m", "skinframes", "can", "decode", str(log), "--json"],
                           capture_output=True, timeout=120, check=True, cwd=ROOT)  # fmt: skip
    assert line + rest == whole.stdout
    assert err == whole.stderr
    assert len(whole.stdout.splitlines()) == len(samples)
