"""CAN log files in and out: python-can's formats and SocketCAN pcap, accounted frame by frame.

Formats (can.md 4-5):

- python-can 4.6 ``can.LogReader`` / ``can.Logger``: Vector ASCII ``.asc``, Vector binary ``.blf``,
  candump ``.log`` (``candump -l`` / ``-L``), PEAK ``.trc``, python-can ``.csv``, python-can
  SQLite ``.db``; the text formats also gzip-compressed (``.asc.gz``, ...). ``.mf4`` needs
  ``asammdf`` and is not offered.
- SocketCAN pcap (``.pcap``, ``.pcapng``, ``.cap``, gzip too): LINKTYPE_CAN_SOCKETCAN (227)
  records, each a Linux ``struct can_frame`` with the CAN-id word big-endian
  (:meth:`skinframes.canbus.CanFrame.to_socketcan`); read with :func:`skinframes.pcap.read_capture`.

Reading never crashes on a log that is not skin data: :func:`read_can_log` decodes every frame
it can and accounts for all of them, ``log.total == log.counts.frames + len(log.skipped)``,
with ``counts`` splitting the frames into samples, orphans, malformed skin frames, other frames
and error frames. A file that cannot be read at all raises :class:`CanLogFormatError`; damage after
some good frames (a junk line that stops python-can's reader, a truncated BLF) becomes one
skipped entry with the reason, after the frames before it.

What python-can's writers lose (checked with python-can 4.6.1): ``.trc`` drops CAN FD, remote and
error frames; ``.log`` drops the DLC of remote frames; ``.csv`` and ``.db`` drop the CAN FD flag.
:func:`write_can_log` refuses such frames unless ``strict=False``. Timestamps: ``.asc`` comes back
relative to the start of the measurement (python-can's default), ``.log``, ``.asc`` and ``.trc``
keep microseconds only; ``.blf``, ``.csv`` and ``.db`` pass through float seconds (exact to the
nanosecond near 0, to ~0.2 us for Unix-epoch times).

Names: a CAN log is what CAN tools call a trace; skinframes keeps "trace" for the emulator's frame
traces. The old names stay as aliases: ``Trace`` = :class:`CanLog`, ``read_trace`` =
:func:`read_can_log`, ``write_trace`` = :func:`write_can_log`, ``trace_format`` =
:func:`can_log_format`, ``TRACE_SUFFIXES`` = :data:`PYTHON_CAN_SUFFIXES`.
"""

from __future__ import annotations

import contextlib
import gzip
import io
import itertools
import logging
import zlib
from collections import Counter
from collections.abc import Collection, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Final, TextIO, cast

from skinframes.atomic_file import atomic_path
from skinframes.canbus.codec import SKIN_CLASS
from skinframes.canbus.lines import (
    ASC_NOT_A_LINE,
    BLOCK_CHARS,
    CANDUMP_NOT_A_LINE,
    EMPTY,
    STREAM_BLOCK_CHARS,
    DataTuple,
    LineSkip,
    LineTally,
    parse_asc_file,
    parse_candump_file,
)
from skinframes.canbus.reassembly import FrameCounts, Malformed, Reassembler, TimedSample
from skinframes.canbus.wire import MAX_DATA_BYTES, MAX_DLC, CanFrame
from skinframes.errors import (
    CanLogFormatError,
    DecodeError,
    FieldRangeError,
    TraceFormatError,
    UnsupportedFormatError,
)
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, PcapWriter, Skipped, read_capture

__all__ = [
    "PCAP_SUFFIXES",
    "PYTHON_CAN_SUFFIXES",
    "STREAM_SUFFIXES",
    "TRACE_SUFFIXES",
    "CanLog",
    "CanLogFormatError",
    "CanLogReader",
    "RecordCounts",
    "Trace",
    "TraceFormatError",
    "UnsupportedFormatError",
    "can_log_format",
    "from_message",
    "read_can_log",
    "read_frames",
    "read_trace",
    "to_message",
    "trace_format",
    "write_can_log",
    "write_trace",
]

