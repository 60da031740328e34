"""Our ASC and candump line parsers (skinframes.canbus.lines) against python-can's readers, and
the record accounting of every CAN log format (skinframes.canbus.log.CanLogReader).

Expected values: what python-can 4.6's ``can.LogReader`` reads from the same file (through
``from_message``), on the project's CAN logs and on random frames written by python-can's own
writers; line counts of hand-written logs; python-can's ``SqliteReader`` for ``.db``.
"""

from __future__ import annotations

import gzip
import io
import sqlite3
from pathlib import Path

import can
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skinframes.canbus import CanFrame, TimedSample, TriangleSample, sample_frames
from skinframes.canbus.lines import LineSkip, LineTally, parse_asc, parse_asc_file
from skinframes.canbus.log import (
    CanLogReader,
    RecordCounts,
    TraceFormatError,
    UnsupportedFormatError,
    from_message,
    read_can_log,
    write_can_log,
)
from skinframes.errors import CaptureError

SHARED_TEXT_LOGS = ["issue_1256.asc", "logfile_errorframes.asc"]


def python_can_frames(path: Path) -> list[CanFrame]:
    with can.LogReader(str(path)) as reader:
        return [from_message(m) for m in reader]


def our_frames(path: Path) -> list[CanFrame]:
    return list(CanLogReader(path))


def skin_log(tmp_path: Path, suffix: str, samples: int = 40) -> Path:
    """A skin log written by write_can_log (python-can's writers)."""
    items = [
        TimedSample(
            1000 * k, TriangleSample(14 - k % 3, k % 16, [k % 256] * 12, k % 4096, k % 16), 1000 * k
        )
        for k in range(samples)
    ]
    path = tmp_path / f"skin{suffix}"
    write_can_log(path, sample_frames(items))
    return path


# --- equal to python-can ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", SHARED_TEXT_LOGS)
def test_asc_parser_equals_python_can_on_third_party_logs(shared_captures: Path, name: str) -> None:
    path = shared_captures / "can" / name
    ours = our_frames(path)
    assert ours == python_can_frames(path) and ours


@pytest.mark.parametrize("suffix", [".asc", ".log", ".asc.gz", ".log.gz"])
def test_parsers_equal_python_can_on_skin_logs(tmp_path: Path, suffix: str) -> None:
    path = skin_log(tmp_path, suffix)
    assert our_frames(path) == python_can_frames(path)
    assert len(our_frames(path)) == 80


_IDS = st.one_of(
    st.tuples(st.integers(0, 0x7FF), st.just(False)),
    st.tuples(st.integers(0, 0x1FFFFFFF), st.just(True)),
)
_FRAMES = st.lists(
    st.one_of(
        st.builds(
            lambda i, d, t: CanFrame(i[0], d, extended=i[1], time_ns=t),
            _IDS,
            st.binary(max_size=8),
            st.integers(0, 10**12).map(lambda us: us * 1000),
        ),
        st.builds(
            lambda i, dlc, t: CanFrame(i[0], b"", extended=i[1], remote=True, dlc=dlc, time_ns=t),
            _IDS,
            st.integers(0, 8),
            st.integers(0, 10**12).map(lambda us: us * 1000),
        ),
        st.builds(
            lambda i, d, t: CanFrame(i[0], d, extended=i[1], fd=True, time_ns=t),
            _IDS,
            st.sampled_from([0, 1, 8, 12, 16, 20, 24, 32, 48, 64]).map(bytes),
            st.integers(0, 10**12).map(lambda us: us * 1000),
        ),
        st.just(CanFrame(0, b"", error=True, time_ns=5000)),
    ),
    min_size=1,
    max_size=40,
)


@pytest.mark.parametrize("suffix", [".asc", ".log"])
@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(frames=_FRAMES)
def test_parsers_equal_python_can_on_random_frames(
    tmp_path: Path, suffix: str, frames: list[CanFrame]
) -> None:
    path = tmp_path / f"random{suffix}"
    write_can_log(path, sorted(frames, key=lambda f: f.time_ns), strict=False)
    theirs = python_can_frames(path)
    assert our_frames(path) == theirs
    assert len(theirs) == len(frames)


def test_block_reader_equals_the_line_reader_across_block_boundaries(tmp_path: Path) -> None:
    path = skin_log(tmp_path, ".asc", samples=3000)  # > BLOCK_CHARS of text
    text = path.read_text()
    lines = text.splitlines()
    # a header in the middle, a frame with fewer bytes than its DLC, no final newline
    lines.insert(2000, "// a comment")
    lines.insert(3000, "   1.000000 1  4E0             Rx   d 8 40 F0")
    text = "\n".join(lines)
    by_line = [x for x in parse_asc(lines) if not isinstance(x, LineSkip)]
    skips: list[tuple[int, LineSkip]] = []
    tally = LineTally(lambda i, s: skips.append((i, s)))
    by_block = [x for block in parse_asc_file(io.StringIO(text), tally) for x in block]
    assert by_block == by_line
    assert tally.lines == len(lines)
    assert [i for i, _ in skips] == [
        i for i, x in enumerate(parse_asc(lines)) if isinstance(x, LineSkip)
    ]


