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
and error frames. A file that cannot be read at all raises :class:`TraceFormatError`; damage after
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

import logging
from collections.abc import Collection, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from skinframes.canbus.codec import SKIN_CLASS
from skinframes.canbus.reassembly import FrameCounts, Malformed, Reassembler, TimedSample
from skinframes.canbus.wire import MAX_DATA_BYTES, MAX_DLC, CanFrame
from skinframes.errors import (
    DecodeError,
    FieldRangeError,
    TraceFormatError,
    UnsupportedFormatError,
)
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, PcapWriter, Skipped, read_capture

__all__ = [
    "PCAP_SUFFIXES",
    "PYTHON_CAN_SUFFIXES",
    "TRACE_SUFFIXES",
    "CanLog",
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
        skipped: what could not be read, with the reason (a damaged tail is one entry).
    """

    path: str
    format: str
    frames: tuple[CanFrame, ...]
    samples: tuple[TimedSample, ...]
    counts: FrameCounts
    malformed: tuple[Malformed, ...]
    skipped: tuple[Skipped, ...]

    @property
    def total(self) -> int:
        """Frames (records) found in the file: read + skipped."""
        return self.counts.frames + len(self.skipped)


def can_log_format(path: str | Path) -> str:
    """The format suffix of ``path`` (``".asc"``, ``".asc.gz"``, ``".pcap"``, ...).

    Raises:
        TraceFormatError: not a suffix skinframes reads or writes.
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
    raise TraceFormatError(
        f"{path}: unknown trace format {''.join(suffixes[-2:]) or '(no suffix)'!r}; "
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
def read_frames(path: str | Path) -> tuple[str, list[CanFrame], list[Skipped]]:
    """Every frame of a CAN log file, without interpretation: ``(format, frames, skipped)``.

    Raises:
        TraceFormatError: unknown suffix, unreadable file, or nothing readable.
    """
    fmt = can_log_format(path)
    if fmt.removesuffix(".gz") in PCAP_SUFFIXES:
        frames, skipped = _read_pcap(path)
    else:
        frames, skipped = _read_python_can(path, fmt)
    return fmt, frames, skipped


def read_can_log(
    path: str | Path,
    *,
    boards: Iterable[int] | None = None,
    skin_classes: Collection[int] = (SKIN_CLASS,),
) -> CanLog:
    """Read a CAN log file and reassemble its skin samples.

    Args:
        path: a CAN log in one of :data:`PYTHON_CAN_SUFFIXES` or :data:`PCAP_SUFFIXES` (text
            formats and pcaps also gzipped).
        boards: accept skin frames of these board addresses only (default: any).
        skin_classes: identifier classes that carry skin data (default 4; 3 for the legacy
            configuration, then give ``boards`` too).

    Raises:
        TraceFormatError: unknown suffix, unreadable file, or damaged before the first frame.
    """
    fmt, frames, skipped = read_frames(path)
    r = Reassembler(boards=boards, skin_classes=skin_classes)
    samples = [s for s in map(r.feed, frames) if s is not None]
    counts = r.finish()
    return CanLog(
        str(path), fmt, tuple(frames), tuple(samples), counts, r.malformed, tuple(skipped)
    )


def _read_pcap(path: str | Path) -> tuple[list[CanFrame], list[Skipped]]:
    capture = read_capture(path)  # raises PcapFormatError, a DecodeError
    frames: list[CanFrame] = []
    skipped = list(capture.skipped)
    for rec in capture.records:
        if rec.linktype != LINKTYPE_CAN_SOCKETCAN:
            skipped.append(Skipped(rec.index, f"linktype {rec.linktype} record, not SocketCAN"))
            continue
        try:
            frames.append(CanFrame.from_socketcan(rec.data, rec.time_ns))
        except DecodeError as exc:
            skipped.append(Skipped(rec.index, str(exc)))
    skipped.sort(key=lambda s: s.index)
    return frames, skipped


def _read_python_can(path: str | Path, fmt: str) -> tuple[list[CanFrame], list[Skipped]]:
    import can  # python-can

    frames: list[CanFrame] = []
    skipped: list[Skipped] = []
    try:
        reader = can.LogReader(str(path))
    except OSError as exc:
        raise TraceFormatError(f"{path}: cannot read ({exc.strerror or exc})") from exc
    except Exception as exc:  # python-can readers raise assorted types on bad headers
        raise TraceFormatError(f"{path}: not a readable {fmt} trace ({_describe(exc)})") from exc
    with reader:
        try:
            for msg in reader:
                frames.append(from_message(msg))
        except Exception as exc:  # ValueError, IndexError, struct.error, zlib/gzip, sqlite3 ...
            if not frames:
                raise TraceFormatError(
                    f"{path}: not a readable {fmt} trace ({_describe(exc)})"
                ) from exc
            skipped.append(
                Skipped(
                    len(frames),
                    f"python-can's {fmt} reader stopped after {len(frames)} frames "
                    f"({_describe(exc)}); rest of file unread",
                )
            )
        if fmt == ".blf":
            skipped.extend(_blf_damage(path, reader, len(frames)))
    return frames, skipped


def _blf_damage(path: str | Path, reader: Any, read: int) -> list[Skipped]:
    """A BLF shorter than its header's file size lost objects at the end (python-can is silent)."""
    announced = getattr(reader, "file_size", None)
    if not isinstance(announced, int):
        return []
    size = Path(path).stat().st_size
    if size >= announced:
        return []
    objects = getattr(reader, "object_count", None)
    return [
        Skipped(
            read,
            f"truncated BLF: {size} of {announced} bytes; the header announces {objects} "
            f"objects, {read} frames were read",
        )
    ]


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


# --- writing ---------------------------------------------------------------------------------------
def write_can_log(path: str | Path, frames: Iterable[CanFrame], *, strict: bool = True) -> int:
    """Write ``frames`` (in the given order) to a CAN log file; the format follows the suffix.

    python-can formats go through ``can.Logger`` with messages created by :func:`to_message`;
    ``.pcap`` is a nanosecond SocketCAN pcap (LINKTYPE 227) from :class:`~skinframes.pcap.PcapWriter`.

    Args:
        path: the file to create (overwritten).
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
    """
    try:
        fmt = can_log_format(path)
    except TraceFormatError as exc:
        raise UnsupportedFormatError(str(exc)) from None
    base = fmt.removesuffix(".gz")
    if base in PCAP_SUFFIXES:
        if fmt != ".pcap":
            raise UnsupportedFormatError(f"{path}: skinframes writes SocketCAN captures as .pcap")
        with PcapWriter(path, LINKTYPE_CAN_SOCKETCAN) as w:
            for f in frames:
                w.write(f.time_ns, f.to_socketcan())
            return w.count
    lossy = _LOSSY.get(base, ())
    import can  # python-can

    written = 0
    with can.Logger(str(path)) as out:
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
            out.on_message_received(msg)
            written += 1
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