logger = logging.getLogger(__name__)

PYTHON_CAN_SUFFIXES: Final = (".asc", ".blf", ".csv", ".db", ".log", ".trc")  # python-can 4.6
TEXT_SUFFIXES: Final = (".asc", ".csv", ".log", ".trc")  # python-can reads and writes them gzipped
PCAP_SUFFIXES: Final = (".pcap", ".pcapng", ".cap")
# formats read from a stream as it comes (CanLogReader(stream=...)); BLF and SQLite need a file
STREAM_SUFFIXES: Final = (*TEXT_SUFFIXES, *PCAP_SUFFIXES)
NS_PER_S: Final = 1_000_000_000
# frames each python-can writer cannot store as given (probed with python-can 4.6.1)
_LOSSY: Final = {
    ".trc": ("fd", "remote", "error"),  # TRCWriter logs "not implemented" and drops them
    ".log": ("remote_dlc",),  # candump "123#R" keeps no DLC
    ".csv": ("fd",),  # no FD column: comes back as a classic frame with > 8 bytes
    ".db": ("fd",),
}


@dataclass(frozen=True, slots=True)
class CanLog:
    """Everything read from a CAN log file (what CAN tools call a trace).

    Attributes:
        path: the file.
        format: its format suffix (``".asc"``, ``".log.gz"``, ``".pcap"``, ...).
        frames: every frame read, in file order (times in ns as the file gives them).
        samples: the skin samples reassembled from ``frames`` (see :class:`~skinframes.canbus.Reassembler`).
        counts: where each frame went; ``counts.frames == len(frames)``.
        malformed: frames with a skin identifier that were not skin data, with the reason.
        skipped: what could not be read, with the reason (a damaged tail is one entry; the
            first :data:`MAX_LISTED_DAMAGE` damaged records).
        records: every record of the file, decoded or skipped with its reason.
    """

    path: str
    format: str
    frames: tuple[CanFrame, ...]
    samples: tuple[TimedSample, ...]
    counts: FrameCounts
    malformed: tuple[Malformed, ...]
    skipped: tuple[Skipped, ...]
    records: RecordCounts | None = None

    @property
    def total(self) -> int:
        """Frames (records) found in the file: read + damaged (headers, comments and events
        are not counted; :attr:`records` has every record)."""
        damaged = len(self.skipped) if self.records is None else self.records.damaged
        return self.counts.frames + damaged


def can_log_format(path: str | Path) -> str:
    """The format suffix of ``path`` (``".asc"``, ``".asc.gz"``, ``".pcap"``, ...).

    Raises:
        CanLogFormatError: not a suffix skinframes reads or writes.
    """
    suffixes = [s.lower() for s in Path(path).suffixes]
    last = suffixes[-1] if suffixes else ""
    if last in PYTHON_CAN_SUFFIXES or last in PCAP_SUFFIXES:
        return last
    if last == ".gz" and len(suffixes) >= 2:
        inner = suffixes[-2]
        if inner in TEXT_SUFFIXES or inner in PCAP_SUFFIXES:
            return inner + ".gz"
    known = ", ".join([*PYTHON_CAN_SUFFIXES, *PCAP_SUFFIXES])
    raise CanLogFormatError(
        f"{path}: unknown CAN log format {''.join(suffixes[-2:]) or '(no suffix)'!r}; "
        f"known: {known} (text formats and pcaps also .gz)"
    )


