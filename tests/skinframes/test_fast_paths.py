"""The fast reading paths of ``check`` and ``analyze`` give what the record reader gives.

:func:`skinframes.check.check_file` and :func:`skinframes.analysis.analyze_file` read a plain
classic pcap with :func:`skinframes.pcap_plain.iter_plain_pcap` (no ``Record`` objects) and
everything else with :func:`skinframes.pcap.read_capture`. Here both paths run on the same files
and every finding (index, node, severity, code, message), count and statistic must be equal:
the real third-party captures, the golden pcaps, the conformance vectors with their malformed
frames, emulated captures, and hand-made files the reader skips records of or notes findings on
(where the fast path must hand over to the reader). Files whose records the reader reads cleanly
must take the fast path (checked by making the reader's path fail), so the comparison is never
between one path and itself.
"""

from __future__ import annotations

import gzip
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from skinframes import check, ethercat, powerlink, vectors
from skinframes.analysis import analyze_capture, analyze_file
from skinframes.check import CaptureReport, check_capture, check_file
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, pcap_bytes, read_capture
from skinframes.pcap_plain import CHUNK_BYTES, NotPlainError, iter_plain_pcap, record_rows
from skinframes.powerlink import PReq, PRes, SoA, SoC

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "captures"
REAL = sorted(p for p in SHARED.glob("*") if p.suffix in (".pcap", ".pcapng", ".cap"))
GOLDEN = sorted((ROOT / "pcaps").glob("*.pcap"))
MAGIC_US, MAGIC_NS = 0xA1B2C3D4, 0xA1B23C4D  # draft-ietf-opsawg-pcap section 4


def findings(report: CaptureReport) -> list[tuple[int, int | None, int, str, str]]:
    return [
        (f.index, f.node, int(f.finding.severity), f.finding.code, f.finding.message)
        for f in report.findings
    ]


def same_report(path: Path) -> CaptureReport:
    """check_file and check_capture(read_capture) on ``path``: asserted equal; the report."""
    fast = check_file(path)
    slow = check_capture(read_capture(path))
    assert (fast.path, fast.total, dict(fast.counts)) == (slow.path, slow.total, dict(slow.counts))
    assert findings(fast) == findings(slow)
    assert fast.to_json() == slow.to_json()
    return fast


