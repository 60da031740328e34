"""CAN log files (skinframes.canbus.log): python-can formats and SocketCAN pcap, in and out.

Expected values: the taxels we encoded, frame counts of the third-party logs from can.md 3
(python-can's own reader agrees), tshark's dissection of our pcaps, cantools' candump parser with
our DBC, and hand-made broken files.
"""

from __future__ import annotations

import io
import random
import struct
from pathlib import Path

import can
import cantools
import numpy as np
import pytest
import tshark_util
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skinframes.canbus import (
    CanFrame,
    TimedSample,
    TriangleSample,
    dbc_text,
    sample_frames,
)
from skinframes.canbus.log import (
    CanLog,
    TraceFormatError,
    UnsupportedFormatError,
    can_log_format,
    from_message,
    read_can_log,
    read_frames,
    to_message,
    write_can_log,
)
from skinframes.errors import DecodeError, FieldRangeError
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, LINKTYPE_ETHERNET, pcap_bytes, read_capture
from skinframes.taxel import contact_pattern

FORMATS = [".log", ".asc", ".blf", ".trc", ".csv", ".db", ".pcap"]
GZIPPED = [".log.gz", ".asc.gz", ".trc.gz", ".csv.gz"]
BOARDS = (14, 13, 12)
PERIOD_NS = 50_000_000  # can.md 1.5: 50 ms firmware period
FRAME_SLOT_NS = 130_000  # a skin frame takes at most 135 us at 1 Mbit/s; stamps on whole us


def skin_samples(periods: int = 3, seed: int = 1) -> list[TimedSample]:
    """Seeded contact patterns on three boards, 16 triangles each, stamped on whole microseconds."""
    taxels = contact_pattern(len(BOARDS), periods, seed=seed)  # (periods, boards, 16, 12)
    out = []
    for k in range(periods):
        slot = 0
        for b, board in enumerate(BOARDS):
            for t in range(16):
                start = k * PERIOD_NS + slot * FRAME_SLOT_NS
                oor = (board * 16 + t) & 0xFFF if t == 5 else 0  # some status bits too
                sample = TriangleSample(
                    board, t, taxels[k, b, t], oor, error=t % 3 if t > 13 else 0
                )
                out.append(TimedSample(start, sample, start + FRAME_SLOT_NS))
                slot += 2
    return out


@pytest.mark.parametrize("suffix", FORMATS + GZIPPED)
def test_skin_log_round_trips_through_every_format(tmp_path: Path, suffix: str) -> None:
    samples = skin_samples()
    frames = sample_frames(samples)
    path = tmp_path / f"skin{suffix}"
    assert write_can_log(path, frames) == len(frames) == 2 * 3 * 16 * len(BOARDS)
    can_log = read_can_log(path)
    assert can_log.format == suffix
    assert [s.sample for s in can_log.samples] == [s.sample for s in samples]
    # times come back relative to the first frame in .asc; .log/.asc/.trc keep microseconds and
    # the stamps here are whole microseconds, so every format gives them back exactly
    t0 = can_log.samples[0].time_ns
    got = [(s.time_ns - t0, s.end_time_ns - t0) for s in can_log.samples]
    want = [(s.time_ns, s.end_time_ns) for s in samples]
    assert got == want
    c = can_log.counts
    assert (c.frames, c.samples, c.other, c.orphan_heads, c.malformed) == (288, 144, 0, 0, 0)
    assert c.accounted and can_log.skipped == () and can_log.total == 288
    # python-can's reader sees the same number of messages
    if suffix != ".pcap":
        with can.LogReader(str(path)) as reader:
            assert sum(1 for _ in reader) == 288


def test_candump_log_decodes_with_cantools_and_our_dbc(tmp_path: Path) -> None:
    samples = skin_samples(periods=1)
    path = tmp_path / "skin.log"
    write_can_log(path, sample_frames(samples))
    lines = path.read_text().splitlines()
    # candump -L style, as can.md 4 shows: "(1700000000.000000) vcan0 4E0#40F0EFEEEDECEBEA R"
    assert lines[0].startswith("(0.000000) vcan0 4E0#40")
    db = cantools.database.load_string(dbc_text(BOARDS), "dbc")
    parser = cantools.logreader.Parser(io.StringIO(path.read_text()))
    decoded = [db.decode_message(e.frame_id, e.data, decode_choices=False) for e in parser]
    taxels = [
        [d[f"P{k:02d}"] for k in range(7)] + [t[f"P{k:02d}"] for k in range(7, 12)]
        for d, t in zip(decoded[::2], decoded[1::2], strict=True)
    ]
    assert taxels == [list(s.sample.taxels) for s in samples]
    assert [t["OUTOFRANGE"] for t in decoded[1::2]] == [s.sample.out_of_range for s in samples]


