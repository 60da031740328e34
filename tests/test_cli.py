"""The ``skinframes`` command line as docs/interface.md promises it.

Exit 0 ok, 1 ``check`` found an error, 2 bad input or usage: then exactly one stderr line starting
with ``skinframes: error:`` and no traceback (unless ``--debug``). Results on stdout, diagnostics on
stderr; ``--json`` is one document, except ``decode --json`` which is JSON Lines.

Expected values come from pcaps/README.md (frame counts, timestamps 10 us apart from 0) and from
hand computation of the frame lengths.
"""

from __future__ import annotations

import argparse
import json
import re
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from skinframes import powerlink
from skinframes.errors import PcapFormatError
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, pcap_bytes
from skinframes.powerlink import PReq, PRes, SoA, SoC
from skinframes_cli import build_parser, main

ROOT = Path(__file__).resolve().parent.parent
PCAPS = ROOT / "pcaps"

# pcaps/README.md: frames per file; every file is stamped 0, 10 us, 20 us, ...
GOLDEN = {
    "epl_cycle_4cn.pcap": 10,
    "epl_asnd_services.pcap": 12,
    "ecat_lrd_7x192.pcap": 2,
    "ecat_23_slaves.pcap": 8,
    "ecat_all_commands.pcap": 15,
}
FRAME_KEYS = {"index", "time_ns", "length", "protocol", "findings"}


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """main(argv) -> (exit code, stdout, stderr); argparse's SystemExit counts as the exit code."""
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_error_line(err: str) -> None:
    lines = err.splitlines()
    assert len(lines) == 1, f"expected one stderr line, got {lines}"
    assert lines[0].startswith("skinframes: error: ")
    assert "Traceback" not in err


def epl_bytes(m: powerlink.EplMessage) -> bytes:
    return powerlink.frame(m).to_bytes()


@pytest.fixture
def capture_with_error(tmp_path: Path) -> Path:
    """SoC, PReq 1, PRes 1 whose Size field (u16 LE at EPL offset 8) says 192 with 8 bytes, SoA."""
    pres = bytearray(epl_bytes(PRes(1, bytes(8))))
    pres[14 + 8 : 14 + 10] = struct.pack("<H", 192)
    frames = [epl_bytes(SoC()), epl_bytes(PReq(1)), bytes(pres), epl_bytes(SoA())]
    path = tmp_path / "size_error.pcap"
    path.write_bytes(pcap_bytes([(i * 10_000, f) for i, f in enumerate(frames)]))  # no overlap
    return path


# --- decode ----------------------------------------------------------------------------------------
# 10 us apart, except where the sender's previous frame is still on the wire: a 1444-byte frame
# takes (8 + 1444 + 4) x 80 ns = 116.48 us, plus the 0.96 us gap (pcaps/README.md)
STAMPS_NS = {
    "ecat_23_slaves.pcap": [0, 117_440, 234_880, 352_320, 362_320, 479_760, 597_200, 714_640]
}


def stamp_ns(name: str, i: int) -> int:
    return STAMPS_NS[name][i] if name in STAMPS_NS else i * 10_000


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_decode_text(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["decode", str(PCAPS / name)], capsys)
    assert code == 0
    lines = out.splitlines()
    assert len(lines) == GOLDEN[name]
    for i, line in enumerate(lines):
        word, frame, seconds, length = line.split()[:4]
        assert (word, int(frame)) == ("frame", i + 1)  # Wireshark's frame.number, from 1
        assert float(seconds) == pytest.approx(stamp_ns(name, i) * 1e-9, abs=1e-9)
        assert int(length) >= 60
    assert err.splitlines() == [f"{GOLDEN[name]} records: {GOLDEN[name]} decoded, 0 skipped"]