# --- python-can messages <-> CanFrame -------------------------------------------------------------
def from_message(msg: Any) -> CanFrame:
    """A :class:`CanFrame` from a ``can.Message`` (timestamp in s -> ns, rounded).

    A classic frame with more than 8 data bytes (as ``.csv``/``.db`` return CAN FD frames) is
    marked ``fd``; a classic DLC 9..15 with 8 bytes is kept in ``dlc``.
    """
    time_ns = round(float(msg.timestamp) * NS_PER_S)
    channel = msg.channel if isinstance(msg.channel, int | str) else None
    if msg.is_error_frame:
        return CanFrame(0, b"", time_ns=time_ns, error=True, channel=channel)
    data = bytes(msg.data or b"")
    ident = int(msg.arbitration_id)
    extended = bool(msg.is_extended_id)
    if msg.is_remote_frame:
        dlc = int(msg.dlc) if 0 <= int(msg.dlc) <= MAX_DLC else None
        return CanFrame(
            ident, b"", time_ns=time_ns, extended=extended, remote=True, dlc=dlc, channel=channel
        )
    if msg.is_fd or len(data) > MAX_DATA_BYTES:
        return CanFrame(ident, data, time_ns=time_ns, extended=extended, fd=True, channel=channel)
    dlc = int(msg.dlc)
    keep = dlc if len(data) == MAX_DATA_BYTES and MAX_DATA_BYTES < dlc <= MAX_DLC else None
    return CanFrame(ident, data, time_ns=time_ns, extended=extended, dlc=keep, channel=channel)


def to_message(frame: CanFrame) -> Any:
    """A ``can.Message`` (created with ``check=True``) for ``frame``.

    Raises:
        FieldRangeError: python-can rejects the frame (negative time, id or DLC out of range;
            python-can has no classic DLC 9..15).
    """
    import can  # python-can; imported here so that skinframes imports fast without it

    kwargs: dict[str, Any] = {
        "timestamp": frame.time_ns / NS_PER_S,
        "is_extended_id": frame.extended,
        "check": True,
    }
    if frame.channel is not None:
        kwargs["channel"] = frame.channel
    if frame.error:
        kwargs.update(is_error_frame=True, is_extended_id=False)
    elif frame.remote:
        kwargs.update(
            arbitration_id=frame.arbitration_id, is_remote_frame=True, dlc=frame.dlc_field
        )
    else:
        kwargs.update(arbitration_id=frame.arbitration_id, data=frame.data, is_fd=frame.fd)
        if frame.dlc is not None and frame.dlc != len(frame.data):
            raise FieldRangeError(
                f"python-can cannot hold a classic frame with DLC {frame.dlc} "
                f"and {len(frame.data)} bytes",
                field="dlc",
            )
    try:
        return can.Message(**kwargs)
    except (ValueError, TypeError) as exc:
        raise FieldRangeError(f"CAN frame at {frame.time_ns} ns: {exc}") from exc


# --- reading ---------------------------------------------------------------------------------------
MAX_LISTED_DAMAGE: Final = 1000  # damaged records kept with their index; the rest are counted


@dataclass(frozen=True, slots=True)
class RecordCounts:
    """Where every record of a CAN log went: ``records == decoded + skipped``.

    A record is a line of a text log (ASC, candump, TRC, CSV), an object of a BLF, a row of a
    ``.db``, a record of a pcap.

    Attributes:
        records: records found in the file.
        decoded: records that became a CAN frame.
        skipped_by_reason: the others, ``(reason, count)``, most frequent first (a header, a
            comment, an event line, a line that is not a frame, a pcap record of another link type).
        damaged: how many of the skipped records are damage (not a header, comment, event or
            empty line a log carries on purpose); the first ones are :attr:`CanLog.skipped`.
    """

    records: int = 0
    decoded: int = 0
    skipped_by_reason: tuple[tuple[str, int], ...] = ()
    damaged: int = 0

    @property
    def skipped(self) -> int:
        """Records that did not become a frame."""
        return sum(n for _, n in self.skipped_by_reason)

    def to_json(self) -> dict[str, Any]:
        """``{"records", "decoded", "skipped", "skipped_by_reason": {reason: count}}``."""
        return {
            "records": self.records,
            "decoded": self.decoded,
            "skipped": self.skipped,
            "skipped_by_reason": dict(self.skipped_by_reason),
        }