MIXED = [
    CanFrame(0x18EBFF00, b"\x01\x02", time_ns=200_000, extended=True),
    CanFrame(0x123, b"", time_ns=300_000, remote=True, dlc=5),
    CanFrame(0x3FF, bytes(8), time_ns=350_000, dlc=13),
    CanFrame(0, b"", time_ns=400_000, error=True),
]


@pytest.mark.tshark
def test_tshark_dissects_our_socketcan_pcap(tmp_path: Path, tshark: str) -> None:
    frames = sample_frames(skin_samples(periods=1)) + MIXED
    frames.sort(key=lambda f: f.time_ns)
    path = tmp_path / "skin.pcap"
    write_can_log(path, frames)
    assert [r.linktype for r in read_capture(path)] == [LINKTYPE_CAN_SOCKETCAN] * len(frames)
    assert tshark_util.problems(tshark, path) == []
    names = ["frame.protocols", "can.id", "can.len", "can.flags.xtd", "can.flags.rtr", "data.data"]
    rows = tshark_util.fields(tshark, path, names)
    assert len(rows) == len(frames)
    for f, row in zip(frames, rows, strict=True):
        if f.error:
            assert row["frame.protocols"] == ["can"]
            continue
        assert row["frame.protocols"] == ["can:data"]
        assert int(row["can.id"][0], 0) == f.arbitration_id
        assert int(row["can.len"][0], 0) == (min(f.dlc_field, 8) if f.remote else len(f.data))
        assert row["can.flags.xtd"] == [str(int(f.extended))]
        assert row["can.flags.rtr"] == [str(int(f.remote))]
        if not f.remote:
            assert bytes.fromhex(row["data.data"][0]) == f.data


# --- third-party logs (can.md 3: python-can test data) --------------------------------------------
THIRD_PARTY = {  # file: (frames, error frames, CAN FD frames)
    "issue_1256.asc": (1457, 0, 0),
    "issue_1905.blf": (22, 0, 22),
    "logfile_errorframes.asc": (12, 3, 0),
    "test_CanMessage.trc": (2, 0, 0),
    "test_CanMessage_V2_1.trc": (11, 0, 0),
}


@pytest.mark.parametrize("name", sorted(THIRD_PARTY))
def test_third_party_logs_are_read_and_accounted(shared_captures: Path, name: str) -> None:
    path = shared_captures / "can" / name
    frames, errors, fd = THIRD_PARTY[name]
    can_log = read_can_log(path)
    assert can_log.total == can_log.counts.frames == frames
    with can.LogReader(str(path)) as reader:
        assert sum(1 for _ in reader) == frames
    assert can_log.samples == () and can_log.skipped == () and can_log.malformed == ()
    assert can_log.counts.accounted
    assert can_log.counts.error_frames == errors
    assert can_log.counts.other == frames - errors
    assert sum(f.fd for f in can_log.frames) == fd
    assert sum(i.count for i in can_log.counts.other_ids) == frames - errors


def test_issue_1256_ids_are_counted(shared_captures: Path) -> None:
    can_log = read_can_log(shared_captures / "can" / "issue_1256.asc")
    ids = {i.arbitration_id: i.count for i in can_log.counts.other_ids}
    text = (shared_captures / "can" / "issue_1256.asc").read_text()
    # count the lines per ID column by hand: "<time> 1  64   Rx   d 4 ..."
    for ident in (0x64, 0x11, 0x12):
        lines = [ln for ln in text.splitlines() if f" 1  {ident:X} " in ln]
        assert ids[ident] == len(lines) > 0


# --- bad input gives our errors only ---------------------------------------------------------------
def test_unknown_suffix_and_missing_file(tmp_path: Path) -> None:
    (tmp_path / "x.txt").write_text("hello\n")
    for name in ("x.txt", "x", "x.blf.gz", "x.mf4"):
        with pytest.raises(TraceFormatError):
            read_can_log(tmp_path / name)
    with pytest.raises(TraceFormatError, match="cannot read"):
        read_can_log(tmp_path / "missing.asc")
    with pytest.raises(UnsupportedFormatError):
        write_can_log(tmp_path / "out.txt", [])
    with pytest.raises(UnsupportedFormatError):
        write_can_log(tmp_path / "out.pcapng", [])
    assert can_log_format("A.LOG.GZ") == ".log.gz"


def _skin_file(tmp_path: Path, suffix: str) -> Path:
    path = tmp_path / f"skin{suffix}"
    write_can_log(path, sample_frames(skin_samples(periods=1)))
    return path


