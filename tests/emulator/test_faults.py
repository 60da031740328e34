"""Fault injection: what breaks, what the network does, and what the diagnosis names."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
import tshark_util

from emulator.ecat_cycle import simulate_ecat
from emulator.ecat_faults import simulate_ecat_faults
from emulator.epl_cycle import simulate_epl
from emulator.epl_faults import DEFAULT_TIMEOUT_MARGIN_PS, simulate_epl_faults
from emulator.errors import ScheduleError, TopologyError
from emulator.faults import Fault, parse_fault
from emulator.params import PAPER, WIRE
from skinframes import read_capture
from skinframes.check import check_capture

IN_CI = os.environ.get("CI", "").lower() == "true"
N, B = 160, 192


@pytest.mark.parametrize("redundant", [False, True])
@pytest.mark.parametrize("layout", ["per-slave", "logical"])
def test_without_faults_the_hop_by_hop_engine_equals_the_fast_one(
    redundant: bool, layout: str
) -> None:
    fast = simulate_ecat(23, 192, WIRE, redundant=redundant, layout=layout, cycles=2, seed=4)
    slow = simulate_ecat_faults(
        23, 192, WIRE, (), redundant=redundant, layout=layout, cycles=2, seed=4
    )
    a, b = fast.trace.to_records(), slow.trace  # type: ignore[union-attr]
    assert (a.times_ps, a.data, a.port, a.outbound) == (b.times_ps, b.data, b.port, b.outbound)


@pytest.mark.parametrize("params", [PAPER, WIRE])
def test_epl_without_faults_equals_the_fast_one(params) -> None:  # type: ignore[no-untyped-def]
    a = simulate_epl(12, 100, params, cycles=3, seed=2).trace.to_records()  # type: ignore[union-attr]
    b = simulate_epl_faults(12, 100, params, (), cycles=3, seed=2).trace
    assert (a.times_ps, a.data) == (b.times_ps, b.data)


LINKS = range(0, N + 1) if IN_CI else range(0, N + 1, 20)


@pytest.mark.parametrize("params", [PAPER, WIRE])
@pytest.mark.parametrize("link", LINKS)
def test_closed_ring_survives_a_break_anywhere(params, link: int) -> None:  # type: ignore[no-untyped-def]
    r = simulate_ecat_faults(N, B, params, (Fault("cable", link, 1),), redundant=True, cycles=3)
    assert r.recovery_us is not None and r.recovery_us <= 15
    before, during, after = r.details
    assert before.wkc == before.expected_wkc == N
    assert after.wkc == N  # every slave still reached, from one port or the other
    assert during.wkc <= N
    r.trace.check_no_overlap()


@pytest.mark.parametrize("k", [1, 2, 40, 80, 159])
def test_open_ring_break_cuts_off_the_slaves_behind(k: int) -> None:
    r = simulate_ecat_faults(N, B, PAPER, (Fault("cable", k, 1),), cycles=3)
    # one LRD per slave: WKC = reachable slaves once the port has closed (in the break's cycle a
    # frame that reached the cable within the 15 us before slave k's port closed is lost)
    assert r.details[0].wkc == N and r.details[1].wkc <= k and r.details[2].wkc == k
    assert any(f"link {k}..{k + 1} down" in line for line in r.diagnosis)
    assert r.recovery_us is None  # nothing recovers in an open ring


def test_power_loss_in_the_closed_ring_loses_only_that_node() -> None:
    r = simulate_ecat_faults(20, B, PAPER, (parse_fault("power:7@1"),), redundant=True, cycles=3)
    assert r.details[-1].wkc == 19
    assert any("node 7 lost power" in line for line in r.diagnosis)


@pytest.mark.parametrize("link", [0, 3, 9])
def test_a_bit_error_is_counted_by_the_port_behind_the_link(link: int) -> None:
    """Every frame is corrupted on its way out over link j: slave j+1's port 0 counts each one
    (invalid frame counter 0x0300), and no other port counts an invalid frame."""
    n, cycles = 10, 2
    r = simulate_ecat_faults(n, B, PAPER, (Fault("biterr", link, 0, 1.0),), cycles=cycles)
    frames = 2  # 10 x 204-byte datagrams: 7 + 3
    crc = [line for line in r.diagnosis if line.startswith("CRC errors")]
    assert crc == [
        f"CRC errors on link {link}..{link + 1}: slave {link + 1} port 0 counted "
        f"{frames * cycles} invalid frames (register 0x0300); later ESCs counted them "
        "as forwarded errors (0x0308+port)"
    ]
    assert all(d.wkc == 0 for d in r.details)  # the master discards every corrupted frame
    assert r.trace.marked == frames * cycles  # type: ignore[union-attr]


@pytest.mark.tshark
def test_fault_pcaps_are_clean_and_marked(tshark: str, tmp_path: Path) -> None:
    faults = (parse_fault("biterr:4:0.5"), parse_fault("cable:12@2"))
    r = simulate_ecat_faults(16, B, WIRE, faults, redundant=True, cycles=4, seed=7)
    path = tmp_path / "faults.pcapng"
    r.trace.write_pcap(path)
    assert tshark_util.problems(tshark, path) == []
    comments = [
        c
        for row in tshark_util.fields(tshark, path, ["frame.comment"])
        for c in row["frame.comment"]
    ]
    assert len(comments) == r.trace.marked > 0  # type: ignore[union-attr]
    report = check_capture(read_capture(path))
    assert sum(f.finding.code == "eth.corrupted" for f in report.findings) == len(comments)
    with pytest.raises(ScheduleError):
        r.trace.write_pcap(tmp_path / "faults.pcap")  # a classic pcap cannot carry the marks


def test_epl_missing_pres_times_out_and_the_mn_keeps_cycling() -> None:
    n = 6
    r = simulate_epl_faults(n, 64, PAPER, (parse_fault("power:4@1"),), cycles=4)
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
    ok = simulate_epl_faults(5, 64, PAPER, (), cycles=1)
    late = simulate_epl_faults(5, 64, PAPER, (parse_fault("late:2:20"),), cycles=1)
    assert late.details[0].cycle_ps - ok.details[0].cycle_ps == 20_000_000
    assert late.details[0].wkc == 5
    too_late = simulate_epl_faults(5, 64, PAPER, (parse_fault("late:2:30"),), cycles=1)
    assert too_late.details[0].wkc == 4
    assert any("after the PRes timeout" in line for line in too_late.diagnosis)


@pytest.mark.parametrize("spec", ["cable:x@1", "cable:3", "biterr:2:1.5", "late:1:-3", "boom:1"])
def test_bad_fault_specs(spec: str) -> None:
    with pytest.raises(TopologyError):
        parse_fault(spec)


def test_faults_naming_missing_links_or_nodes() -> None:
    with pytest.raises(TopologyError, match="link 10"):
        simulate_ecat_faults(10, B, PAPER, (Fault("cable", 10, 1),), cycles=2)  # open: 0..9
    simulate_ecat_faults(10, B, PAPER, (Fault("cable", 10, 1),), redundant=True, cycles=2)
    with pytest.raises(TopologyError, match="EPL"):
        simulate_ecat_faults(10, B, PAPER, (parse_fault("late:1:5"),), cycles=2)


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