# --- every record accounted ------------------------------------------------------------------------
def test_asc_lines_python_can_passes_over_are_counted_with_reasons(tmp_path: Path) -> None:
    path = skin_log(tmp_path, ".asc", samples=5)  # 10 frames
    lines = path.read_text().splitlines()
    junk = [
        "this is not an ASC line",  # python-can: no regex match, silently passed over
        "   0.000500 1  4E0             Rx   d 8 40 ZZ 00 00 00 00 00 00",  # bad byte
        "",
        "   0.000600 CAN 1 Status:chip status error active",  # an event
    ]
    path.write_text("\n".join([*lines[:6], *junk, *lines[6:]]) + "\n")
    reader = CanLogReader(path)
    frames = list(reader)
    assert len(frames) == 10
    counts = reader.record_counts
    assert counts.records == len(lines) + len(junk) == counts.decoded + counts.skipped
    reasons = dict(counts.skipped_by_reason)
    assert reasons["not an ASC line"] == 2
    assert reasons["empty line"] == 1
    assert reasons["ASC event line, not a CAN frame (start of measurement, statistics, ...)"] == 2
    assert counts.damaged == 2
    assert [s.index for s in reader.damaged] == [6, 7]
    assert "bad CAN frame" in reader.damaged[1].reason
    with pytest.raises(ValueError):  # python-can stops at the bad byte
        python_can_frames(path)


def test_every_trc_line_and_blf_object_is_counted(shared_captures: Path) -> None:
    reader = CanLogReader(shared_captures / "can" / "test_CanMessage_V2_1.trc")
    frames = list(reader)
    text = (shared_captures / "can" / "test_CanMessage_V2_1.trc").read_text().splitlines()
    counts = reader.record_counts
    assert counts.records == len(text) == counts.decoded + counts.skipped
    assert counts.decoded == len(frames) == 11
    comments = sum(1 for ln in text if ln.startswith(";"))
    assert dict(counts.skipped_by_reason)["header or comment line"] == comments
    reader = CanLogReader(shared_captures / "can" / "issue_1905.blf")
    assert len(list(reader)) == 22 and reader.record_counts.records == 22


def test_ethernet_pcap_is_one_reason_many_times(tmp_path: Path) -> None:
    from skinframes.pcap import LINKTYPE_ETHERNET, pcap_bytes

    path = tmp_path / "eth.pcap"
    path.write_bytes(pcap_bytes([(k, bytes(60)) for k in range(1500)], LINKTYPE_ETHERNET))
    reader = CanLogReader(path)
    assert list(reader) == []
    counts = reader.record_counts
    assert counts == RecordCounts(1500, 0, (("linktype 1 record, not SocketCAN", 1500),), 1500)
    assert len(reader.damaged) == 1000  # the first ones listed, all counted


# --- .db and atomic writing ------------------------------------------------------------------------
def test_db_round_trip_every_row_and_replaced(tmp_path: Path) -> None:
    frames = [
        CanFrame(0x400 + k % 0x100, bytes([k % 256] * 8), time_ns=k * 1000) for k in range(1234)
    ]
    path = tmp_path / "x.db"
    assert write_can_log(path, frames) == 1234
    with can.SqliteReader(str(path)) as reader:
        back = [from_message(m) for m in reader]
    assert back == frames
    assert write_can_log(path, frames[:700]) == 700  # replaces, does not append
    with sqlite3.connect(path) as conn:
        assert conn.execute("SELECT COUNT(*) FROM messages").fetchone() == (700,)
    before = path.read_bytes()
    fd = CanFrame(0x123, bytes(12), fd=True)
    with pytest.raises(UnsupportedFormatError):
        write_can_log(path, [*frames, fd])  # refused at the end: nothing changes
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.db"]


@pytest.mark.parametrize("suffix", [".asc", ".blf", ".log", ".trc", ".csv", ".asc.gz", ".pcap"])
def test_every_writer_is_atomic(tmp_path: Path, suffix: str) -> None:
    path = skin_log(tmp_path, suffix)
    before = path.read_bytes()

    def frames_then_interrupt() -> object:
        yield CanFrame(0x410, bytes(8))
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_can_log(path, frames_then_interrupt())  # type: ignore[arg-type]
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
    with pytest.raises(CaptureError, match="does not exist"):
        write_can_log(tmp_path / "missing" / f"x{suffix}", [])


def test_gzip_header_names_the_target_not_the_temporary_file(tmp_path: Path) -> None:
    path = skin_log(tmp_path, ".asc.gz")
    raw = path.read_bytes()
    assert raw[3] & 0x08  # FNAME
    name = raw[10 : raw.index(b"\0", 10)]
    assert name == b"skin.asc"
    assert gzip.decompress(raw).startswith(b"date ")


def test_a_log_without_frames_is_refused_by_the_reader_only_when_nothing_is_readable(
    tmp_path: Path,
) -> None:
    path = tmp_path / "junk.log"
    path.write_text("junk\nmore junk\n")
    with pytest.raises(TraceFormatError):
        list(CanLogReader(path))
    log = read_can_log(skin_log(tmp_path, ".log", samples=1))
    assert log.records is not None and log.records.decoded == 2