def test_junk_line_is_skipped_with_its_reason_and_reading_goes_on(tmp_path: Path) -> None:
    path = _skin_file(tmp_path, ".log")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([*lines[:10], "this is not candump", *lines[10:]]) + "\n")
    can_log = read_can_log(path)
    assert can_log.counts.frames == 96 and can_log.counts.samples == 48
    (skipped,) = can_log.skipped
    assert skipped.index == 10 and "not a candump line" in skipped.reason
    assert can_log.total == 97
    assert can_log.records is not None
    assert (can_log.records.records, can_log.records.decoded, can_log.records.skipped) == (
        97,
        96,
        1,
    )
    path.write_text("this is not candump\nnor this\n")
    with pytest.raises(TraceFormatError, match=r"not a readable \.log CAN log"):
        read_can_log(path)


def test_truncated_blf_is_reported(tmp_path: Path) -> None:
    path = _skin_file(tmp_path, ".blf")
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) * 2 // 3])
    can_log = read_can_log(path)
    assert can_log.counts.frames < 96
    assert can_log.skipped and "truncated BLF" in can_log.skipped[-1].reason
    assert "96 objects" in can_log.skipped[-1].reason
    path.write_bytes(b"")
    with pytest.raises(TraceFormatError):
        read_can_log(path)


def test_truncated_gzip_is_reported(tmp_path: Path) -> None:
    path = _skin_file(tmp_path, ".asc.gz")
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])
    can_log = read_can_log(path)
    assert 0 < can_log.counts.frames < 96
    (skipped,) = can_log.skipped
    assert "reader stopped" in skipped.reason and "EOFError" in skipped.reason
    assert can_log.total == can_log.counts.frames + 1


def test_pcap_records_that_are_not_socketcan_are_skipped(tmp_path: Path) -> None:
    good = CanFrame(0x410, bytes(8)).to_socketcan()
    path = tmp_path / "mixed.pcap"
    truncated = struct.pack(">IB3x", 0x410, 8) + bytes(3)
    path.write_bytes(pcap_bytes([(0, good), (1, truncated), (2, good)], LINKTYPE_CAN_SOCKETCAN))
    can_log = read_can_log(path)
    assert (can_log.counts.frames, [s.index for s in can_log.skipped], can_log.total) == (2, [1], 3)
    path.write_bytes(pcap_bytes([(0, bytes(60))], LINKTYPE_ETHERNET))
    can_log = read_can_log(path)
    assert can_log.counts.frames == 0 and "linktype 1" in can_log.skipped[0].reason
    path.write_bytes(b"not a pcap at all")
    with pytest.raises(DecodeError):
        read_can_log(path)


@pytest.mark.parametrize("suffix", [*FORMATS, ".asc.gz"])
@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(junk=st.binary(max_size=400), cut=st.floats(0, 1))
def test_damaged_files_raise_only_our_errors(
    tmp_path: Path, suffix: str, junk: bytes, cut: float
) -> None:
    path = tmp_path / f"bad{suffix}"
    if path.exists():
        path.unlink()
    write_can_log(path, sample_frames(skin_samples(periods=1))[:40])
    raw = path.read_bytes()
    at = int(len(raw) * cut)
    path.write_bytes(raw[:at] + junk + raw[at + len(junk) :])  # overwrite a stretch with junk
    try:
        can_log = read_can_log(path)
    except DecodeError:
        return
    assert isinstance(can_log, CanLog)
    assert can_log.counts.accounted
    assert can_log.total == can_log.counts.frames + len(can_log.skipped)


def test_random_files_raise_only_our_errors(tmp_path: Path) -> None:
    rng = random.Random(5)
    for suffix in [*FORMATS, *GZIPPED]:
        for size in (0, 1, 10, 100, 1000):
            path = tmp_path / f"random{suffix}"
            path.write_bytes(bytes(rng.randrange(256) for _ in range(size)))
            try:
                can_log = read_can_log(path)
            except DecodeError:
                continue
            assert can_log.counts.accounted


# --- writing ---------------------------------------------------------------------------------------
def test_writers_refuse_frames_they_would_lose(tmp_path: Path) -> None:
    remote, error = MIXED[1], MIXED[3]
    fd = CanFrame(0x123, bytes(12), fd=True)
    for suffix, frame in ((".trc", remote), (".trc", error), (".trc", fd), (".log", remote)):
        with pytest.raises(UnsupportedFormatError):
            write_can_log(tmp_path / f"x{suffix}", [frame])
    for suffix in (".csv", ".db"):
        with pytest.raises(UnsupportedFormatError):
            write_can_log(tmp_path / f"x{suffix}", [fd])
    # strict=False: TRC drops them, the others write what they can
    base = CanFrame(0x410, bytes(8))
    assert write_can_log(tmp_path / "y.trc", [base, remote, error, fd], strict=False) == 1
    assert read_can_log(tmp_path / "y.trc").counts.frames == 1
    assert write_can_log(tmp_path / "y.log", [base, remote], strict=False) == 2
    _, frames, _ = read_frames(tmp_path / "y.log")
    assert frames[1].remote and frames[1].dlc_field == 0  # candump keeps no DLC for remote frames


