"""pcapng ``if_speed`` (draft-ietf-opsawg-pcapng 4.2, option 8: u64 bits per second): read per
interface, used by ``check``'s overlap rule, written by our pcapng writer.

The captures here are packed by hand with struct, block by block as the draft lays them out (not
with skinframes' writer). Wire times by hand (IEEE 802.3-2018): a 1000-byte frame without FCS is
8 preamble/SFD + 1000 + 4 FCS = 1012 octets, 80,960 ns at 100 Mbit/s and 8,096 ns at 1 Gbit/s; the
gap is 960 ns or 96 ns. Two such frames 20 us apart overlap at 100 Mbit/s, not at 1 Gbit/s.
"""

from __future__ import annotations

import json
import re
import struct
import subprocess
from pathlib import Path

import pytest

from skinframes import golden
from skinframes.check import check_capture
from skinframes.pcap import CaptureWriter, pcap_bytes, read_capture
from skinframes_cli import main

SENDER = bytes.fromhex("020000000001")
GAP_NS = 20_000  # between the two frames of the sender
GIGABIT = 1_000_000_000


def _frame(tag: int) -> bytes:
    """1000 bytes from SENDER, EtherType 0x88B5 (IEEE local experimental), ``tag`` in byte 14."""
    return bytes.fromhex("ffffffffffff") + SENDER + b"\x88\xb5" + bytes([tag]) + bytes(985)


def _block(e: str, kind: int, body: bytes) -> bytes:
    body += bytes(-len(body) % 4)
    return struct.pack(e + "II", kind, 12 + len(body)) + body + struct.pack(e + "I", 12 + len(body))


def _option(e: str, code: int, value: bytes) -> bytes:
    return struct.pack(e + "HH", code, len(value)) + value + bytes(-len(value) % 4)


def pcapng(speeds: list[int | None], records: list[tuple[int, int, bytes]], e: str = "<") -> bytes:
    """SHB (4.1), one IDB (4.2) per entry of ``speeds`` (Ethernet, microsecond stamps: no
    if_tsresol; ``if_speed`` when not None), then one EPB (4.3) per (interface, time_us, frame)."""
    out = _block(e, 0x0A0D0D0A, struct.pack(e + "IHHq", 0x1A2B3C4D, 1, 0, -1))
    for speed in speeds:
        opts = b"" if speed is None else _option(e, 8, struct.pack(e + "Q", speed))
        opts += struct.pack(e + "HH", 0, 0) if opts else b""
        out += _block(e, 1, struct.pack(e + "HHI", 1, 0, 0) + opts)
    for interface, time_us, data in records:
        head = struct.pack(
            e + "IIIII", interface, time_us >> 32, time_us & 0xFFFFFFFF, len(data), len(data)
        )
        out += _block(e, 6, head + data)
    return out


def capinfos_speeds(tshark: str, path: Path) -> list[str]:
    """The ``Speed =`` of each interface as Wireshark's capinfos (beside tshark) reads them."""
    capinfos = Path(tshark).with_name("capinfos")
    assert capinfos.exists(), f"{capinfos}: Wireshark's capinfos is installed with tshark"
    out = subprocess.run([capinfos, str(path)], capture_output=True, text=True, check=True)
    return re.findall(r"Speed = (\d+)", out.stdout)


def _overlaps(path: Path) -> list[int]:
    """Wireshark frame numbers of the eth.overlap findings of ``check``."""
    report = check_capture(read_capture(path))
    return [f.index + 1 for f in report.findings if f.finding.code == "eth.overlap"]


PAIR = [(1_000, _frame(1)), (1_000 + GAP_NS // 1000, _frame(2))]  # microseconds


@pytest.mark.tshark
@pytest.mark.parametrize("endian", ["<", ">"])
def test_if_speed_is_read_per_interface(tshark: str, tmp_path: Path, endian: str) -> None:
    path = tmp_path / "speeds.pcapng"
    path.write_bytes(pcapng([GIGABIT, None, 0], [(i, 1, _frame(i)) for i in range(3)], endian))
    speeds = [rec.if_speed_bps for rec in read_capture(path)]
    assert speeds == [GIGABIT, None, None]  # 0: unknown, as no option
    assert capinfos_speeds(tshark, path) == [str(GIGABIT), "0"]  # Wireshark reads the same


def test_overlap_is_judged_at_the_interface_speed(tmp_path: Path) -> None:
    fast, slow = tmp_path / "gigabit.pcapng", tmp_path / "unknown.pcapng"
    fast.write_bytes(pcapng([GIGABIT], [(0, t, d) for t, d in PAIR]))
    slow.write_bytes(pcapng([None], [(0, t, d) for t, d in PAIR]))
    assert _overlaps(fast) == []
    assert _overlaps(slow) == [2]  # 100 Mbit/s when the capture does not say
    classic = tmp_path / "classic.pcap"
    classic.write_bytes(pcap_bytes([(t * 1000, d) for t, d in PAIR]))
    assert _overlaps(classic) == [2]


def test_each_interface_has_its_own_speed(tmp_path: Path) -> None:
    path = tmp_path / "two.pcapng"
    (t0, a), (t1, b) = PAIR
    records = [(0, t0, a), (1, t0 + 1, a), (0, t1, b), (1, t1 + 1, b)]  # frames 1..4
    path.write_bytes(pcapng([GIGABIT, None], records))
    assert _overlaps(path) == [4]  # the pair on interface 1 (100 Mbit/s), not on 0 (1 Gbit/s)
    assert main(["check", str(path)]) == 0  # a warning
    report = check_capture(read_capture(path))
    (finding,) = [f.finding for f in report.findings if f.finding.code == "eth.overlap"]
    assert "100 Mbit/s" in finding.message and "interface 1" in finding.message


def test_check_json_names_the_frame(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "unknown.pcapng"
    path.write_bytes(pcapng([None], [(0, t, d) for t, d in PAIR]))
    main(["check", str(path), "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert [f["frame"] for f in doc["findings"] if f["code"] == "eth.overlap"] == [2]


@pytest.mark.tshark
def test_our_writer_writes_if_speed(tshark: str, tmp_path: Path) -> None:
    path = tmp_path / "ring.pcapng"
    frame = golden.build("ecat_all_commands")[0][1]
    with CaptureWriter(path, ports=2, if_speed_bps=100_000_000) as w:
        w.write(0, frame, port=0)
        w.write(1000, frame, port=1)
    assert [rec.if_speed_bps for rec in read_capture(path)] == [100_000_000] * 2
    assert capinfos_speeds(tshark, path) == ["100000000"] * 2


def test_emulated_pcapng_carries_the_link_speed(tmp_path: Path) -> None:
    path = tmp_path / "sim.pcapng"
    assert (
        main(
            [
                "simulate",
                "ecat",
                "--nodes",
                "2",
                "--bytes",
                "8",
                "--closed-ring",
                "--cycles",
                "1",
                "--pcap",
                str(path),
            ]
        )
        == 0
    )
    assert {rec.if_speed_bps for rec in read_capture(path)} == {100_000_000}
