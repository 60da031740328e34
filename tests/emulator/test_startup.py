"""``simulate ecat --startup``: the master's start-up before the cycles, judged by tshark."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
import tshark_util

from emulator import PAPER, simulate_ecat
from emulator.errors import TopologyError
from emulator.net.run import MemorySink
from skinframes import decode_frame
from skinframes.ethercat import EcatFrame
from skinframes_cli import main

NODES, SIZE = 3, 192
VENDOR = "0x534b494e"


@pytest.mark.tshark
def test_startup_pcap_is_a_clean_master_startup(tshark: str, tmp_path: Path) -> None:
    path = tmp_path / "startup.pcapng"
    r = simulate_ecat(NODES, SIZE, PAPER, cycles=3, startup=True, pcap=path)
    assert tshark_util.problems(tshark, path) == []
    rows = tshark_util.fields(
        tshark,
        path,
        [
            "frame.protocols",
            "ecat.cmd",
            "ecat.ado",
            "ecat.cnt",
            "ecat.reg.alstatus.status",
            "ecat_mailbox.coe.sdoidx",
            "ecat_mailbox.coe.sdosub",
            "ecat_mailbox.coe.type",
            "ecat_mailbox.coe.sdodata",
        ],
    )
    assert len(rows) == r.startup_frames + r.frames
    start = rows[: r.startup_frames]
    sent, back = start[0::2], start[1::2]
    assert all(row["frame.protocols"][0].startswith("eth:ethertype:ecatf:ecat") for row in rows)
    # the scan: BRD 0x0000 answered by every slave, then INIT + ack, station addresses
    assert (sent[0]["ecat.cmd"], sent[0]["ecat.ado"], back[0]["ecat.cnt"]) == (
        ["0x07"],
        ["0x0000"],
        [str(NODES)],
    )
    cmds = [(s["ecat.cmd"][0], s["ecat.ado"][0]) for s in sent]
    assert cmds[1] == ("0x08", "0x0120")
    assert cmds[2 : 2 + NODES] == [("0x02", "0x0010")] * NODES
    assert ("0x05", "0x0502") in cmds and ("0x04", "0x0508") in cmds  # SII reads
    # CoE: per slave an upload of 0x1018:01 (expedited answer: the vendor ID) and complete
    # access uploads of the PDO assignment 0x1C12 and 0x1C13
    requests = [(s["ecat_mailbox.coe.sdoidx"], s["ecat_mailbox.coe.sdosub"]) for s in sent]
    coe = [(i[0], s[0]) for i, s in requests if i]
    assert coe == [("0x1018", "0x01"), ("0x1c12", "0x00"), ("0x1c13", "0x00")] * NODES
    answers = [b for b in back if b["ecat_mailbox.coe.type"] == ["3"] and b["ecat.cmd"] == ["0x04"]]
    assert len(answers) == 3 * NODES
    assert [a["ecat_mailbox.coe.sdodata"] for a in answers[0::3]] == [[VENDOR]] * NODES
    # the states, each checked with BRD 0x0130 by every slave: PREOP, SAFEOP and OP at the end
    states = [
        b["ecat.reg.alstatus.status"][0]
        for s, b in zip(sent, back, strict=True)
        if s["ecat.cmd"] == ["0x07"] and s["ecat.ado"] == ["0x0130"]
    ]
    assert states == ["0x0002", "0x0004", "0x0008"]
    # the cycles follow, the chain configured by those frames: every LRD answered
    assert [d.wkc for d in r.details] == [NODES]
    assert r.details[0].start_ps > 0
    assert r.startup_us == pytest.approx(r.details[0].start_ps / 1e6 - PAPER.ifg_ps / 1e6)


def test_startup_frames_are_timed_by_the_engine() -> None:
    sink = MemorySink()
    r = simulate_ecat(NODES, 16, PAPER, cycles=1, startup=True, sink=sink)
    records = sink.records
    start, cycle = records[: r.startup_frames], records[r.startup_frames :]
    # a frame's way out and back does not depend on its kind: a start-up frame returns after
    # as long as a cycle's LRD frame (both walked by the engine, same length, same chain)
    trips = {back[0] - out[0] for out, back in zip(start[0::2], start[1::2], strict=True)}
    (lrd_out, lrd_back) = cycle
    assert trips == {lrd_back[0] - lrd_out[0]}
    # one frame at a time: the next leaves one IFG after the previous one is back whole
    for back, nxt in zip(start[1::2], start[2::2], strict=False):
        assert nxt[0] == back[0] + PAPER.frame_ps(len(back[3])) + PAPER.ifg_ps
    ecat = decode_frame(start[-1][3]).payload
    assert isinstance(ecat, EcatFrame)
    assert ecat.datagrams[0].data == b"\x08\x00"  # the last answer: AL status OP


def test_startup_refuses_faults_and_the_closed_ring(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(TopologyError):
        simulate_ecat(NODES, SIZE, PAPER, closed_ring=True, startup=True)
    argv = ["simulate", "ecat", "--nodes", "3", "--bytes", "8", "--startup"]
    assert main([*argv, "--fault", "drop:1:0.5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error: --startup")
    assert main(["simulate", "epl", "--nodes", "3", "--bytes", "8", "--startup"]) == 2


def test_startup_sets_up_the_distributed_clocks_as_soem_does() -> None:
    # SOEM's ecx_configdc: BWR 0x0900 latches, FPRD 0x0918 and 0x0900 per slave, then FPWR of
    # the offset 0x0920 and the delay 0x0928; the delay of slave p is the difference of the port-0
    # receive times the latch left in slave p and in the reference (slave 0)
    sink = MemorySink()
    r = simulate_ecat(NODES, 16, PAPER, cycles=1, startup=True, sink=sink)
    answers = []
    for _, _, outbound, frame, _ in sink.records[: r.startup_frames]:
        ecat = decode_frame(frame).payload
        assert isinstance(ecat, EcatFrame)
        (d,) = ecat.datagrams
        if not outbound and 0x0900 <= d.ado < 0x0A00:
            answers.append((int(d.cmd), d.ado, d.data, d.wkc))
    assert answers[0] == (0x08, 0x0900, bytes(4), NODES)  # BWR: every slave latched
    port0 = [int.from_bytes(a[2][:4], "little") for a in answers if a[:2] == (0x04, 0x0900)]
    assert len(port0) == NODES and all(a[3] == 1 for a in answers[1:])
    delays = [int.from_bytes(a[2], "little") for a in answers if a[:2] == (0x05, 0x0928)]
    assert delays == [t - port0[0] for t in port0]
    assert delays[0] == 0 and all(b > a for a, b in itertools.pairwise(delays))
    # by hand: the frame reaches port 0 of slave p after p passes through an ESC and a cable of
    # the run's preset (PAPER: 675 ns + 0.5 ns per hop), latched to the whole ns
    hop_ns = (PAPER.ecat_processing_ps + PAPER.cable_ps) / 1000
    assert all(abs(d - p * hop_ns) <= 0.5 for p, d in enumerate(delays))
    assert len([a for a in answers if a[:2] == (0x05, 0x0920)]) == NODES
