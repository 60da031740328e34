"""Physical timing: two frames of one sender on one interface cannot overlap on the wire.

Wire time by hand (IEEE 802.3-2018): a 60-byte frame (no FCS captured) is 8 preamble/SFD + 60 +
4 FCS = 72 octets, 5760 ns at 100 Mbit/s; the inter-frame gap is 12 octets, 960 ns.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from skinframes import golden
from skinframes.check import OverlapChecker, check_capture
from skinframes.pcap import CaptureWriter, parse_capture, pcap_bytes, read_capture

PCAPS = Path(__file__).resolve().parents[2] / "pcaps"
NEED_NS = 5760 + 960  # a 60-byte frame at 100 Mbit/s, then the gap


def overlaps(records: list[tuple[int, bytes]]) -> list[int]:
    report = check_capture(parse_capture(pcap_bytes(records, linktype=1)))
    return [f.index for f in report.findings if f.finding.code == "eth.overlap"]


@pytest.mark.parametrize("name", sorted(golden.SCENARIOS))
def test_golden_captures_are_physically_possible(name: str) -> None:
    report = check_capture(read_capture(PCAPS / f"{name}.pcap"))
    assert [f for f in report.findings if f.finding.code == "eth.overlap"] == []


def test_one_deliberate_overlap_is_reported_at_that_frame() -> None:
    records = golden.build("ecat_all_commands")  # 60-byte frames of the master, 10 us apart
    assert overlaps(records) == []
    t6, _ = records[6]
    records[7] = (t6 + 3_000, records[7][1])  # 3 us after the previous one: still on the wire
    assert overlaps(records) == [7]


def test_the_boundary_is_wire_time_plus_gap() -> None:
    frame = golden.build("ecat_all_commands")[0][1]
    assert len(frame) == 60
    # the next frame of the sender: another datagram index (byte 17). The same frame again
    # would be taken for its return through a ring (see the closed-ring test in test_check)
    other = frame[:17] + bytes([frame[17] ^ 1]) + frame[18:]
    start = 60_001  # not whole microseconds: nanosecond resolution, no tolerance
    assert overlaps([(start, frame), (start + NEED_NS, other)]) == []
    assert overlaps([(start, frame), (start + NEED_NS - 1, other)]) == [1]


def test_other_senders_and_interfaces_do_not_overlap(tmp_path: Path) -> None:
    frame = golden.build("ecat_all_commands")[0][1]
    other = frame[:6] + bytes.fromhex("00005e005302") + frame[12:]
    assert overlaps([(0, frame), (1000, other)]) == []
    path = tmp_path / "ports.pcapng"
    with CaptureWriter(path, ports=2) as w:
        w.write(0, frame, port=0)
        w.write(1000, frame, port=1)
    report = check_capture(read_capture(path))
    assert [f for f in report.findings if f.finding.code == "eth.overlap"] == []


def test_speed_per_interface() -> None:
    gigabit = OverlapChecker({0: 1_000_000_000})
    assert gigabit.wire_ns(0, 60, fcs_captured=False) == 576
    assert gigabit.wire_ns(0, 64, fcs_captured=True) == 576
    assert gigabit.feed(0, 0, 0, bytes(6), 60, False) == []
    assert gigabit.feed(1, 672, 0, bytes(6), 60, False) == []
    assert [f.code for f in gigabit.feed(2, 1343, 0, bytes(6), 60, False)] == ["eth.overlap"]
    assert OverlapChecker().wire_ns(1, 1514, fcs_captured=False) == (8 + 1514 + 4) * 80