class CanLogReader:
    """The frames of a CAN log file, read one record at a time (memory independent of its size).

    Iterate once; the accounting is complete at the end (skipped records are counted as they
    come): :attr:`record_counts` (every record decoded or skipped with a reason) and
    :attr:`damaged` (the first :data:`MAX_LISTED_DAMAGE` damaged records with their index). ASC
    and candump are read by :mod:`skinframes.canbus.lines`, the other python-can formats by
    python-can's reader, pcaps by :func:`skinframes.pcap.read_capture`.

    ``stream`` (a binary stream, e.g. standard input): the log is read from it as it comes, in
    small blocks (frames come out soon after their lines come in), its format the suffix
    ``log_format`` (``".asc"``, ``".log.gz"``, ...: :data:`STREAM_SUFFIXES`, their ``.gz``);
    ``path`` then only names it in messages.

    Raises:
        CanLogFormatError: ``path`` is a directory, or its suffix is unknown; when iterated:
            an unreadable file, or damaged before the first frame; a stream of a format that
            needs a file (BLF, SQLite).
    """

    def __init__(
        self, path: str | Path, *, stream: IO[bytes] | None = None, log_format: str | None = None
    ) -> None:
        self.path = str(path)
        if stream is None and Path(path).is_dir():  # before its suffix: a folder has none
            raise CanLogFormatError(f"{self.path}: cannot read (is a directory)")
        self.format = can_log_format(path if log_format is None else f"{path}{log_format}")
        self._stream = stream
        if stream is not None and self.format.removesuffix(".gz") not in STREAM_SUFFIXES:
            raise CanLogFormatError(f"{self.path}: a {self.format} log is read from a file only")
        self._block = BLOCK_CHARS if stream is None else STREAM_BLOCK_CHARS
        self._batch = _BATCH_FRAMES if stream is None else _STREAM_BATCH_FRAMES
        self._records = 0
        self._decoded = 0
        self._reasons: Counter[str] = Counter()
        self._damaged = 0
        self.damaged: list[Skipped] = []
        self._used = False

    @property
    def record_counts(self) -> RecordCounts:
        """The accounting so far."""
        return RecordCounts(
            self._records,
            self._decoded,
            tuple(sorted(self._reasons.items(), key=lambda kv: (-kv[1], kv[0]))),
            self._damaged,
        )

    def _skip(
        self, index: int, reason: str, *, detail: str = "", damage: bool = True, count: int = 1
    ) -> None:
        """Count ``count`` records skipped for ``reason``; list damage with its ``detail``."""
        self._reasons[reason] += count
        self._records += count
        if damage:
            self._damaged += count
            if len(self.damaged) < MAX_LISTED_DAMAGE:
                text = f"{reason}: {detail}" if detail else reason
                self.damaged.append(Skipped(index, text[:300]))

    def __iter__(self) -> Iterator[CanFrame]:
        for item in self.items():
            yield item if isinstance(item, CanFrame) else _tuple_frame(item)

    def items(self) -> Iterator[CanFrame | DataTuple]:
        """The frames, plain 11-bit data frames left as :data:`~skinframes.canbus.lines.DataTuple`
        (faster; :meth:`Reassembler.feed_data` takes them as they are)."""
        for batch in self.batches():
            yield from batch

    def batches(self) -> Iterator[list[CanFrame | DataTuple]]:
        """:meth:`items` in lists (a block of the file each): the fastest way through a log."""
        if self._used:
            raise CanLogFormatError(f"{self.path}: a CanLogReader is read once")
        self._used = True
        base = self.format.removesuffix(".gz")
        if base in PCAP_SUFFIXES:
            return _batched(self._pcap(), self._batch)
        if base in (".asc", ".log"):
            return self._lines(base)
        return _batched(self._python_can(base), self._batch)

    # ASC, candump: our line parsers
    def _lines(self, base: str) -> Iterator[list[CanFrame | DataTuple]]:
        skipped_before = self._records

        def on_skip(index: int, skip: LineSkip) -> None:
            self._skip(index, skip.reason, detail=skip.detail, damage=skip.damage)

        tally = LineTally(on_skip)
        with self._open_text() as text:
            try:
                if base == ".asc":
                    yield from parse_asc_file(text, tally, self._block)
                else:
                    yield from parse_candump_file(text, tally, self._block)
            except (OSError, EOFError, UnicodeDecodeError, zlib.error) as exc:
                frames = tally.lines - (self._records - skipped_before)
                if frames <= 0:
                    raise CanLogFormatError(
                        f"{self.path}: not a readable {self.format} CAN log ({_describe(exc)})"
                    ) from exc
                self._count_frames(frames)
                self._skip(
                    self._records,
                    f"reader stopped after {self._decoded} frames ({_describe(exc)}); "
                    "rest of file unread",
                )
                return
        self._count_frames(tally.lines - (self._records - skipped_before))
        if self._decoded == 0 and self._damaged and not self._reasons.keys() - _DAMAGE_TEXT:
            raise CanLogFormatError(
                f"{self.path}: not a readable {self.format} CAN log "
                f"({self.damaged[0].reason if self.damaged else 'no frame'})"
            )

    def _count_frames(self, frames: int) -> None:
        self._records += frames
        self._decoded += frames

    @contextlib.contextmanager
    def _open_text(self) -> Iterator[IO[str]]:
        try:
            f = self._text()
        except OSError as exc:
            raise CanLogFormatError(f"{self.path}: cannot read ({exc.strerror or exc})") from exc
        with f:
            yield f

    # TRC, CSV, BLF, DB: python-can's readers, every line / object / row accounted
    def _python_can(self, base: str) -> Iterator[CanFrame | DataTuple]:
        import can  # python-can

        lines: _CountingLines | None = None
        reader: Any
        try:
            if base in (".trc", ".csv"):
                lines = _CountingLines(self._text(), base)
                reader = (can.TRCReader if base == ".trc" else can.CSVReader)(
                    cast(TextIO, lines)  # a file for python-can: it only iterates and closes it
                )
            else:
                reader = can.LogReader(self.path)
        except OSError as exc:
            raise CanLogFormatError(f"{self.path}: cannot read ({exc.strerror or exc})") from exc
        except Exception as exc:  # python-can readers raise assorted types on bad headers
            raise CanLogFormatError(
                f"{self.path}: not a readable {self.format} CAN log ({_describe(exc)})"
            ) from exc
        with reader:
            try:
                for msg in reader:
                    if lines is not None:
                        self._take_lines(lines, frame=True)
                    self._records += 1
                    self._decoded += 1
                    yield from_message(msg)
            except Exception as exc:  # ValueError, IndexError, struct.error, zlib, sqlite3 ...
                if not self._decoded:
                    raise CanLogFormatError(
                        f"{self.path}: not a readable {self.format} CAN log ({_describe(exc)})"
                    ) from exc
                if lines is not None:
                    self._take_lines(lines, frame=False)
                reason = (
                    f"python-can's {self.format} reader stopped after {self._decoded} frames "
                    f"({_describe(exc)}); rest of file unread"
                )
                self._skip(self._records, reason)
                if lines is not None:
                    self._drain(lines, "unread after python-can's reader stopped")
            else:
                if lines is not None:
                    self._take_lines(lines, frame=False)
            if base == ".blf":
                self._blf_objects(reader)

    def _take_lines(self, lines: _CountingLines, *, frame: bool) -> None:
        """Account for the lines python-can consumed since the last frame."""
        for reason, n in lines.benign.items():
            self._skip(self._records, reason, damage=False, count=n)
        lines.benign.clear()
        others = lines.candidates - (1 if frame and lines.candidates else 0)
        if others:  # TRC bus status lines, types python-can does not read: events, not damage
            self._skip(
                self._records,
                f"{self.format.removesuffix('.gz')} line python-can reads as no frame "
                "(status or unsupported type)",
                damage=False,
                count=others,
            )
        lines.candidates = 0

    def _drain(self, lines: _CountingLines, reason: str) -> None:
        try:
            for _ in lines:
                pass
        except Exception:
            pass
        n = lines.candidates + sum(lines.benign.values())
        if n:
            self._skip(self._records, reason, damage=False, count=n)

    def _blf_objects(self, reader: Any) -> None:
        announced = getattr(reader, "file_size", None)
        objects = getattr(reader, "object_count", None)
        size = Path(self.path).stat().st_size
        if isinstance(announced, int) and size < announced:
            self._skip(
                self._records,
                f"truncated BLF: {size} of {announced} bytes; the header announces {objects} "
                f"objects, {self._decoded} frames were read",
            )
        elif isinstance(objects, int) and objects > self._decoded:
            self._skip(
                self._records,
                "BLF object that is not a CAN frame (python-can reads CAN, CAN FD and error "
                "frames)",
                damage=False,
                count=objects - self._decoded,
            )

    # SocketCAN pcap
    def _text(self) -> IO[str]:
        """The log's text (UTF-8), gunzipped for a ``.gz`` format; the caller closes it."""
        if self._stream is None:
            return _open_text(self.path, self.format)
        raw: IO[bytes] = self._stream
        if self.format.endswith(".gz"):
            raw = cast(IO[bytes], gzip.GzipFile(fileobj=raw, mode="rb"))
        return io.TextIOWrapper(cast(Any, raw), encoding="utf-8")  # stdin: read1 as lines come

    def _pcap(self) -> Iterator[CanFrame | DataTuple]:
        # raises PcapFormatError, a DecodeError
        capture = read_capture(self.path if self._stream is None else self._stream)
        for rec in capture:  # record by record, none held
            if rec.linktype != LINKTYPE_CAN_SOCKETCAN:
                self._skip(rec.index, f"linktype {rec.linktype} record, not SocketCAN")
                continue
            try:
                frame = CanFrame.from_socketcan(rec.data, rec.time_ns)
            except DecodeError as exc:
                self._skip(rec.index, str(exc))
                continue
            self._records += 1
            self._decoded += 1
            yield frame
        for s in capture.skipped:  # what the pass just made could not read
            self._skip(s.index, s.reason)
        self.damaged.sort(key=lambda s: s.index)