def key(f: CanFrame) -> tuple[int, bytes, bool, bool, bool, int]:
    if f.error:  # error frames carry error-class data in SocketCAN, none in python-can
        return (0, b"", False, False, True, 0)
    return (f.arbitration_id, f.data, f.extended, f.remote, f.error, f.dlc_field)


@pytest.mark.parametrize("suffix", [".asc", ".blf", ".pcap"])
def test_formats_that_keep_every_kind_of_frame(tmp_path: Path, suffix: str) -> None:
    frames = [CanFrame(0x410, bytes(8)), *MIXED]
    if suffix != ".pcap":  # python-can has no classic DLC 9..15
        frames = [f for f in frames if f.dlc_field <= 8]
    write_can_log(tmp_path / f"z{suffix}", frames)
    assert [key(f) for f in read_can_log(tmp_path / f"z{suffix}").frames] == [
        key(f) for f in frames
    ]


def test_python_can_messages(tmp_path: Path) -> None:
    msg = to_message(CanFrame(0x4E0, bytes(8), time_ns=1_500_000_000, channel=1))
    want = can.Message(
        timestamp=1.5, arbitration_id=0x4E0, is_extended_id=False, data=bytes(8), channel=1
    )
    assert msg.equals(want, timestamp_delta=None)
    assert from_message(msg) == CanFrame(0x4E0, bytes(8), time_ns=1_500_000_000, channel=1)
    remote = to_message(CanFrame(0x123, b"", remote=True, dlc=3))
    assert remote.is_remote_frame and remote.dlc == 3
    assert from_message(remote) == CanFrame(0x123, b"", remote=True, dlc=3)
    assert from_message(to_message(CanFrame(0, b"", error=True))).error
    with pytest.raises(FieldRangeError):
        to_message(CanFrame(0x410, bytes(8), time_ns=-1))
    with pytest.raises(FieldRangeError):
        to_message(CanFrame(0x3FF, bytes(8), dlc=13))  # python-can has no classic DLC 9..15
    with pytest.raises(FieldRangeError):
        write_can_log(tmp_path / "neg.asc", [CanFrame(0x410, bytes(8), time_ns=-5)])
    # a classic frame with > 8 bytes (how .csv/.db return CAN FD frames) is CAN FD
    fd = can.Message(arbitration_id=0x1, is_extended_id=False, data=bytes(12), dlc=12)
    assert from_message(fd).fd


def test_numpy_taxels_survive_a_can_log(tmp_path: Path) -> None:
    # a whole patch per board, as skinframes.taxel models it, through BLF
    taxels = contact_pattern(1, 1, seed=3)[0, 0]
    samples = [TimedSample(t * 250_000, TriangleSample(7, t, taxels[t]), t * 250_000 + 125_000)
               for t in range(16)]  # fmt: skip
    write_can_log(tmp_path / "p.blf", sample_frames(samples))
    got = read_can_log(tmp_path / "p.blf").samples
    assert np.array_equal(np.array([s.sample.taxels for s in got], dtype=np.uint8), taxels)


def test_the_old_trace_names_are_aliases_of_the_can_log_names() -> None:
    from skinframes.canbus import log

    aliases = {
        "Trace": "CanLog",
        "read_trace": "read_can_log",
        "write_trace": "write_can_log",
        "trace_format": "can_log_format",
        "TRACE_SUFFIXES": "PYTHON_CAN_SUFFIXES",
    }
    for old, new in aliases.items():
        assert getattr(log, old) is getattr(log, new), old
        assert {old, new} <= set(log.__all__)


def test_a_socketcan_pcap_is_read_record_by_record(tmp_path: Path) -> None:
    """tracemalloc counts the bytes Python allocates (not time): eight times the records may
    cost a few bytes more per record, far less than a record held (object, bytes, list slot)."""
    from memory_util import traced_peak

    from skinframes.canbus.log import CanLogReader

    def peak_bytes(frames: int) -> int:
        path = tmp_path / f"{frames}.pcap"
        write_can_log(
            path, (CanFrame(0x4E0 | k % 16, bytes(8), time_ns=1000 * k) for k in range(frames))
        )

        def work() -> None:
            reader = CanLogReader(path)
            assert sum(1 for _ in reader) == frames == reader.record_counts.decoded

        return traced_peak(work)

    small, large = 2_000, 16_000
    peak_bytes(small)  # warm up: imports, caches
    growth = peak_bytes(large) - peak_bytes(small)
    assert growth < 8 * (large - small), f"{growth / (large - small):.1f} bytes per record"