def takes_fast_path(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """check_file reads ``path`` without the record reader's path."""

    def refuse(capture: Any) -> CaptureReport:
        raise AssertionError(f"{path.name}: check_file fell back to check_capture")

    with monkeypatch.context() as m:
        m.setattr(check, "check_capture", refuse)
        check_file(path)
    assert list(iter_plain_pcap(path)) == list(record_rows(read_capture(path)))


def pcap(
    records: list[tuple[int, int, bytes, int]],
    *,
    magic: int = MAGIC_NS,
    order: str = "<",
    snaplen: int = 262144,
    linktype: int = 1,
) -> bytes:
    """A classic pcap packed by hand (section 4-5): (sec, frac, data, orig_len) per record."""
    out = [struct.pack(order + "IHHiIII", magic, 2, 4, 0, 0, snaplen, linktype)]
    for sec, frac, data, orig in records:
        out.append(struct.pack(order + "IIII", sec, frac, len(data), orig) + data)
    return b"".join(out)


def epl_cycle(cycles: int, nodes: int = 3) -> list[bytes]:
    out = []
    for c in range(cycles):
        out.append(powerlink.frame(SoC()).to_bytes())
        for n in range(1, nodes + 1):
            out.append(powerlink.frame(PReq(dest=n, payload=bytes(8))).to_bytes())
            out.append(powerlink.frame(PRes(src=n, payload=bytes([c & 0xFF]) * 8)).to_bytes())
        out.append(powerlink.frame(SoA()).to_bytes())
    return out


def spaced(frames: list[bytes], step_us: int = 100) -> list[tuple[int, int, bytes, int]]:
    return [
        (i * step_us // 1_000_000, i * step_us % 1_000_000 * 1000, f, len(f))
        for i, f in enumerate(frames)
    ]


@pytest.mark.parametrize("path", REAL + GOLDEN, ids=lambda p: p.name)
def test_real_and_golden_captures(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    same_report(path)
    if read_capture(path).format == "pcap" and not read_capture(path).skipped:
        takes_fast_path(path, monkeypatch)


def test_conformance_vectors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every vector, malformed ones included: the same findings by both paths."""
    path = tmp_path / "vectors.pcap"
    path.write_bytes(pcap_bytes([(t, raw) for _, t, raw in vectors.build()]))
    report = same_report(path)
    assert report.errors > 0  # the malformed cases are there
    takes_fast_path(path, monkeypatch)


def test_cycle_order_overlap_and_repeats(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Frames reordered, repeated PRes with other taxels, and frames too close together: the
    cycle, node and overlap findings come out equal."""
    frames = epl_cycle(40)
    frames[5], frames[9] = frames[9], frames[5]  # a PRes before its PReq
    del frames[47]  # cycle 5 (8 frames each) without its SoA
    records = spaced(frames)
    records[60] = (records[59][0], records[59][1] + 1000, records[60][2], records[60][3])
    records[70] = (records[69][0], records[69][1], records[70][2], records[70][3] + 4)  # orig_len
    lrds = [
        ethercat.frame(EcatFrame((Datagram(Command.LRD, 0, 0, bytes(16), idx=i),))).to_bytes()
        for i in range(5)
    ]
    records += [(9, i * 3000, f, len(f)) for i, f in enumerate(lrds)]  # one sender, 3 us apart
    path = tmp_path / "orders.pcap"
    path.write_bytes(pcap(records))
    report = same_report(path)
    codes = {f.finding.code for f in report.findings}
    assert {"epl.cycle.unpolled", "epl.cycle.no_soa", "eth.overlap"} <= codes
    takes_fast_path(path, monkeypatch)


@pytest.mark.parametrize("order", ["<", ">"])
@pytest.mark.parametrize("magic", [MAGIC_US, MAGIC_NS])
def test_byte_orders_and_resolutions(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, order: str, magic: int
) -> None:
    records = [
        (s, f if magic == MAGIC_NS else f // 1000, d, o) for s, f, d, o in spaced(epl_cycle(5))
    ]
    path = tmp_path / "order.pcap"
    path.write_bytes(pcap(records, magic=magic, order=order))
    same_report(path)
    takes_fast_path(path, monkeypatch)


def test_records_across_chunks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """More than one chunk of records of many lengths: records cross every chunk boundary."""
    frames = []
    for i in range(3 * CHUNK_BYTES // 700):
        payload = bytes([i & 0xFF]) * (i * 37 % 1400)
        frames.append(powerlink.frame(PRes(src=1 + i % 200, payload=payload)).to_bytes())
    path = tmp_path / "chunks.pcap"
    path.write_bytes(pcap(spaced(frames, 200)))
    assert path.stat().st_size > 2 * CHUNK_BYTES
    same_report(path)
    takes_fast_path(path, monkeypatch)


@pytest.mark.parametrize("linktype", [LINKTYPE_CAN_SOCKETCAN, 147])
def test_other_linktypes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, linktype: int) -> None:
    can = struct.pack(">IB3x", 0x123, 3) + b"abc" + bytes(5)
    bad = struct.pack(">IB3x", 0x123, 12) + bytes(8)  # len 12 in a classic CAN frame
    path = tmp_path / "can.pcap"
    path.write_bytes(
        pcap([(0, i * 1000, d, len(d)) for i, d in enumerate([can, bad, can])], linktype=linktype)
    )
    same_report(path)
    takes_fast_path(path, monkeypatch)


GOOD = spaced(epl_cycle(3))


@pytest.mark.parametrize(
    "name, raw",
    [
        ("truncated record header", pcap(GOOD) + b"\x00" * 5),
        ("truncated record", pcap(GOOD)[:-7]),
        ("caplen over snaplen", pcap(GOOD, snaplen=40)),
        ("fraction out of range", pcap([*GOOD[:3], (0, 10**9, GOOD[3][2], 60), *GOOD[4:]])),
        (
            "us fraction out of range",
            pcap(
                [(0, 10**6, GOOD[0][2], 60), *((s, f // 1000, d, o) for s, f, d, o in GOOD)],
                magic=MAGIC_US,
            ),
        ),
        ("record too long", pcap(GOOD) + struct.pack("<IIII", 1, 0, 262145, 262145)),
        ("short frame", pcap([*GOOD, (1, 0, b"\x01" * 10, 10)])),
        ("header only", pcap([])),
    ],
)
def test_hostile_files(tmp_path: Path, name: str, raw: bytes) -> None:
    """What the reader skips or notes: the fast path hands over; the findings are equal."""
    path = tmp_path / "hostile.pcap"
    path.write_bytes(raw)
    same_report(path)
    capture = read_capture(path)
    if capture.skipped or capture.findings:
        with pytest.raises(NotPlainError):
            list(iter_plain_pcap(path))
    same_analysis(path)


def test_other_formats_use_the_reader(tmp_path: Path) -> None:
    """gzip (and pcapng, among the real captures) go through the reader: the same report."""
    path = tmp_path / "cycle.pcap.gz"
    path.write_bytes(gzip.compress(pcap(GOOD)))
    same_report(path)
    with pytest.raises(NotPlainError):
        list(iter_plain_pcap(path))


# --- analyze -------------------------------------------------------------------------------------
def same_analysis(path: Path) -> None:
    fast = analyze_file(path).to_json()
    slow = analyze_capture(read_capture(path)).to_json()
    assert fast == slow


@pytest.mark.parametrize("path", REAL + GOLDEN, ids=lambda p: p.name)
def test_analyze_real_and_golden(path: Path) -> None:
    same_analysis(path)


def test_analyze_emulated(tmp_path: Path) -> None:
    from emulator import WIRE, simulate_ecat, simulate_epl

    epl, ecat = tmp_path / "epl.pcap", tmp_path / "ecat.pcap"
    simulate_epl(4, 32, WIRE, cycles=50, asnd=True, pcap=epl)
    simulate_ecat(4, 32, WIRE, cycles=50, pcap=ecat, closed_ring=True)
    for path in (epl, ecat):
        same_analysis(path)
    records = spaced(epl_cycle(40))
    del records[30]  # a PRes missing
    path = tmp_path / "missing.pcap"
    path.write_bytes(pcap(records))
    same_analysis(path)


# --- what a command imports ----------------------------------------------------------------------
def test_check_imports_no_numpy() -> None:
    """``check`` starts without numpy, the emulator, matplotlib, scapy or tqdm (the other
    commands' modules are not imported: their imports cost ``check`` its start-up time)."""
    path = GOLDEN[0]
    code = (
        "import sys\nfrom skinframes_cli import main\n"
        f"main(['check', {str(path)!r}])\n"
        "print(sorted(m for m in ('numpy', 'emulator', 'matplotlib', 'scapy', 'tqdm') "
        "if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False
    ).stdout
    assert out.splitlines()[-1] == "[]"


# --- judged bytes --------------------------------------------------------------------------------
def ecat_frame(*datagrams: Datagram, tail: bytes = b"") -> bytes:
    return ethercat.frame(EcatFrame(datagrams)).to_bytes() + tail


def lrd(data: bytes, wkc: int = 0, idx: int = 0, cmd: int = Command.LRD) -> Datagram:
    return Datagram(cmd, 0, 0, data, idx=idx, wkc=wkc)


SEQUENCE = [
    ecat_frame(lrd(b"\x01" * 16), lrd(b"\x02" * 16)),
    ecat_frame(lrd(b"\x03" * 16), lrd(b"\x04" * 16)),  # other data: the same judged bytes
    ecat_frame(lrd(b"\x03" * 16, wkc=1), lrd(b"\x04" * 16)),  # another working counter
    ecat_frame(lrd(b"\x03" * 16, idx=7), lrd(b"\x04" * 16)),  # another index
    ecat_frame(lrd(b"\x03" * 16, cmd=Command.APRD), lrd(b"\x04" * 16)),  # not logical: whole
    ecat_frame(lrd(b"\x03" * 16), lrd(b"\x04" * 16, cmd=Command.LRW)),
    ecat_frame(lrd(b"\x03" * 8), lrd(b"\x04" * 24)),  # same length, other split
    ecat_frame(lrd(b"\x03" * 16), lrd(b"\x04" * 16), tail=b"\xaa" * 4),  # an FCS: whole
    ecat_frame(lrd(b"\x03" * 16), lrd(b"\x04" * 16), tail=b"\xaa" * 3),
    ecat_frame(lrd(b"\x05" * 16), lrd(b"\x06" * 16), tail=b"\xbb" * 3),
    powerlink.frame(PRes(src=1, payload=bytes(48))).to_bytes(),  # EPL of an equal length (72)
    ecat_frame(lrd(b"\x07" * 16), lrd(b"\x08" * 16)),
]


def test_judged_bytes_remembered_layout_is_exact() -> None:
    """JudgedBytes (the last EtherCAT layout remembered) equals judged_bytes frame by frame:
    on frames that differ from the one before in each judged field, and on every frame of the
    conformance vectors, real and golden captures, in order."""
    judged = check.JudgedBytes()
    frames = SEQUENCE + [raw for _, _, raw in vectors.build()]
    for path in REAL + GOLDEN:
        frames += [r.data for r in read_capture(path) if r.linktype == 1]
    for i, data in enumerate(frames):
        for variant in (data, data[:-1], bytearray(data)):  # cut and mutable copies too
            assert judged(bytes(variant)) == check.judged_bytes(bytes(variant)), i
    assert len(SEQUENCE[-2]) == len(SEQUENCE[-1]) == len(SEQUENCE[0])  # EPL amid EtherCAT
    keys = [check.judged_bytes(f) for f in SEQUENCE]
    assert keys[0] == keys[1] and len(set(keys[1:7])) == 6 and keys[8] != keys[9]


def test_overlap_shortcut_keeps_the_boundary() -> None:
    """OverlapChecker's shortcut (apart by more than the previous frame's wire time + gap) and
    its remembered wire times leave the boundary where IEEE 802.3 puts it: a long frame, then a
    short one, need the short one's wire time + gap (100 Mbit/s: (8 + 60 + 4) x 80 ns + 960 ns
    = 6720 ns), at every repetition."""
    for dt, want in ((6719, ["eth.overlap"]), (6720, []), (20_000, []), (-5, [])):
        checker = check.OverlapChecker()
        for i in range(3):
            t0 = i * 1_000_000 + 1  # nanosecond stamps: no tick of tolerance
            assert checker.feed(2 * i, t0, 0, bytes(6), 1514, False) == []
            found = checker.feed(2 * i + 1, t0 + dt, 0, bytes(6), 60, False)
            assert [f.code for f in found] == want, (dt, i)


@pytest.mark.parametrize(
    "path",
    [ROOT / "pcaps" / "epl_cycle_4cn.pcap", SHARED / "epl-viz_1CN.pcapng"],  # plain, not plain
    ids=lambda p: p.name,
)
def test_check_counts_every_record_once_for_the_progress_bar(path: Path) -> None:
    seen: list[int] = []
    report = check_file(path, progress=seen.append)
    assert sum(seen) == report.total == read_capture(path).total
    assert all(n <= check.PROGRESS_EVERY for n in seen)