def _open_text(path: str, fmt: str) -> IO[str]:
    """The text of a log (UTF-8), gunzipped when ``fmt`` ends in ``.gz``; the caller closes it."""
    if fmt.endswith(".gz"):
        return gzip.open(path, "rt", encoding="utf-8")
    return open(path, encoding="utf-8")


_DAMAGE_TEXT: Final = frozenset((ASC_NOT_A_LINE, CANDUMP_NOT_A_LINE, EMPTY))


class _CountingLines:
    """A text file for python-can's TRC/CSV readers that counts the lines they consume."""

    def __init__(self, f: IO[str], base: str) -> None:
        self._f = f
        self._comment = ";" if base == ".trc" else None
        self.benign: Counter[str] = Counter()
        self.candidates = 0
        self._first = base == ".csv"  # the CSV header line

    def __iter__(self) -> Iterator[str]:
        for line in self._f:
            text = line.strip()
            if not text:
                self.benign[EMPTY] += 1
            elif self._first or (self._comment and text.startswith(self._comment)):
                self.benign["header or comment line"] += 1
            else:
                self.candidates += 1
            self._first = False
            yield line

    def __next__(self) -> str:
        return next(iter(self))

    def readline(self) -> str:
        return next(iter(self), "")

    def close(self) -> None:
        self._f.close()