def test_decode_text_names_the_messages(capsys: pytest.CaptureFixture[str]) -> None:
    _, out, _ = run(["decode", str(PCAPS / "epl_cycle_4cn.pcap")], capsys)
    kinds = [re.findall(r"\b(SOC|PREQ|PRES|SOA|ASND)\b", line) for line in out.splitlines()]
    assert kinds == [["SOC"]] + [["PREQ"], ["PRES"]] * 4 + [["SOA"]]


def _json_lines(out: str) -> list[dict[str, object]]:
    objs = [json.loads(line) for line in out.splitlines()]  # every stdout line is one JSON object
    assert all(isinstance(o, dict) for o in objs)
    return objs


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_decode_json_lines(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["decode", "--json", str(PCAPS / name)], capsys)
    assert code == 0
    objs = _json_lines(out)
    assert len(objs) == GOLDEN[name]
    for i, o in enumerate(objs):
        assert o.keys() >= FRAME_KEYS
        assert (o["index"], o["time_ns"]) == (i, stamp_ns(name, i))
        assert o["protocol"] == ("epl" if name.startswith("epl") else "ecat")
        assert o["findings"] == []
    assert len(err.splitlines()) == 1 and f"{GOLDEN[name]} records" in err  # the count line


def test_decode_json_lengths_hand_computed(capsys: pytest.CaptureFixture[str]) -> None:
    # EPL: SoC 22 / PReq 10 / SoA 10 bytes pad to 60; PRes = 14 + 10 + 192 = 216
    _, out, _ = run(["decode", "--json", str(PCAPS / "epl_cycle_4cn.pcap")], capsys)
    assert [o["length"] for o in _json_lines(out)] == [60] + [60, 216] * 4 + [60]
    # EtherCAT: 14 + 2 + 7 x (12 + 192) = 1444; the last frame of 23 carries 2: 14 + 2 + 408 = 424
    _, out, _ = run(["decode", "--json", str(PCAPS / "ecat_23_slaves.pcap")], capsys)
    assert [o["length"] for o in _json_lines(out)] == [1444, 1444, 1444, 424] * 2


