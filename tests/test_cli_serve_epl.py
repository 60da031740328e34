"""``skinframes serve epl``: argument checks, error lines, and a run over a stand-in socket (no
root needed; the live run against openPOWERLINK is tests/emulator/test_live_epl.py)."""

from __future__ import annotations

import json
import signal
import socket
from pathlib import Path

import pytest
import tshark_util
from epl_frames import preq, soa, soc
from epl_mn_util import SkinSocket

import emulator.live
from emulator.epl.skin import EplSkin
from skinframes import read_capture
from skinframes_cli import main


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--nodes", "0", "--bytes", "16"], "EPL: 0 CNs (1..239)"),
        (["--nodes", "240", "--bytes", "16"], "EPL: 240 CNs (1..239)"),
        (["--nodes", "2", "--bytes", "1491"], "EPL: 1491 payload bytes (0..1490)"),
        (["--nodes", "2", "--bytes", "0"], "served EPL CN: 0 taxel bytes (1..1490)"),
        (["--nodes", "3", "--bytes", "8", "--node-ids", "1,2"], "--node-ids: 2 ids for 3 nodes"),
        (["--nodes", "2", "--bytes", "8", "--node-ids", "5,5"], "--node-ids: an id appears twice"),
        (["--nodes", "2", "--bytes", "8", "--samples", "0"], "argument --samples: 0: expected"),
        (["--nodes", "2", "--bytes", "8", "--no-mailbox"], "--no-mailbox, --drift-ppm and --esi"),
        (
            ["--nodes", "2", "--bytes", "8", "--drift-ppm", "3"],
            "--no-mailbox, --drift-ppm and --esi",
        ),
        (["--nodes", "2", "--bytes", "8", "--pcap", ""], "--pcap: an empty file name"),
        (["--nodes", "2", "--bytes", "8", "--esi", "x.xml"], "--no-mailbox, --drift-ppm and --esi"),
        (["--nodes", "2"], "serve epl: --bytes is required"),
    ],
)
def test_bad_arguments(capsys: pytest.CaptureFixture[str], args: list[str], message: str) -> None:
    assert main(["serve", "epl", "--iface", "lo", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"skinframes: error: {message}"), err
    assert err.count("\n") == 1


@pytest.mark.parametrize("option", [["--node-ids", "1"], ["--rt-priority", "5"]])
def test_epl_options_are_refused_for_ecat(
    capsys: pytest.CaptureFixture[str], option: list[str]
) -> None:
    assert main(["serve", "ecat", "--iface", "lo", "--nodes", "1", "--bytes", "8", *option]) == 2
    assert capsys.readouterr().err == (
        f"skinframes: error: {option[0]} applies to serve epl only\n"  # (new: only the one given)
    )
    argv = ["serve", "ecat", "--iface", "lo", "--nodes", "1", "--bytes", "8", "--node-ids", "1"]
    assert main([*argv, "--rt-priority", "5"]) == 2
    assert capsys.readouterr().err == (
        "skinframes: error: --node-ids and --rt-priority apply to serve epl only\n"
    )


def test_node_ids_out_of_range_are_refused_at_parse(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["serve", "epl", "--iface", "lo", "--nodes", "1", "--bytes", "8", "--node-ids", "240"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--node-ids" in err and "240" in err


class ScriptedSocket:
    """Stands in for RawSocket: MN frames in (as RawSocket, their first ``snaplen`` bytes and
    their length), answers kept; SIGINT once every frame was read, as a user stops serve."""

    def __init__(self, frames: list[bytes], snaplen: int = 65535) -> None:
        self.inbox, self.outbox, self.snaplen = list(frames), [], snaplen
        self.r, self.w = socket.socketpair()
        self.w.send(b"x")

    def fileno(self) -> int:
        return self.r.fileno()

    def receive(self) -> tuple[bytes, int] | None:
        if not self.inbox:
            signal.raise_signal(signal.SIGINT)
            return None
        frame = self.inbox.pop(0)
        return frame[: self.snaplen], len(frame)

    def send(self, frame: bytes) -> None:
        self.outbox.append(frame)

    def __enter__(self) -> ScriptedSocket:
        return self

    def __exit__(self, *exc: object) -> None:
        self.r.close()
        self.w.close()


def test_serve_epl_answers_and_reports(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    tshark: str,
) -> None:
    """SoA (NotActive -> PreOp1), SoC (-> PreOp2), a PReq to CN 5 and one to CN 9 (not here),
    an IdentRequest to CN 6: two answers, a PRes and an IdentResponse."""
    scripted = ScriptedSocket([soa(0, 0), soc(), preq(5), preq(9), soa(1, 6)])
    opened: list[tuple[object, ...]] = []

    def fake(iface: str, ethertype: int, *, promiscuous: bool) -> ScriptedSocket:
        opened.append((iface, ethertype, promiscuous))
        return scripted

    monkeypatch.setattr(emulator.live, "RawSocket", fake)
    capture = tmp_path / "serve.pcapng"
    argv = ["serve", "epl", "--iface", "veth9", "--nodes", "2", "--bytes", "24"]
    assert main([*argv, "--node-ids", "5,6", "--pcap", str(capture), "--json"]) == 0
    assert opened == [("veth9", 0x88AB, True)]
    summary = json.loads(capsys.readouterr().out)
    assert (summary["frames_in"], summary["frames_out"], summary["errors"]) == (5, 2, 0)
    assert summary["node_ids"] == [5, 6]
    assert summary["counts"] == {"preq_unknown_node": 1}
    assert [cn["state"] for cn in summary["cns"]] == ["PRE_OPERATIONAL_2"] * 2
    pres, ident = scripted.outbox
    assert pres[14:18] == bytes.fromhex("04ff055d") and ident[14:18] == bytes.fromhex("06ff0601")
    assert tshark_util.problems(tshark, capture) == []
    rows = tshark_util.fields(tshark, capture, ["epl.mtyp", "epl.src"])
    assert [(int(r["epl.mtyp"][0]), int(r["epl.src"][0])) for r in rows] == [
        (5, 240),
        (1, 240),
        (3, 240),
        (4, 5),
        (3, 240),
        (5, 240),
        (6, 6),
    ]


@pytest.mark.tshark
def test_serve_epl_pcap_keeps_the_wire_length_of_a_frame_cut_at_the_snaplen(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, tshark: str
) -> None:
    """A frame longer than the socket keeps (65535 bytes, on an interface of a 64 KiB MTU) is
    recorded cut, with its length on the wire as the original length."""
    frames = [soa(0, 0), preq(9) + bytes(70_000 - len(preq(9))), soa(1, 6)]
    scripted = ScriptedSocket(frames)
    monkeypatch.setattr(emulator.live, "RawSocket", lambda *a, **k: scripted)
    capture = tmp_path / "serve.pcapng"
    argv = ["serve", "epl", "--iface", "veth9", "--nodes", "1", "--bytes", "8", "--node-ids", "6"]
    assert main([*argv, "--pcap", str(capture), "-q"]) == 0
    rows = tshark_util.run(tshark, capture, "-Y", "frame.p2p_dir == 1", "-T", "fields",
                           "-e", "frame.len", "-e", "frame.cap_len")  # fmt: skip
    assert rows.split() == [str(n) for f in frames for n in (len(f), min(len(f), 65535))]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--cdc", "x.cdc"], "--cdc, --cycle-us, --cycles apply to serve epl --mn only"),
        (["--nodes", "2", "--bytes", "8", "--cycles", "5"], "--cdc, --cycle-us, --cycles apply"),
        (["--mn"], "serve epl --mn: --cdc FILE, or --nodes N and --bytes B"),
        (["--mn", "--nodes", "2"], "serve epl --mn: --cdc FILE, or --nodes N and --bytes B"),
        (["--mn", "--cdc", "x.cdc", "--nodes", "2"], "serve epl --mn: --cdc or --nodes"),
        (["--mn", "--cdc", "/nonexistent/x.cdc"], "--cdc /nonexistent/x.cdc: No such file"),
        (
            ["--mn", "--nodes", "41", "--bytes", "8"],
            "serve epl --mn: --nodes 41: the CDC's MN has 40",
        ),
        (["--mn", "--nodes", "2", "--bytes", "8", "--esi", "x.xml"], "--no-mailbox, --drift"),
    ],
)
def test_bad_mn_arguments(
    capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    assert main(["serve", "epl", "--iface", "lo", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"skinframes: error: {message}"), err
    assert err.count("\n") == 1


def test_a_cdc_that_is_no_cdc_is_one_error_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    bad = tmp_path / "bad.cdc"
    bad.write_bytes(b"\x05\x00\x00\x00\x06\x10")  # 5 entries announced, one cut short
    assert main(["serve", "epl", "--mn", "--iface", "lo", "--cdc", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"skinframes: error: --cdc {bad}: CDC: entry 0 of 5"), err
    assert err.count("\n") == 1


def test_mn_is_refused_for_ecat(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["serve", "ecat", "--iface", "lo", "--nodes", "1", "--bytes", "8", "--mn"]
    assert main(argv) == 2
    assert capsys.readouterr().err == "skinframes: error: --mn applies to serve epl only\n"


def test_serve_epl_mn_boots_emulated_cns_and_reports(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    tshark: str,
) -> None:
    """``serve epl --mn --nodes 2 --bytes 8 --cycles 5`` over a stand-in socket whose emulated
    CNs (emulator.epl.skin) answer at once: both OPERATIONAL, the report's keys, a tshark-clean
    capture in which the MN sent SoC, PReq, SoA and ASnd and the CNs PRes and ASnd."""
    opened: list[tuple[object, ...]] = []

    def fake(iface: str, ethertype: int, *, promiscuous: bool) -> SkinSocket:
        opened.append((iface, ethertype, promiscuous))
        return SkinSocket(EplSkin([3, 7], 8))

    monkeypatch.setattr(emulator.live, "RawSocket", fake)
    capture = tmp_path / "mn.pcapng"
    argv = ["serve", "epl", "--mn", "--iface", "veth9", "--nodes", "2", "--bytes", "8"]
    assert (
        main([*argv, "--node-ids", "3,7", "--cycles", "5", "--pcap", str(capture), "--json"]) == 0
    )
    assert opened == [("veth9", 0x88AB, True)]
    summary = json.loads(capsys.readouterr().out)
    assert summary["role"] == "mn" and summary["node_ids"] == [3, 7]
    assert summary["operational_cycles"] == 5 and summary["errors"] == 0
    assert [cn["state"] for cn in summary["cns"]] == ["OPERATIONAL"] * 2
    assert all(cn["response_us_median"] is not None for cn in summary["cns"])
    # every frame sent and received is in the capture, the last ones too
    assert sum(1 for _ in read_capture(capture)) == summary["frames_in"] + summary["frames_out"]
    assert tshark_util.problems(tshark, capture) == []
    rows = tshark_util.fields(tshark, capture, ["epl.mtyp", "epl.src"])
    sent = {(int(r["epl.mtyp"][0]), int(r["epl.src"][0])) for r in rows}
    assert sent == {(1, 240), (3, 240), (5, 240), (6, 240), (4, 3), (4, 7), (6, 3), (6, 7)}


def test_serve_epl_mn_text_summary(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(emulator.live, "RawSocket", lambda *a, **k: SkinSocket(EplSkin([1], 8)))
    assert (
        main(
            [
                "serve",
                "epl",
                "--mn",
                "--iface",
                "x",
                "--nodes",
                "1",
                "--bytes",
                "8",
                "--cycles",
                "3",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("MN: 1 CNs, cycle ") and "all OPERATIONAL after" in out[0]
    assert out[1].startswith("  CN 1: OPERATIONAL after ") and "PReq -> PRes median" in out[1]