def _batched(
    items: Iterator[CanFrame | DataTuple], size: int
) -> Iterator[list[CanFrame | DataTuple]]:
    while batch := list(itertools.islice(items, size)):
        yield batch


_BATCH_FRAMES: Final = 1024
_STREAM_BATCH_FRAMES: Final = 32  # a stream: frames out soon after they come in


def _tuple_frame(item: DataTuple) -> CanFrame:
    time_ns, ident, data, channel = item
    return CanFrame(ident, data, time_ns=time_ns, channel=channel)


def read_frames(path: str | Path) -> tuple[str, list[CanFrame], list[Skipped]]:
    """Every frame of a CAN log file, without interpretation: ``(format, frames, skipped)``.

    ``skipped`` lists the damaged records (see :class:`CanLogReader`); the whole file is held.

    Raises:
        CanLogFormatError: unknown suffix, unreadable file, or nothing readable.
    """
    reader = CanLogReader(path)
    frames = list(reader)
    return reader.format, frames, reader.damaged


def read_can_log(
    path: str | Path,
    *,
    boards: Iterable[int] | None = None,
    skin_classes: Collection[int] = (SKIN_CLASS,),
) -> CanLog:
    """Read a CAN log file whole and reassemble its skin samples.

    For long logs iterate a :class:`CanLogReader` into a
    :class:`~skinframes.canbus.Reassembler` instead (``skinframes can decode`` does).

    Args:
        path: a CAN log in one of :data:`PYTHON_CAN_SUFFIXES` or :data:`PCAP_SUFFIXES` (text
            formats and pcaps also gzipped).
        boards: accept skin frames of these board addresses only (default: any).
        skin_classes: identifier classes that carry skin data (default 4; 3 for the legacy
            configuration, then give ``boards`` too).

    Raises:
        CanLogFormatError: unknown suffix, unreadable file, or damaged before the first frame.
    """
    reader = CanLogReader(path)
    r = Reassembler(boards=boards, skin_classes=skin_classes)
    frames = list(reader)
    samples = [s for s in map(r.feed, frames) if s is not None]
    counts = r.finish()
    return CanLog(
        str(path),
        reader.format,
        tuple(frames),
        tuple(samples),
        counts,
        r.malformed,
        tuple(reader.damaged),
        reader.record_counts,
    )


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