def test_decode_json_real_capture_with_other_traffic(
    shared_captures: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # frames.md 5: 580 EtherCAT frames plus 14 IP/TLS frames; SOEM sends from a group MAC
    code, out, err = run(
        ["decode", "--json", str(shared_captures / "ethercrab_soem-sdinfo-ek1100-el1004.pcapng")],
        capsys,
    )
    assert code == 0
    objs = _json_lines(out)
    assert len(objs) == 594
    assert sum(o["protocol"] == "ecat" for o in objs) == 580
    assert sum(o["protocol"] == "other" for o in objs) == 14
    assert {o["protocol"] for o in objs} <= {"epl", "ecat", "other"}
    codes = [f["code"] for o in objs for f in o["findings"]]  # type: ignore[attr-defined]
    assert codes.count("eth.src.group") == 580
    assert "594 records" in err


def test_decode_json_marks_finding_fields(
    capture_with_error: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = run(["decode", "--json", str(capture_with_error)], capsys)
    assert code == 0  # decode reports, check judges
    objs = _json_lines(out)
    bad = objs[2]["findings"]
    assert isinstance(bad, list) and bad and bad[0].keys() == {"severity", "code", "message"}
    assert bad[0]["severity"] == "error"
    assert [o["findings"] for i, o in enumerate(objs) if i != 2] == [[], [], []]


def test_decode_socketcan_records(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # LINKTYPE_CAN_SOCKETCAN (227): CAN id u32 BE, DLC, 3 reserved bytes, data
    frame = struct.pack(">IB3x", 0x410, 8) + bytes(range(8))
    path = tmp_path / "can.pcap"
    path.write_bytes(pcap_bytes([(5, frame)], linktype=LINKTYPE_CAN_SOCKETCAN))
    code, out, _ = run(["decode", "--json", str(path)], capsys)
    assert code == 0
    (obj,) = _json_lines(out)
    assert (obj["protocol"], obj["length"], obj["time_ns"], obj["findings"]) == ("can", 16, 5, [])


def test_decode_damaged_capture_prints_the_good_records(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    raw = (PCAPS / "epl_cycle_4cn.pcap").read_bytes()
    path = tmp_path / "cut.pcap"
    path.write_bytes(raw[:-7])  # the last record (a SoA) loses 7 bytes
    code, out, err = run(["decode", "--json", str(path)], capsys)
    assert code == 0
    assert [o["index"] for o in _json_lines(out)] == list(range(9))
    assert [o["frame"] for o in _json_lines(out)] == list(range(1, 10))
    assert "skipped frame 10" in err
    assert err.splitlines()[-1] == "10 records: 9 decoded, 1 skipped"
    assert "Traceback" not in err
    # check calls the lost record an error
    code, _, _ = run(["check", str(path)], capsys)
    assert code == 1


# --- check -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_check_golden_exit_0(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["check", str(PCAPS / name)], capsys)
    assert code == 0
    assert out == ""  # no findings to list
    assert err.splitlines()[-1].endswith(": 0 errors, 0 warnings")
    assert f"{GOLDEN[name]} records" in err


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_check_json_one_document(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["check", "--json", str(PCAPS / name)], capsys)
    assert code == 0
    doc = json.loads(out)  # exactly one document: json.loads rejects trailing data
    assert doc["records"] == GOLDEN[name]
    assert (doc["errors"], doc["warnings"], doc["findings"]) == (0, 0, [])
    assert sum(doc["counts"].values()) == GOLDEN[name]
    assert doc["path"] == str(PCAPS / name)
    assert err == ""


@pytest.mark.parametrize("fmt", ["pcap", "pcapng"])
def test_check_a_capture_without_records(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fmt: str
) -> None:
    """Only the file's header: 0 records and no empty ``()`` of kinds."""
    path = tmp_path / f"hdr.{fmt}"
    if fmt == "pcap":  # the 24-byte global header (nanoseconds, snaplen 65535, Ethernet)
        path.write_bytes(struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, 65535, 1))
    else:  # a Section Header Block and an Interface Description Block
        shb = struct.pack("<IIIHHqI", 0x0A0D0D0A, 28, 0x1A2B3C4D, 1, 0, -1, 28)
        path.write_bytes(shb + struct.pack("<IIHHII", 1, 20, 1, 0, 65535, 20))
    code, out, err = run(["check", str(path)], capsys)
    assert (code, out) == (0, "")
    assert err.splitlines()[-1] == f"{path}: 0 records: 0 errors, 0 warnings"


def test_check_error_exit_1(capture_with_error: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["check", str(capture_with_error)], capsys)
    assert code == 1
    assert len(out.splitlines()) == 1 and "error" in out  # the finding, on record 2
    assert out.split()[:2] == ["frame", "3"]  # Wireshark's number of record 2
    assert err.splitlines()[-1].endswith(": 1 errors, 0 warnings")
    code, out, err = run(["check", "--json", str(capture_with_error)], capsys)
    assert code == 1
    doc = json.loads(out)
    assert doc["errors"] == 1 and doc["records"] == 4
    (finding,) = doc["findings"]
    assert finding["index"] == 2 and finding["frame"] == 3 and finding["severity"] == "error"
    assert finding.keys() == {"index", "frame", "severity", "code", "message"}


def test_check_min_severity_hides_but_keeps_the_exit_code(
    shared_captures: Path, capture_with_error: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    soem = str(shared_captures / "ethercrab_soem-sdinfo-ek1100-el1004.pcapng")
    code, out, _ = run(["check", "--json", soem], capsys)
    doc = json.loads(out)
    assert code == 0 and doc["warnings"] == 580 and doc["errors"] == 0
    assert {f["severity"] for f in doc["findings"]} == {"info", "warning"}
    code, out, _ = run(["check", "--json", "--min-severity", "warning", soem], capsys)
    assert {f["severity"] for f in json.loads(out)["findings"]} == {"warning"}
    code, out, _ = run(["check", "--min-severity", "error", soem], capsys)
    assert code == 0 and out == ""
    code, _, _ = run(["check", "--min-severity", "error", str(capture_with_error)], capsys)
    assert code == 1


def test_check_groups_identical_findings(
    shared_captures: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # EPL_Example: 251 eth.trailer (CN 17) + 251 epl.reserved (MN) info, 2 eth.overlap warnings
    path = str(shared_captures / "epl-viz_EPL_Example.cap")
    code, out, err = run(["check", path], capsys)
    assert code == 0
    assert out.splitlines() == [
        line for line in out.splitlines() if line.startswith("frames 225..842  warning eth.overlap")
    ]
    assert len(out.splitlines()) == 1 and " x2 " in out and "node 240" in out
    assert "502 below warning not listed" in err
    code, out, _ = run(["check", "--verbose", path], capsys)
    lines = out.splitlines()
    assert [line.split()[3] for line in lines] == ["eth.overlap", "eth.trailer", "epl.reserved"]
    assert [line.split()[4] for line in lines] == ["x2", "x251", "x251"]
    code, out, _ = run(["check", "--json", path], capsys)
    assert len(json.loads(out)["findings"]) == 504  # every instance


# --- bad input and usage ---------------------------------------------------------------------------
def _bad_files(tmp: Path) -> dict[str, Path]:
    text = tmp / "notes.txt"
    text.write_text("this is a text file, not a capture\n" * 3)
    short = tmp / "short.pcap"
    short.write_bytes((PCAPS / "epl_cycle_4cn.pcap").read_bytes()[:20])  # global header cut
    empty = tmp / "empty.pcap"
    empty.write_bytes(b"")
    magic = tmp / "magic.pcap"
    magic.write_bytes(b"\x00" * 100)
    return {
        "missing": tmp / "does-not-exist.pcap",
        "text": text,
        "truncated": short,
        "empty": empty,
        "magic": magic,
        "directory": tmp,
    }


@pytest.mark.parametrize("command", ["decode", "check"])
@pytest.mark.parametrize("kind", ["missing", "text", "truncated", "empty", "magic", "directory"])
@pytest.mark.parametrize("json_flag", [[], ["--json"]], ids=["text", "json"])
def test_bad_file_exit_2(
    command: str,
    kind: str,
    json_flag: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = _bad_files(tmp_path)[kind]
    code, out, err = run([command, *json_flag, str(path)], capsys)
    assert code == 2
    assert out == ""
    assert_one_error_line(err)


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["frobnicate"],
        ["decode"],
        ["check"],
        ["decode", "--bogus", "x.pcap"],
        ["check", "--min-severity", "fatal", "x.pcap"],
        ["--nope", "decode", "x.pcap"],
        ["decode", "a.pcap", "b.pcap"],
    ],
)
def test_usage_errors_exit_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(argv, capsys)
    assert code == 2
    assert out == ""
    assert_one_error_line(err)


def test_debug_shows_the_exception(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(PcapFormatError):
        main(["--debug", "decode", str(tmp_path / "missing.pcap")])


def _subcommands() -> list[str]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return sorted(sub.choices)


def test_help(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(["--help"], capsys)
    assert code == 0 and out.startswith("usage: skinframes") and err == ""
    for name in ("decode", "check", "demo"):
        assert name in out
    for name in _subcommands():
        code, out, err = run([name, "--help"], capsys)
        assert code == 0, name
        assert out.startswith(f"usage: skinframes {name}"), name
        assert err == ""


def _options(parser: argparse.ArgumentParser, path: str) -> list[tuple[str, argparse.Action]]:
    """Every option of ``parser`` and its subcommands, with the command path that has it."""
    found: list[tuple[str, argparse.Action]] = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found += _options(sub, f"{path} {name}")
        elif action.option_strings:
            found.append((path, action))
    return found


def test_every_option_with_a_default_names_it_in_its_help() -> None:
    """A value that is used unless given (not a flag's False, not a list that --X appends to)
    is said in the option's help: `simulate --preset` once showed no help at all."""
    missing = [
        f"{path} {action.option_strings[-1]} (default {action.default!r})"
        for path, action in _options(build_parser(), "skinframes")
        if action.default not in (None, False, argparse.SUPPRESS)
        and not isinstance(action.default, list)
        and "default" not in (action.help or "").lower()
    ]
    assert missing == []


def test_module_entry_point() -> None:
    golden = PCAPS / "epl_cycle_4cn.pcap"
    result = subprocess.run(
        [sys.executable, "-m", "skinframes", "decode", str(golden)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    assert len(result.stdout.splitlines()) == 10
    assert result.stderr.splitlines() == ["10 records: 10 decoded, 0 skipped"]
    result = subprocess.run(
        [sys.executable, "-m", "skinframes", "check", str(ROOT / "no-such.pcap")],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 2 and result.stdout == ""
    assert_one_error_line(result.stderr)


# --- atomic output under signals (issue 11, Build 2) -----------------------------------------------
def _temp_files(folder: Path) -> list[Path]:
    return [p for p in folder.iterdir() if p.name.startswith(".") and p.name.endswith(".tmp")]


@pytest.mark.parametrize(("sig", "code"), [("SIGINT", 130), ("SIGTERM", 143)])
def test_signal_halfway_keeps_the_previous_pcap(tmp_path: Path, sig: str, code: int) -> None:
    """A run killed while writing leaves the previous file byte-identical and no temporary file."""
    import os
    import signal
    import time

    target = tmp_path / "x.pcap"
    previous = [sys.executable, "-m", "skinframes", "simulate", "ecat", "--nodes", "4"]
    previous += ["--bytes", "8", "--cycles", "2", "--pcap", str(target)]
    subprocess.run(previous, check=True, capture_output=True, timeout=300, cwd=ROOT)
    before = target.read_bytes()
    assert before[:4] == struct.pack("<I", 0xA1B23C4D)
    argv = [sys.executable, "-m", "skinframes", "simulate", "ecat", "--nodes", "160"]
    argv += ["--bytes", "192", "--cycles", "10000", "--pcap", str(target)]
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        grown = False
        while proc.poll() is None and not grown:  # poll the temporary file, not the clock
            grown = any(p.stat().st_size > 1 << 20 for p in _temp_files(tmp_path))
            time.sleep(0.01)
        assert grown, "the run ended before its temporary file grew"
        proc.send_signal(getattr(signal, sig))
        _out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == code, err
    lines = err.decode().splitlines()
    assert len(lines) == 1 and lines[0].startswith("skinframes: "), lines
    assert "Traceback" not in err.decode()
    assert target.read_bytes() == before
    assert _temp_files(tmp_path) == []


def test_demo_writes_only_its_own_files_and_no_picture_with_no_plot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from skinframes_cli.demo import MANIFEST, output_names

    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(["demo", "--out", str(out), "--no-plot"]) == 0
    capsys.readouterr()
    written = {p.name for p in out.iterdir()}
    assert written == {"notes.txt", MANIFEST, *output_names(plots=False)}
    assert not any(name.endswith((".png", ".svg")) for name in written)
    assert (out / "notes.txt").read_text() == "mine"
    listed = (out / MANIFEST).read_text().splitlines()[1:]
    assert sorted(listed) == sorted(output_names(plots=False))


@pytest.mark.parametrize("kind", ["foreign", "symlink", "symlink-out"])
def test_demo_refuses_a_file_it_did_not_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    elsewhere = tmp_path / "elsewhere.txt"
    elsewhere.write_text("keep")
    victim = out / "skin_can.asc"
    if kind == "foreign":
        victim.write_text("a trace of my own")
    elif kind == "symlink":
        victim.symlink_to(elsewhere)
    else:
        victim = out / "epl_160x192_paper.pcap"
        victim.symlink_to(elsewhere)
    code, stdout, err = run(["demo", "--out", str(out), "--no-plot"], capsys)
    assert code == 2 and stdout == ""
    assert_one_error_line(err)
    assert str(victim) in err
    assert elsewhere.read_text() == "keep"
    assert {p.name for p in out.iterdir()} == {victim.name}  # nothing written, not even a list


def test_demo_force_replaces_links_never_their_targets(tmp_path: Path) -> None:
    from skinframes_cli.demo import MANIFEST, prepare_out

    out = tmp_path / "out"
    out.mkdir()
    elsewhere = tmp_path / "elsewhere.txt"
    elsewhere.write_text("keep")
    (out / "a.pcap").symlink_to(elsewhere)
    (out / "b.pcap").write_text("foreign")
    prepare_out(out, ["a.pcap", "b.pcap"], force=True)
    assert not (out / "a.pcap").exists() and elsewhere.read_text() == "keep"
    assert (out / MANIFEST).read_text().splitlines()[1:] == ["a.pcap", "b.pcap"]
    # what demo wrote before may be replaced without --force
    (out / "a.pcap").write_text("from demo")
    prepare_out(out, ["a.pcap"], force=False)


def test_demo_out_needs_an_existing_parent(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run(["demo", "--out", str(tmp_path / "no" / "such"), "--no-plot"], capsys)
    assert code == 2
    assert_one_error_line(err)
    assert not (tmp_path / "no").exists()


# --- streams, pipes and untrusted names (issue 11, Builds 3, 6, 7) ---------------------------------
def many_errors(tmp_path: Path, count: int = 3000) -> Path:
    """A capture whose every frame is a PRes in the asynchronous phase: one error each."""
    frames = [epl_bytes(SoA())] + [epl_bytes(PRes(src=1))] * count
    path = tmp_path / "errors.pcap"
    path.write_bytes(pcap_bytes([(i * 1000, f) for i, f in enumerate(frames)]))
    return path


@pytest.mark.parametrize(
    ("extra", "head"),
    [
        ([], b"frames 2..3001  error   epl.cycle.order        x3000"),  # grouped: one line
        (["--json"], b"{"),  # every instance: ~500 kB, more than a pipe holds
    ],
)
def test_check_keeps_exit_1_through_a_closed_pipe(
    tmp_path: Path, extra: list[str], head: bytes
) -> None:
    path = many_errors(tmp_path)
    proc = subprocess.Popen(
        [sys.executable, "-m", "skinframes", "check", str(path), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=ROOT,
    )
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()  # `| head -1`
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 1
    assert first.startswith(head)
    assert "BrokenPipe" not in err and "Traceback" not in err and "Exception" not in err


def test_decode_and_check_read_standard_input() -> None:
    raw = (PCAPS / "epl_cycle_4cn.pcap").read_bytes()
    for cmd, code in (("decode", 0), ("check", 0)):
        result = subprocess.run(
            [sys.executable, "-m", "skinframes", cmd, "-"],
            input=raw,
            capture_output=True,
            timeout=300,
            check=False,
            cwd=ROOT,
        )
        assert result.returncode == code, result.stderr
        if cmd == "decode":
            assert len(result.stdout.splitlines()) == 10
            assert result.stdout.split()[:2] == [b"frame", b"1"]


@pytest.mark.parametrize("kind", ["device", "fifo", "newline-name"])
def test_special_inputs_end_with_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str
) -> None:
    import os

    if kind == "device":
        path = "/dev/zero"
    elif kind == "fifo":
        path = str(tmp_path / "fifo")
        os.mkfifo(path)
    else:  # a name that tries to forge a second line and recolour the terminal
        path = str(tmp_path / "x\nskinframes: error: forged\x1b[31m.pcap")
        Path(path).write_bytes(b"not a capture at all")
    for cmd in ("decode", "check"):
        code, out, err = run([cmd, path], capsys)
        assert code == 2 and out == ""
        assert_one_error_line(err)
        assert "\x1b" not in err
    if kind == "newline-name":
        assert "x\\nskinframes: error: forged\\x1b[31m.pcap" in err


def test_demo_refuses_a_list_of_files_it_did_not_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from skinframes_cli.demo import MANIFEST, prepare_out

    out = tmp_path / "out"
    out.mkdir()
    (out / MANIFEST).write_text("my own notes\nepl_160x192_paper.pcap\n")
    (out / "epl_160x192_paper.pcap").write_text("mine")
    code, stdout, err = run(["demo", "--out", str(out), "--no-plot"], capsys)
    assert code == 2 and stdout == ""
    assert_one_error_line(err)
    assert f"{out / MANIFEST}: exists and was not written by demo" in err
    assert (out / MANIFEST).read_text().startswith("my own notes")
    assert (out / "epl_160x192_paper.pcap").read_text() == "mine"
    prepare_out(out, ["a.pcap"], force=True)  # --force replaces it and trusts no name on it
    assert (out / MANIFEST).read_text().splitlines()[1:] == ["a.pcap"]


# `python -m` with its command swapped for one whose SIGINT is handled inside code that exec()
# runs from a string, as namedtuple() and dataclasses build their methods
_INTERRUPTED_IN_EXEC = """
import sys

import skinframes_cli
from skinframes_cli import tables


def run(args):
    exec("import signal\\nsignal.raise_signal(signal.SIGINT)\\n")
    return 0


tables.run = run
sys.exit(skinframes_cli.main(["tables"]))
"""


def test_sigint_handled_inside_exec_still_exits_130(tmp_path: Path) -> None:
    """Issue 42's 3 in 400: CPython marks a KeyboardInterrupt that leaves code exec() ran from a
    string as unhandled for good, caught or not, and ``python -m`` then ends itself by SIGINT
    (-2) after printing the error line. numpy.random.bit_generator calls namedtuple() while it
    is imported, in the first milliseconds of a run."""
    import os
    import signal

    (tmp_path / "interrupted_in_exec.py").write_text(_INTERRUPTED_IN_EXEC)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    result = subprocess.run(
        [sys.executable, "-m", "interrupted_in_exec"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=ROOT,
        env=env,
    )
    assert result.returncode == 128 + signal.SIGINT, (result.returncode, result.stderr)
    assert result.stderr.splitlines() == [
        "skinframes: interrupted (SIGINT); no file was left half-written"
    ]


def test_sigint_in_the_first_moments_after_the_temporary_file_appears(tmp_path: Path) -> None:
    """Issue 42: a SIGINT 0-40 ms after the temporary pcap appears always wins: exit 130, the
    previous file unchanged, no temporary file left. (numpy.random's Cython modules, imported
    when the run first draws taxels, swallowed a KeyboardInterrupt that arrived during their
    import: 2 of 16 such runs went on to replace the file; skinframes_cli.signals.)"""
    import os
    import signal
    import time

    target = tmp_path / "x.pcapng"
    argv = [sys.executable, "-m", "skinframes", "simulate", "ecat", "--nodes", "160", "--bytes",
            "192", "--cycles", "200000", "--allow-large-pcap", "--pcap", str(target)]  # fmt: skip
    for k in range(16):
        target.write_bytes(b"previous")
        proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            while proc.poll() is None and not _temp_files(tmp_path):
                time.sleep(0.0002)
            time.sleep(k * 0.0025)  # 0, 2.5, .. 37.5 ms after it appeared
            proc.send_signal(signal.SIGINT)
            _out, err = proc.communicate(timeout=300)
        finally:
            if proc.poll() is None:
                os.kill(proc.pid, signal.SIGKILL)
                proc.wait()
        assert proc.returncode == 130, (k, err)
        assert target.read_bytes() == b"previous", k
        assert not _temp_files(tmp_path), k
