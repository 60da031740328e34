"""Fault injection: one engine per protocol, what breaks, what the network does, and what the
diagnosis names; the same meaning of each fault in EPL and EtherCAT."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
import tshark_util
from engine_util import records

from emulator.errors import TopologyError
from emulator.model.params import PAPER, WIRE
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.ecat import DEFAULT_TIMEOUT_MARGIN_PS
from emulator.net.faults import Fault, parse_fault
from skinframes import ethernet, read_capture
from skinframes.check import check_capture
from skinframes.errors import SkinframesError
from skinframes.powerlink import MessageType

IN_CI = os.environ.get("CI", "").lower() == "true"
N, B = 160, 192

RUNS = [  # (function, nodes, keyword arguments): both protocols, both rings, ASnd, short timeout
    (simulate_ecat, 23, {"closed_ring": False}),
    (simulate_ecat, 23, {"closed_ring": True}),
    (simulate_ecat, 23, {"closed_ring": True, "layout": "logical"}),
    (simulate_epl, 12, {}),
    (simulate_epl, 12, {"asnd": True}),
    (simulate_epl, 45, {"pres_timeout_ps": 25_000_000}),  # CNs 39..45 cannot meet it
]


@pytest.mark.parametrize("params", [PAPER, WIRE])
@pytest.mark.parametrize(("fn", "nodes", "kw"), RUNS)
def test_the_fast_path_equals_the_walk_of_every_cycle(fn, nodes, kw, params) -> None:  # type: ignore[no-untyped-def]
    """The periodic fast path (walk one period, repeat it) gives the bytes and times of walking
    each cycle frame by frame, also around a fault in the middle of the run."""
    for faults in ((), (Fault("cable", 3, 5),)):
        a = records(fn, nodes, 100, params, cycles=14, seed=2, faults=faults, **kw)
        b = records(fn, nodes, 100, params, cycles=14, seed=2, faults=faults, fast=False, **kw)
        assert a[1] == b[1]
        assert a[0].to_json() == b[0].to_json()


@pytest.mark.parametrize("data_bytes", [0, 8, 1490])
@pytest.mark.parametrize("asnd", [False, True])
def test_the_fast_path_fills_every_pres_payload_size(data_bytes: int, asnd: bool) -> None:
    """A PRes repeats with only its taxels filled in: none (0 bytes), a padded short frame (8)
    and the largest (1490) give the bytes of the walk."""
    a = records(simulate_epl, 5, data_bytes, WIRE, cycles=12, seed=3, asnd=asnd)
    b = records(simulate_epl, 5, data_bytes, WIRE, cycles=12, seed=3, asnd=asnd, fast=False)
    assert a[1] == b[1]
    pres = {r[3] for r in a[1] if r[3][ethernet.HEADER_BYTES] == MessageType.PRES}
    assert len(pres) == (5 * 12 if data_bytes else 5)  # the taxels change from cycle to cycle


@pytest.mark.tshark
@pytest.mark.parametrize("params", [PAPER, WIRE])
@pytest.mark.parametrize(("fn", "nodes", "kw"), RUNS)
def test_a_fault_after_the_last_cycle_changes_no_byte(  # type: ignore[no-untyped-def]
    fn, nodes, kw, params, tmp_path: Path, tshark: str
) -> None:
    for suffix in (".pcap", ".pcapng"):
        plain, late = tmp_path / f"plain{suffix}", tmp_path / f"late{suffix}"
        fn(nodes, 100, params, cycles=5, seed=1, pcap=plain, **kw)
        fn(nodes, 100, params, cycles=5, seed=1, pcap=late, faults=(Fault("cable", 2, 5),), **kw)
        assert plain.read_bytes() == late.read_bytes()
    assert tshark_util.problems(tshark, plain) == []


LINKS = range(0, N + 1) if IN_CI else range(0, N + 1, 20)


@pytest.mark.parametrize("params", [PAPER, WIRE])
@pytest.mark.parametrize("link", LINKS)
def test_closed_ring_survives_a_break_anywhere(params, link: int) -> None:  # type: ignore[no-untyped-def]
    r = simulate_ecat(
        N,
        B,
        params,
        faults=(Fault("cable", link, 1),),
        closed_ring=True,
        cycles=3,
        every_cycle=True,
    )
    assert r.recovery_us is not None and r.recovery_us <= 15
    before, during, after = r.details
    assert before.wkc == before.expected_wkc == N
    assert after.wkc == N  # every slave still reached, from one port or the other
    assert during.wkc <= N


@pytest.mark.parametrize("k", [1, 2, 40, 80, 159])
def test_open_ring_break_cuts_off_the_slaves_behind(k: int) -> None:
    r = simulate_ecat(N, B, PAPER, faults=(Fault("cable", k, 1),), cycles=3, every_cycle=True)
    # one LRD per slave: WKC = reachable slaves once the port has closed (in the break's cycle a
    # frame that reached the cable within the 15 us before slave k's port closed is lost)
    assert r.details[0].wkc == N and r.details[1].wkc <= k and r.details[2].wkc == k
    assert any(f"link {k}..{k + 1} down" in line for line in r.diagnosis)
    assert r.recovery_us is None  # nothing recovers in an open ring


def test_power_loss_in_the_closed_ring_loses_only_that_node() -> None:
    r = simulate_ecat(20, B, PAPER, faults=(parse_fault("power:7@1"),), closed_ring=True, cycles=3)
    assert r.details[-1].wkc == 19
    assert any("node 7 lost power" in line for line in r.diagnosis)


@pytest.mark.parametrize("link", [0, 3, 9])
def test_a_bit_error_is_counted_by_the_port_behind_the_link(link: int) -> None:
    """Every frame is corrupted on its way out over link j: slave j+1's port 0 counts each one
    (invalid frame counter 0x0300), and no other port counts an invalid frame."""
    n, cycles = 10, 2
    r, recs = records(
        simulate_ecat, n, B, PAPER, faults=(Fault("biterr", link, 0, 1.0),), cycles=cycles
    )
    frames = 2  # 10 x 204-byte datagrams: 7 + 3
    crc = [line for line in r.diagnosis if line.startswith("CRC errors")]
    assert crc == [
        f"CRC errors on link {link}..{link + 1}: slave {link + 1} port 0 counted "
        f"{frames * cycles} invalid frames (register 0x0300); later ESCs counted them "
        "as forwarded errors (0x0308+port)"
    ]
    assert all(d.wkc == 0 for d in r.details)  # the master discards every corrupted frame
    assert sum(rec[4] is not None for rec in recs) == frames * cycles


@pytest.mark.tshark
def test_fault_pcaps_are_clean_and_marked(tshark: str, tmp_path: Path) -> None:
    faults = (parse_fault("biterr:4:0.5"), parse_fault("cable:12@2"))
    path = tmp_path / "faults.pcapng"
    kw = {"faults": faults, "closed_ring": True, "cycles": 4, "seed": 7}
    simulate_ecat(16, B, WIRE, pcap=path, **kw)  # type: ignore[arg-type]
    _, recs = records(simulate_ecat, 16, B, WIRE, **kw)
    assert tshark_util.problems(tshark, path) == []
    comments = [
        c
        for row in tshark_util.fields(tshark, path, ["frame.comment"])
        for c in row["frame.comment"]
    ]
    assert len(comments) == sum(rec[4] is not None for rec in recs) > 0
    report = check_capture(read_capture(path))
    assert sum(f.finding.code == "eth.corrupted" for f in report.findings) == len(comments)
    classic = tmp_path / "faults.pcap"
    with pytest.raises(SkinframesError, match="pcapng"):  # a classic pcap cannot carry the marks
        simulate_ecat(16, B, WIRE, pcap=classic, **kw)  # type: ignore[arg-type]
    assert not classic.exists()  # nothing half-written is left behind


def test_epl_missing_pres_times_out_and_the_mn_keeps_cycling() -> None:
    n = 6
    r = simulate_epl(n, 64, PAPER, faults=(parse_fault("power:4@1"),), cycles=4, every_cycle=True)
    assert [d.wkc for d in r.details] == [6, 3, 3, 3]  # CN 4's hub dies with it: 4..6 cut off
    assert any("CN 4: 3 of 4 PRes lost" in line for line in r.diagnosis)
    base = r.details[0].cycle_ps
    # each silent CN costs its timeout instead of its PRes (hand sum, paper preset)
    pres_ps = (8 + 14 + 10 + 64 + 4) * 80_000
    extra = sum(
        (DEFAULT_TIMEOUT_MARGIN_PS + 2 * (i + 1) * 300_500 + 1_000_000)
        - (2 * (i + 1) * 300_500 + 1_000_000 + pres_ps)
        for i in (4, 5, 6)
    )
    assert r.details[1].cycle_ps == base + extra


def test_a_late_cn_within_its_timeout_only_stretches_the_cycle() -> None:
    ok = simulate_epl(5, 64, PAPER, cycles=1)
    late = simulate_epl(5, 64, PAPER, faults=(parse_fault("late:2:20"),), cycles=1)
    assert late.details[0].cycle_ps - ok.details[0].cycle_ps == 20_000_000
    assert late.details[0].wkc == 5
    too_late = simulate_epl(5, 64, PAPER, faults=(parse_fault("late:2:30"),), cycles=1)
    assert too_late.details[0].wkc == 4
    assert any("after the PRes timeout" in line for line in too_late.diagnosis)


@pytest.mark.parametrize("spec", ["cable:x@1", "cable:3", "biterr:2:1.5", "late:1:-3", "boom:1"])
def test_bad_fault_specs(spec: str) -> None:
    with pytest.raises(TopologyError):
        parse_fault(spec)


def test_faults_naming_missing_links_or_nodes() -> None:
    with pytest.raises(TopologyError, match="link 10"):
        simulate_ecat(10, B, PAPER, faults=(Fault("cable", 10, 1),), cycles=2)  # open: 0..9
    simulate_ecat(10, B, PAPER, faults=(Fault("cable", 10, 1),), closed_ring=True, cycles=2)
    with pytest.raises(TopologyError, match="node 11"):
        simulate_ecat(10, B, PAPER, faults=(parse_fault("late:11:5"),), cycles=2)


def test_fault_help_and_cli(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from skinframes_cli import main

    assert main(["simulate", "ecat", "--nodes", "4", "--bytes", "8", "--fault", "help"]) == 0
    assert "cable:K@C" in capsys.readouterr().out
    out = tmp_path / "f.pcapng"
    assert (
        main(
            [
                "simulate",
                "ecat",
                "--nodes",
                "40",
                "--bytes",
                "192",
                "--redundant",
                "--fault",
                "cable:7@1",
                "--cycles",
                "3",
                "--pcap",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    import json

    doc = json.loads(capsys.readouterr().out)
    assert doc["recovery_us"] == 15
    assert re.search(r"link 7\.\.8 down", " ".join(doc["diagnosis"]))
    assert [d["wkc"] for d in doc["cycles_detail"]][-1] == 40


# --- one meaning per fault kind, EPL and EtherCAT alike --------------------------------------
PROTOCOLS = [simulate_ecat, simulate_epl]


@pytest.mark.parametrize("fn", PROTOCOLS)
def test_a_bit_error_flips_one_bit_and_the_receiver_discards_the_frame(fn, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """biterr:0:P: a frame crossing link 0 has one bit of its data flipped (the FCS no longer
    matches); the frame is marked, `check` calls it corrupted, and the master (EtherCAT) or MN
    (EPL) does not count it (working counter / PRes received)."""
    from skinframes import decode_frame, taxel

    n, size, cycles = 5, 16, 12
    kw = {"cycles": cycles, "seed": 3, "faults": (Fault("biterr", 0, 0, 0.4),), "every_cycle": True}
    r, recs = records(fn, n, size, PAPER, **kw)
    clean = taxel.sample_payloads(n, cycles, size, seed=3)
    marked = [(i, rec) for i, rec in enumerate(recs) if rec[4] is not None]
    assert marked and all("link 0..1" in rec[4] for _, rec in marked)
    starts = [d.start_ps for d in r.details]
    for _, rec in marked:
        c = max(k for k, s in enumerate(starts) if s <= rec[0])
        msg = decode_frame(rec[3]).payload
        if fn is simulate_ecat:  # corrupted going out (nobody processed it) or coming back
            got = b"".join(d.data for d in msg.datagrams)  # type: ignore[union-attr]
            candidates = [bytes(n * size), clean[c].tobytes()]
        else:
            got = msg.payload  # type: ignore[union-attr]
            candidates = [clean[c, msg.src - 1].tobytes()]  # type: ignore[union-attr]
        flips = [
            sum(bin(a ^ b).count("1") for a, b in zip(got, want, strict=True))
            for want in candidates
        ]
        assert min(flips) == 1
        assert r.details[c].wkc < r.details[c].expected_wkc
    path = tmp_path / "bits.pcapng"
    fn(n, size, PAPER, pcap=path, **kw)
    report = check_capture(read_capture(path))
    assert sum(f.finding.code == "eth.corrupted" for f in report.findings) == len(marked)


@pytest.mark.parametrize("fn", PROTOCOLS)
def test_a_dropped_frame_is_a_loss_the_master_counts(fn) -> None:  # type: ignore[no-untyped-def]
    n = 5
    r, recs = records(
        fn, n, 16, PAPER, cycles=8, seed=1, faults=(Fault("drop", 0, 0, 0.3),), every_cycle=True
    )
    ok, ok_recs = records(fn, n, 16, PAPER, cycles=8, seed=1, every_cycle=True)
    assert len(recs) < len(ok_recs)  # dropped frames never reach the master's port
    assert sum(d.wkc for d in r.details) < sum(d.wkc for d in ok.details)
    assert any("lost" in line for line in r.diagnosis)
    assert all(rec[4] is None for rec in recs)  # a loss is not a corruption


@pytest.mark.parametrize("fn", PROTOCOLS)
def test_a_late_answer_within_the_timeout_only_stretches_the_cycle(fn) -> None:  # type: ignore[no-untyped-def]
    """late:2:US: node 2 answers (EPL) or passes frames on (EtherCAT) US late. Within the
    receive timeout (round trip + 25 us) the cycle grows by exactly US and nothing is lost;
    beyond it the answers are losses the master counts, and the cycles go on."""
    ok = (
        simulate_ecat(5, 64, PAPER, cycles=1)
        if fn is simulate_ecat
        else simulate_epl(5, 64, PAPER, cycles=1)
    )
    late = fn(5, 64, PAPER, faults=(parse_fault("late:2:20"),), cycles=1)
    assert late.details[0].cycle_ps - ok.details[0].cycle_ps == 20_000_000
    assert late.details[0].wkc == late.details[0].expected_wkc
    too_late = fn(5, 64, PAPER, faults=(parse_fault("late:2:30"),), cycles=3)
    assert too_late.cycles == 3
    assert too_late.details[0].wkc < too_late.details[0].expected_wkc
    assert any("timeout" in line for line in too_late.diagnosis)


def test_the_default_timeout_margin_is_25_us() -> None:
    assert DEFAULT_TIMEOUT_MARGIN_PS == 25_000_000


@pytest.mark.parametrize("fn", PROTOCOLS)
def test_timing_only_runs_time_the_same_cycles(fn) -> None:  # type: ignore[no-untyped-def]
    """Without a capture the engine builds no frame bytes, yet draws the same chances: the
    same cycles, counters and diagnosis as the run that writes every frame."""
    faults = (Fault("biterr", 1, 0, 0.3), Fault("drop", 2, 0, 0.2), Fault("cable", 3, 12))
    kw = {"cycles": 20, "seed": 5, "faults": faults, "every_cycle": True}
    timing = fn(6, 32, WIRE, **kw)
    full, recs = records(fn, 6, 32, WIRE, **kw)
    assert recs and timing.to_json() == full.to_json()