# --- writing ---------------------------------------------------------------------------------------
def write_can_log(path: str | Path, frames: Iterable[CanFrame], *, strict: bool = True) -> int:
    """Write ``frames`` (in the given order) to a CAN log file; the format follows the suffix.

    python-can formats go through python-can's writer for the suffix with messages created by
    :func:`to_message`; ``.db`` is python-can's SQLite table (``messages``, the columns of its
    ``SqliteWriter``), written here row for row (python-can's threaded writer loses rows);
    ``.pcap`` is a nanosecond SocketCAN pcap (LINKTYPE 227) from :class:`~skinframes.pcap.PcapWriter`.
    The file is written beside ``path`` and renamed into place when complete
    (:mod:`skinframes.atomic_file`): a refused or interrupted write leaves a previous file as it was.

    Args:
        path: the file to create or replace; its folder must exist.
        frames: the frames; ``time_ns`` >= 0.
        strict: refuse frames the format cannot store as given (``.trc``: CAN FD, remote and error
            frames; ``.log``: the DLC of a remote frame; ``.csv``/``.db``: the CAN FD flag). With
            ``strict=False`` they are written as the format can (``.trc`` drops them).

    Returns:
        The number of frames written.

    Raises:
        UnsupportedFormatError: an unknown or read-only suffix (``.pcapng``), or (strict) a frame
            the format would lose.
        FieldRangeError: a frame python-can or SocketCAN cannot hold.
        CaptureError: ``path`` is refused (a symbolic link, a directory, a missing folder).
    """
    try:
        fmt = can_log_format(path)
    except CanLogFormatError as exc:
        raise UnsupportedFormatError(str(exc)) from None
    base = fmt.removesuffix(".gz")
    if base in PCAP_SUFFIXES and fmt != ".pcap":
        raise UnsupportedFormatError(f"{path}: skinframes writes SocketCAN captures as .pcap")
    with atomic_path(path) as tmp:
        if base in PCAP_SUFFIXES:
            with PcapWriter(tmp, LINKTYPE_CAN_SOCKETCAN) as w:
                for f in frames:
                    w.write(f.time_ns, f.to_socketcan())
                return w.count
        messages = _messages(path, fmt, frames, strict)
        if base == ".db":
            return _write_db(tmp, messages)
        return _write_python_can(tmp, Path(path).name, fmt, messages)


def _messages(
    path: str | Path, fmt: str, frames: Iterable[CanFrame], strict: bool
) -> Iterator[Any]:
    """python-can messages of ``frames``, lossy frames refused (strict) or left out (.trc)."""
    base = fmt.removesuffix(".gz")
    lossy = _LOSSY.get(base, ())
    for index, f in enumerate(frames):
        loss = _loss(f, lossy)
        if loss and strict:
            raise UnsupportedFormatError(
                f"{path}: frame {index} ({loss}) cannot be stored in {fmt} by python-can; "
                "pass strict=False to write it anyway"
            )
        if loss and base == ".trc":
            continue  # TRCWriter would drop it with a log line
        msg = to_message(f)
        if base == ".blf":  # BLFWriter truncates int((t - start) * 1e9): nudge by 0.5 ns
            msg.timestamp += 0.5 / NS_PER_S
        yield msg


_WRITERS: Final = {  # python-can's writer class per suffix, and whether it writes text
    ".asc": ("ASCWriter", True),
    ".blf": ("BLFWriter", False),
    ".csv": ("CSVWriter", True),
    ".log": ("CanutilsLogWriter", True),
    ".trc": ("TRCWriter", True),
}
_DB_TABLE: Final = "messages"  # python-can's SqliteWriter/SqliteReader default table
_DB_BATCH: Final = 10_000


def _write_python_can(tmp: Path, name: str, fmt: str, messages: Iterator[Any]) -> int:
    """python-can's writer for ``fmt`` into the open temporary file (gzip as can.Logger does)."""
    import can  # python-can

    cls_name, text = _WRITERS[fmt.removesuffix(".gz")]
    written = 0
    with open(tmp, "wb") as raw:
        stream = cast(
            IO[bytes],
            gzip.GzipFile(filename=name, mode="wb", fileobj=raw) if fmt.endswith(".gz") else raw,
        )
        out: IO[Any] = io.TextIOWrapper(stream, encoding="utf-8") if text else stream
        writer = getattr(can, cls_name)(out)
        try:
            for msg in messages:
                writer.on_message_received(msg)
                written += 1
        finally:
            writer.stop()  # writes the BLF header and closes `out` (and the gzip stream)
    return written


def _write_db(tmp: Path, messages: Iterator[Any]) -> int:
    """python-can's SQLite layout (``SqliteWriter``: one row per message, same columns and
    values), every row, committed once."""
    import sqlite3

    written = 0
    conn = sqlite3.connect(tmp)
    try:
        conn.execute(
            f"CREATE TABLE {_DB_TABLE} (ts REAL, arbitration_id INTEGER, extended INTEGER, "
            "remote INTEGER, error INTEGER, dlc INTEGER, data BLOB)"
        )
        insert = f"INSERT INTO {_DB_TABLE} VALUES (?, ?, ?, ?, ?, ?, ?)"
        while batch := [
            (
                m.timestamp,
                m.arbitration_id,
                m.is_extended_id,
                m.is_remote_frame,
                m.is_error_frame,
                m.dlc,
                memoryview(m.data),
            )
            for m in itertools.islice(messages, _DB_BATCH)
        ]:
            conn.executemany(insert, batch)
            written += len(batch)
        conn.commit()
    finally:
        conn.close()
    return written


def _loss(frame: CanFrame, lossy: tuple[str, ...]) -> str:
    if frame.error and "error" in lossy:
        return "error frame"
    if frame.remote and "remote" in lossy:
        return "remote frame"
    if frame.remote and "remote_dlc" in lossy and frame.dlc_field:
        return f"remote frame with DLC {frame.dlc_field}"
    if frame.fd and "fd" in lossy:
        return "CAN FD frame"
    return ""


# --- the old names: a CAN log was called a trace (users' scripts still use them) -----------------
Trace = CanLog
read_trace = read_can_log
write_trace = write_can_log
trace_format = can_log_format
TRACE_SUFFIXES: Final = PYTHON_CAN_SUFFIXES
