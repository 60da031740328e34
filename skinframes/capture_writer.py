"""Writing capture files: classic pcap and pcapng, in memory or streamed atomically to disk.

Formats (the ones :mod:`skinframes.pcap` reads back):

- classic pcap (draft-ietf-opsawg-pcap sections 4-5): a 24-byte file header (magic 0xA1B23C4D for
  nanosecond stamps, version 2.4, snaplen, link type), then per record a 16-byte header
  ``seconds, nanoseconds, captured length, original length`` and the frame. Little endian.
- pcapng (draft-ietf-opsawg-pcapng section 4): a Section Header Block, one Interface Description
  Block per interface (``if_tsresol`` 9: nanoseconds), then one Enhanced Packet Block per record
  with its ``epb_flags`` (direction, CRC error; section 4.3.1) and ``opt_comment``.

Each header is built in one place: :func:`pcap_header`, :func:`record_header`, and the block
builders ``_shb``, ``_idb`` and ``_epb``. :meth:`CaptureWriter.write_block` copies each
column's record header from them once into an image it reuses, and then writes only the
timestamps and frames of each block into it, with numpy.
"""

from __future__ import annotations

import bisect
import contextlib
import io
import operator
import os
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, BinaryIO, Final

from skinframes.atomic_file import atomic_output, check_target, create_temp
from skinframes.errors import (
    CaptureError,
    FieldRangeError,
    FrameTooLargeError,
    PcapFormatError,
)
from skinframes.write_behind import WriteBehind

if TYPE_CHECKING:  # numpy is imported where an array is made: reading needs none
    import numpy as np
    import numpy.typing as npt

__all__ = [
    "CAPTURE_SNAPLEN",
    "EPB_CRC_ERROR",
    "EPB_INBOUND",
    "EPB_OUTBOUND",
    "LINKTYPE_CAN_SOCKETCAN",
    "LINKTYPE_ETHERNET",
    "NS_PER_S",
    "CaptureWriter",
    "MarkedRecord",
    "PcapWriter",
    "capture_format",
    "pcap_bytes",
    "pcap_header",
    "pcapng_bytes",
    "record_header",
    "write_pcap",
]

LINKTYPE_ETHERNET: Final = 1  # IEEE 802.3, no FCS
LINKTYPE_CAN_SOCKETCAN: Final = 227  # Linux SocketCAN header + data

MAGIC_US: Final = 0xA1B2C3D4
MAGIC_NS: Final = 0xA1B23C4D
SNAPLEN: Final = 262144  # Wireshark's default and its largest accepted record
CAPTURE_SNAPLEN: Final = 65535  # CaptureWriter's snaplen: any Ethernet frame, jumbo included
NS_PER_S: Final = 1_000_000_000
_GLOBAL = struct.Struct("<IHHiIII")  # magic, major, minor, thiszone, sigfigs, snaplen, linktype
_RECORD = struct.Struct("<IIII")  # seconds, fraction, captured length, original length
PCAP_HEADER_BYTES: Final = _GLOBAL.size  # 24
PCAP_RECORD_HEADER_BYTES: Final = _RECORD.size  # 16
_PCAP_TIME_OFFSET: Final = 0  # seconds and nanoseconds: the first two u32 of a record header
_PCAP_MAX_TIME_NS: Final = (1 << 32) * NS_PER_S - 1  # the latest stamp u32 seconds hold


# --- classic pcap ----------------------------------------------------------------------------------
def pcap_header(linktype: int = LINKTYPE_ETHERNET, snaplen: int = SNAPLEN) -> bytes:
    """The 24-byte global header: little-endian, nanosecond magic, version 2.4."""
    return _GLOBAL.pack(MAGIC_NS, 2, 4, 0, 0, snaplen, linktype)


def record_header(time_ns: int, length: int, orig_len: int | None = None) -> bytes:
    """The 16-byte record header for a nanosecond pcap."""
    if time_ns < 0:
        raise PcapFormatError(f"pcap: negative timestamp {time_ns} ns")
    sec, nsec = divmod(time_ns, NS_PER_S)
    if sec > 0xFFFFFFFF:
        raise PcapFormatError(f"pcap: timestamp {time_ns} ns does not fit 32-bit seconds")
    return _RECORD.pack(sec, nsec, length, length if orig_len is None else orig_len)


class PcapWriter:
    """Write a nanosecond, little-endian pcap: byte-deterministic for the same records.

    Use as a context manager; ``write(time_ns, data)`` appends one record. A path is written
    atomically (:mod:`skinframes.atomic_file`: the file appears when the writer closes, and an
    exception leaves the previous file); :class:`CaptureWriter` writes pcapng too, and whole
    blocks fast.
    """

    def __init__(self, target: str | Path | BinaryIO, linktype: int = LINKTYPE_ETHERNET):
        self._own = isinstance(target, str | Path)
        self._stack = contextlib.ExitStack()
        if isinstance(target, str | Path):  # atomic: the file appears whole when closed
            self._f: IO[bytes] = self._stack.enter_context(atomic_output(target, "wb"))
        else:
            self._f = target
        self._f.write(pcap_header(linktype))
        self.count = 0

    def write(self, time_ns: int, data: bytes) -> None:
        """Append one record stamped ``time_ns`` (nanoseconds)."""
        self._f.write(record_header(time_ns, len(data)))
        self._f.write(data)
        self.count += 1

    def close(self) -> None:
        """Flush, and close (rename into place) the file if this writer opened it."""
        if self._own:
            self._stack.close()
        else:
            self._f.flush()

    def __enter__(self) -> PcapWriter:
        return self

    def __exit__(
        self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None
    ) -> None:
        if e is not None and self._own:  # an error or interruption: no file, the old one stays
            self._stack.__exit__(t, e, tb)
            return
        self.close()


def pcap_bytes(records: Iterable[tuple[int, bytes]], linktype: int = LINKTYPE_ETHERNET) -> bytes:
    """A whole pcap file in memory from ``(time_ns, data)`` pairs."""
    buf = io.BytesIO()
    w = PcapWriter(buf, linktype)
    for t, d in records:
        w.write(t, d)
    return buf.getvalue()


def write_pcap(
    path: str | Path, records: Iterable[tuple[int, bytes]], linktype: int = LINKTYPE_ETHERNET
) -> int:
    """Write ``(time_ns, data)`` pairs to ``path``; returns the number of records."""
    with PcapWriter(path, linktype) as w:
        for t, d in records:
            w.write(t, d)
        return w.count


# --- pcapng (draft-ietf-opsawg-pcapng): several interfaces, direction, marks -----------------------
BLOCK_SHB: Final = 0x0A0D0D0A  # 4.1 Section Header Block
BLOCK_IDB: Final = 0x00000001  # 4.2 Interface Description Block
BLOCK_EPB: Final = 0x00000006  # 4.3 Enhanced Packet Block
BYTE_ORDER_MAGIC: Final = 0x1A2B3C4D
OPT_ENDOFOPT: Final = 0
OPT_COMMENT: Final = 1
IF_NAME: Final = 2
IF_SPEED: Final = 8  # u64 bits per second
IF_TSRESOL: Final = 9
EPB_FLAGS: Final = 2
TSRESOL_NS: Final = 9  # if_tsresol: 10^-9 s
EPB_INBOUND: Final = 0x1  # epb_flags bits 0-1: direction
EPB_OUTBOUND: Final = 0x2
EPB_CRC_ERROR: Final = 1 << 24  # epb_flags link-layer error bits 16-31: bit 24 = CRC error
_EPB_HEAD = struct.Struct("<IIIIIII")  # type, length, interface, ts high, ts low, caplen, origlen
EPB_HEADER_BYTES: Final = _EPB_HEAD.size  # 28
_EPB_TIME_OFFSET: Final = 12  # ts high, ts low: two u32 after type, length and interface id


def _option(code: int, value: bytes) -> bytes:
    if len(value) > 0xFFFF:
        raise FieldRangeError(f"pcapng: option {code} of {len(value)} bytes exceeds 65535")
    return struct.pack("<HH", code, len(value)) + value + bytes(-len(value) % 4)


def _block(kind: int, body: bytes) -> bytes:
    size = 12 + len(body)
    return struct.pack("<II", kind, size) + body + struct.pack("<I", size)


def _shb() -> bytes:
    """Section Header Block (4.1): byte-order magic, version 1.0, section length unknown (-1)."""
    return _block(
        BLOCK_SHB,
        struct.pack("<IHHq", BYTE_ORDER_MAGIC, 1, 0, -1) + struct.pack("<HH", OPT_ENDOFOPT, 0),
    )


def _idb(
    linktype: int, snaplen: int, name: str | None = None, speed_bps: int | None = None
) -> bytes:
    """Interface Description Block (4.2) with nanosecond stamps and an optional ``if_name`` and
    ``if_speed``."""
    opts = b"" if name is None else _option(IF_NAME, name.encode("utf-8"))
    if speed_bps is not None:
        opts += _option(IF_SPEED, struct.pack("<Q", speed_bps))
    opts += _option(IF_TSRESOL, bytes([TSRESOL_NS])) + struct.pack("<HH", OPT_ENDOFOPT, 0)
    return _block(BLOCK_IDB, struct.pack("<HHI", linktype, 0, snaplen) + opts)


def _epb(
    interface: int,
    time_ns: int,
    data: bytes,
    flags: int | None,
    comment: str | None,
    orig_len: int | None = None,
) -> bytes:
    """Enhanced Packet Block (4.3): the frame padded to 4 bytes, then comment and flags options;
    ``orig_len``: the original length (None: the captured one)."""
    if time_ns < 0:
        raise PcapFormatError(f"pcapng: negative timestamp {time_ns} ns")
    opts = b""
    if comment is not None:
        opts += _option(OPT_COMMENT, comment.encode("utf-8"))
    if flags is not None:
        opts += _option(EPB_FLAGS, struct.pack("<I", flags))
    if opts:
        opts += struct.pack("<HH", OPT_ENDOFOPT, 0)
    n = len(data)
    size = EPB_HEADER_BYTES + n + (-n % 4) + len(opts) + 4
    orig = n if orig_len is None else orig_len
    head = _EPB_HEAD.pack(BLOCK_EPB, size, interface, time_ns >> 32, time_ns & 0xFFFFFFFF, n, orig)
    return b"".join((head, data, bytes(-n % 4), opts, struct.pack("<I", size)))


def _epb_flags(outbound: bool | None, crc_error: bool) -> int | None:
    """``epb_flags`` for a direction (None: unknown) and a CRC mark; None when neither is set."""
    if outbound is None and not crc_error:
        return None
    flags = 0 if outbound is None else EPB_OUTBOUND if outbound else EPB_INBOUND
    return flags | EPB_CRC_ERROR if crc_error else flags


@dataclass(frozen=True, slots=True)
class MarkedRecord:
    """A record for :func:`pcapng_bytes`: a frame, its time, and optionally flags and a comment."""

    time_ns: int
    data: bytes
    flags: int | None = None  # epb_flags: direction, CRC error, ...
    comment: str | None = None


def pcapng_bytes(records: Iterable[MarkedRecord], linktype: int = LINKTYPE_ETHERNET) -> bytes:
    """A whole pcapng file: one section, one interface (nanosecond timestamps), one enhanced
    packet block per record with its flags and comment. Byte-deterministic."""
    out = [_shb(), _idb(linktype, SNAPLEN)]
    out += [_epb(0, r.time_ns, r.data, r.flags, r.comment) for r in records]
    return b"".join(out)


# --- streaming, atomic -----------------------------------------------------------------------------
FORMATS: Final = ("pcap", "pcapng")
_BUFFER_BYTES: Final = 1 << 20  # for write(); write_block() hands its chunks to the OS whole
_CHUNK_BYTES: Final = 4 << 20  # write_block's image: rows of records that stay in the CPU cache


@dataclass(frozen=True, slots=True)
class _Layout:
    """One row of records as the file holds it, and the reused image a block is assembled in.

    ``image`` holds as many rows as fit :data:`_CHUNK_BYTES`. The constant bytes between two
    frames (the previous record's tail, then this record's header) are filled in once, so a
    chunk of rows only writes its timestamps (at ``stamp_index``, the flat positions of every
    record's two u32 time words, row by row, in units of ``stamp_unit``: whole little-endian
    u32 words where every stamp is 4-byte aligned in the image, else bytes) and its frames (``frames``: image offset,
    data offset and length of each; ``sources``: the data offsets alone, to look fills up).
    """

    key: tuple[bytes, bytes, bytes | None]
    data_bytes: int
    frames: tuple[tuple[int, int, int], ...]
    image: npt.NDArray[np.uint8]
    stamp_index: npt.NDArray[np.intp]
    stamp_unit: np.dtype[np.uint8] | np.dtype[np.uint32]
    sources: tuple[int, ...]


COMPRESSED_SUFFIXES: Final = (".gz", ".zst", ".lz4", ".xz", ".bz2")  # what Wireshark may read


def capture_format(path: str | os.PathLike[str]) -> str:
    """The format a capture file named ``path`` is written in: ``pcapng`` for ``.pcapng``
    (any case), else ``pcap``.

    Raises:
        CaptureError: a compressed name (``.gz`` ...): captures are written uncompressed, and
            such a file would hold plain pcap under a name that says otherwise.
    """
    name = os.fspath(path)
    suffix = Path(name).suffix.lower()
    if suffix in COMPRESSED_SUFFIXES:
        raise CaptureError(
            f"{name}: captures are written uncompressed; name it .pcap or .pcapng "
            f"(and compress it afterwards)"
        )
    return "pcapng" if suffix == ".pcapng" else "pcap"


class CaptureWriter:
    """Stream records into a pcap or pcapng file that appears at ``path`` only when complete.

    The records go to a temporary file beside ``path`` (``.NAME.XXXXXXXX.tmp``), which replaces
    ``path`` on :meth:`close`; an exception inside the ``with`` block (KeyboardInterrupt too)
    removes it and leaves any previous file at ``path`` as it was. The file gets the mode a
    plain ``open(path, "w")`` would give a new file (0o666 minus the umask). Atomic against
    exceptions and interruption, not against a power cut (no fsync).

    Formats: ``"pcap"``: nanosecond stamps, LINKTYPE_ETHERNET, little endian, snaplen 65535;
    it cannot carry ports, directions or marks, so ``port`` and ``outbound`` are not written
    (a port is still checked against ``ports``, so that a program runs alike with either format)
    and a record with ``crc_error`` or ``comment`` raises. ``"pcapng"``: one interface per port
    (LINKTYPE_ETHERNET, nanoseconds, ``if_name`` from ``port_names`` or ``"port N"``, ``if_speed``
    from ``if_speed_bps`` when given), direction
    and CRC error in ``epb_flags`` and the comment in ``opt_comment`` of each Enhanced Packet
    Block (draft-ietf-opsawg-pcapng 4.2, 4.3). ``fmt=None`` takes pcapng for a ``.pcapng``
    suffix, classic pcap otherwise.

    ``path`` may also be an open binary stream (``sys.stdout.buffer``, a pipe, a socket file):
    a pipe is not a file, so the records are written to it as they come, nothing is renamed,
    :meth:`close` flushes it and leaves it open, and an exception leaves what was written
    (``fmt=None`` is classic pcap there: a stream has no suffix).

    With ``write_behind`` the records are written by a thread of their own
    (:class:`skinframes.write_behind.WriteBehind`), so that a busy disk or a slow reader of the
    pipe does not hold up the program making them (``serve``): a record is built and handed over
    at once, none is dropped (the writer waits when the thread is 64 MiB behind), and an
    ``OSError`` of the thread is raised by the next call.

    Args:
        path: the capture file to create or replace, or a binary stream to write to.
        fmt: ``"pcap"``, ``"pcapng"`` or None (from the suffix).
        ports: interfaces the records come from (pcapng interface ids 0 .. ports-1).
        port_names: one ``if_name`` per port (pcapng).
        if_speed_bps: the ports' bit rate, written as each interface's ``if_speed`` (pcapng);
            None writes no speed.
        write_behind: write the records from a thread of their own (see above).

    Raises:
        CaptureError: ``path`` is a symbolic link, a directory or not a regular file, its
            directory does not exist or is not writable, an unknown ``fmt``, ``port_names``
            of another length than ``ports``, or an ``if_speed_bps`` outside 1 .. 2**64 - 1.
            Nothing is written then.
    """

    def __init__(
        self,
        path: str | os.PathLike[str] | BinaryIO,
        *,
        fmt: str | None = None,
        ports: int = 1,
        port_names: Sequence[str] | None = None,
        if_speed_bps: int | None = None,
        write_behind: bool = False,
    ) -> None:
        self._file: BinaryIO | WriteBehind | None = None
        self._tmp: Path | None = None
        if isinstance(path, str | os.PathLike):
            stream: BinaryIO | None = None
            target = Path(os.fspath(path))
        else:
            stream = path
            target = Path(str(getattr(stream, "name", "-")))
        if fmt is None:
            fmt = capture_format(target) if stream is None else "pcap"
        if fmt not in FORMATS:
            raise CaptureError(f"capture format {fmt!r}: expected one of {', '.join(FORMATS)}")
        ports = operator.index(ports)
        if ports < 1:
            raise CaptureError(f"capture: {ports} ports, need at least 1")
        names = [f"port {i}" for i in range(ports)] if port_names is None else list(port_names)
        if len(names) != ports:
            raise CaptureError(f"capture: {len(names)} port names for {ports} ports")
        if if_speed_bps is not None and not 0 < operator.index(if_speed_bps) < 1 << 64:
            raise CaptureError(f"capture: if_speed {if_speed_bps} bit/s, need 1 .. 2**64 - 1")
        if fmt == "pcap":
            header = pcap_header(LINKTYPE_ETHERNET, CAPTURE_SNAPLEN)
        else:
            header = _shb() + b"".join(
                _idb(LINKTYPE_ETHERNET, CAPTURE_SNAPLEN, n, if_speed_bps) for n in names
            )
        if stream is None:
            check_target(target)
        self._path = target
        self._stream = stream
        self._fmt = fmt
        self._ports = ports
        self._records = 0
        self._bytes = 0
        self._layout: _Layout | None = None
        # what the image's frame bytes hold after write_repeated: (layout, template, fill places)
        self._image_holds: tuple[_Layout, bytes, tuple[tuple[int, int], ...]] | None = None
        if stream is not None:  # a pipe is not a file: the records stream as they come
            self._file = WriteBehind(stream, close_sink=False) if write_behind else stream
            self._file.write(header)
            self._bytes = len(header)
            return
        self._tmp, fd = create_temp(target)
        try:
            if write_behind:  # the thread gathers its chunks: the file needs no buffer
                self._file = WriteBehind(open(fd, "wb", buffering=0), close_sink=True)  # noqa: SIM115
            else:
                self._file = open(fd, "wb", buffering=_BUFFER_BYTES)  # noqa: SIM115  # closed in close()
            self._file.write(header)
        except BaseException:
            self._abort()
            raise
        self._bytes = len(header)

    # --- properties ---
    @property
    def path(self) -> Path:
        """The file that appears on a successful :meth:`close` (a stream: its ``name``, e.g.
        ``<stdout>``, or ``-``)."""
        return self._path

    @property
    def fmt(self) -> str:
        """``"pcap"`` or ``"pcapng"``."""
        return self._fmt

    @property
    def records(self) -> int:
        """Records written so far."""
        return self._records

    @property
    def bytes_written(self) -> int:
        """Bytes written so far, file header included (the file's size once closed)."""
        return self._bytes

    # --- writing ---
    def write(
        self,
        time_ns: int,
        frame: bytes,
        *,
        port: int = 0,
        outbound: bool | None = None,
        crc_error: bool = False,
        comment: str | None = None,
        orig_len: int | None = None,
    ) -> None:
        """Append one record.

        Args:
            time_ns: the timestamp, nanoseconds (>= 0; classic pcap: seconds fit 32 bits).
            frame: the frame as captured (no FCS), at most 65535 bytes.
            port: the interface it was captured on (pcapng interface id).
            outbound: the direction (pcapng ``epb_flags``); None: not recorded.
            crc_error: mark the frame as received with a bad FCS (pcapng only).
            comment: a packet comment (pcapng only).
            orig_len: the frame's length on the wire when ``frame`` is cut short of it (pcap
                orig_len, pcapng original length); None: ``len(frame)``.

        Raises:
            CaptureError: ``crc_error`` or ``comment`` in a classic pcap; the writer is closed.
            FieldRangeError: a timestamp, port or ``orig_len`` out of range (``orig_len``:
                ``len(frame)`` .. 2**32 - 1).
            FrameTooLargeError: a frame longer than the snaplen (65535).
        """
        f = self._open_file()
        t = operator.index(time_ns)
        self._check_time(t, t)
        self._check_port(operator.index(port))
        if len(frame) > CAPTURE_SNAPLEN:
            raise FrameTooLargeError(
                f"capture: frame of {len(frame)} bytes exceeds the snaplen {CAPTURE_SNAPLEN}"
            )
        if orig_len is not None and not len(frame) <= operator.index(orig_len) < 1 << 32:
            raise FieldRangeError(
                f"capture: original length {orig_len} outside {len(frame)}..{(1 << 32) - 1}",
                field="orig_len",
            )
        record = self._record(t, frame, port, outbound, crc_error, comment, orig_len)
        f.write(record)
        self._records += 1
        self._bytes += len(record)

    def write_block(
        self,
        times_ns: npt.NDArray[np.integer],
        lengths: npt.NDArray[np.integer],
        data: npt.NDArray[np.uint8],
        *,
        ports: npt.NDArray[np.integer] | None = None,
        outbound: npt.NDArray[np.bool_] | None = None,
    ) -> None:
        """Append k rows ("cycles") of R records with the same layout, vectorised.

        The records are written row by row (row 0's R records, then row 1's ...), byte for byte
        as R*k calls of :meth:`write` would write them. Rows are assembled with numpy in an image
        of about 4 MiB that is reused from block to block (headers filled in once per layout;
        per chunk of rows one scatter of the timestamps and one slice copy per record column,
        never a Python call per record) and handed to the OS with one write per chunk. The
        extra memory is that image, whatever k is.

        Args:
            times_ns: (k, R) integer timestamps, nanoseconds.
            lengths: (R,) frame lengths.
            data: (k, sum(lengths)) uint8: each row the R frames concatenated in record order.
            ports: (R,) the port of each record column; None: port 0.
            outbound: (R,) bool, the direction of each record column; None: not recorded.

        Raises:
            CaptureError: the arrays' shapes disagree; the writer is closed.
            FieldRangeError: a timestamp or port out of range.
            FrameTooLargeError: a length over the snaplen (65535).
        """
        import numpy as np  # here, not at the top: reading captures needs no numpy

        f = self._open_file()
        times = _integers("times_ns", times_ns, 2)
        k, r = times.shape
        layout = self._layout_for(lengths, ports, outbound, r)
        data = np.asarray(data)
        if data.dtype != np.uint8:
            raise TypeError(f"data must be uint8, not {data.dtype}")
        if data.shape != (k, layout.data_bytes):
            raise CaptureError(
                f"capture block: data of shape {data.shape}, expected {(k, layout.data_bytes)}"
            )
        if k == 0 or r == 0:
            return
        self._check_time(int(times.min()), int(times.max()))
        self._image_holds = None  # the frames' bytes in the image are this block's from now on
        image = layout.image
        for start in range(0, k, len(image)):
            rows = min(len(image), k - start)
            part = image[:rows]
            self._stamp(layout, times[start : start + rows])
            rows_data = data[start : start + rows]
            for at, src, n in layout.frames:
                part[:, at : at + n] = rows_data[:, src : src + n]
            f.write(part.data)
            self._records += rows * r
            self._bytes += part.nbytes

    def write_repeated(
        self,
        times_ns: npt.NDArray[np.integer],
        lengths: npt.NDArray[np.integer],
        template: npt.NDArray[np.uint8],
        *,
        ports: npt.NDArray[np.integer] | None = None,
        outbound: npt.NDArray[np.bool_] | None = None,
        fills: Sequence[tuple[int, npt.NDArray[np.uint8]]] = (),
    ) -> None:
        """Append k rows of R records whose frames are ``template`` but for the ``fills``.

        Byte for byte :meth:`write_block` with ``data`` = ``template`` in every row and each
        fill's values put in. The template stays in the reused image from call to call, so a
        row costs its timestamps, its fills and the write, not a copy of the bytes that do not
        change (a periodic emulation: the same frames every cycle but for their taxels).

        Args:
            times_ns: (k, R) integer timestamps, nanoseconds.
            lengths: (R,) frame lengths.
            template: (sum(lengths),) uint8, one row's R frames concatenated in record order.
            ports, outbound: as in :meth:`write_block`.
            fills: ``(offset, values)`` pairs: ``values`` (k, n) uint8 replace bytes
                ``offset .. offset + n`` of each row's frames (inside one frame).

        Raises:
            CaptureError: shapes disagree, or a fill leaves its frame; the writer is closed.
            FieldRangeError, FrameTooLargeError: as in :meth:`write_block`.
        """
        import numpy as np  # here, not at the top: reading captures needs no numpy

        f = self._open_file()
        times = _integers("times_ns", times_ns, 2)
        k, r = times.shape
        layout = self._layout_for(lengths, ports, outbound, r)
        row = np.asarray(template)
        if row.dtype != np.uint8:
            raise TypeError(f"template must be uint8, not {row.dtype}")
        if row.shape != (layout.data_bytes,):
            raise CaptureError(
                f"capture block: template of shape {row.shape}, expected ({layout.data_bytes},)"
            )
        places = [self._place(layout, offset, values, k) for offset, values in fills]
        if k == 0 or r == 0:
            return
        self._check_time(int(times.min()), int(times.max()))
        image = layout.image
        holds = (layout, row.tobytes(), tuple((at, v.shape[1]) for at, v in places))
        if (
            self._image_holds is None
            or self._image_holds[0] is not layout
            or (self._image_holds[1:] != holds[1:])
        ):
            for at, src, n in layout.frames:
                image[:, at : at + n] = row[src : src + n]
            self._image_holds = holds
        runs = _runs_of(places, k)
        for start in range(0, k, len(image)):
            rows = min(len(image), k - start)
            part = image[:rows]
            self._stamp(layout, times[start : start + rows])
            for at, step, values in runs:
                if step:  # m fills of n bytes, step bytes apart: one copy
                    _, m, n = values.shape
                    dest = np.lib.stride_tricks.as_strided(
                        part[:, at:], (rows, m, n), (part.strides[0], step, 1), writeable=True
                    )
                    dest[...] = values[start : start + rows]
                else:
                    part[:, at : at + values.shape[1]] = values[start : start + rows]
            f.write(part.data)
            self._records += rows * r
            self._bytes += part.nbytes

    # --- closing ---
    def close(self) -> None:
        """Finish the file and move it onto ``path``; a second call does nothing."""
        f, self._file = self._file, None
        if f is None:
            return
        if self._stream is not None:  # the stream stays open: its owner closes it
            (f.close if isinstance(f, WriteBehind) else f.flush)()
            return
        try:
            f.close()
            assert self._tmp is not None
            os.replace(self._tmp, self._path)
        except BaseException:
            self._remove_temp()
            raise
        self._tmp = None

    def __enter__(self) -> CaptureWriter:
        return self

    def __exit__(
        self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None
    ) -> None:
        if t is None:
            self.close()
        else:
            self._abort()

    def __del__(self) -> None:
        # an unclosed writer leaves no temporary file behind (and no file at path)
        if getattr(self, "_file", None) is not None:
            with contextlib.suppress(Exception):
                self._abort()

    # --- internals ---
    def _open_file(self) -> BinaryIO | WriteBehind:
        if self._file is None:
            raise CaptureError(f"{self._path}: the capture writer is closed")
        return self._file

    def _abort(self) -> None:
        f, self._file = self._file, None
        if isinstance(f, WriteBehind):  # what the thread has not written is dropped
            f.abort()  # (and the file closed)
        elif self._stream is None and f is not None:
            with contextlib.suppress(OSError):
                f.close()
        if self._stream is not None:  # what reached the stream cannot be taken back
            return
        self._remove_temp()

    def _remove_temp(self) -> None:
        tmp, self._tmp = self._tmp, None
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)

    def _check_time(self, first_ns: int, last_ns: int) -> None:
        """Raise unless every stamp in ``first_ns .. last_ns`` fits the format."""
        limit = _PCAP_MAX_TIME_NS if self._fmt == "pcap" else (1 << 64) - 1
        if first_ns < 0:
            raise FieldRangeError(f"{self._fmt}: negative timestamp {first_ns} ns", field="time_ns")
        if last_ns > limit:
            what = "32-bit seconds" if self._fmt == "pcap" else "64 bits"
            raise FieldRangeError(
                f"{self._fmt}: timestamp {last_ns} ns does not fit {what}", field="time_ns"
            )

    def _check_port(self, port: int) -> None:
        if not 0 <= port < self._ports:
            raise FieldRangeError(
                f"capture: port {port} outside 0..{self._ports - 1}", field="port"
            )

    def _record(
        self,
        time_ns: int,
        frame: bytes,
        port: int,
        outbound: bool | None,
        crc_error: bool,
        comment: str | None,
        orig_len: int | None = None,
    ) -> bytes:
        """One record as the file holds it (the single encoder of write and write_block)."""
        if self._fmt == "pcap":
            if crc_error or comment is not None:
                raise CaptureError(
                    f"{self._path}: classic pcap cannot carry CRC marks or comments; "
                    "name the file .pcapng"
                )
            return record_header(time_ns, len(frame), orig_len) + frame
        return _epb(port, time_ns, frame, _epb_flags(outbound, crc_error), comment, orig_len)

    def _stamp(self, layout: _Layout, t: npt.NDArray[np.int64]) -> None:
        """Write the timestamps ``t`` (rows, R) into the first rows of the layout's image."""
        import numpy as np  # here, not at the top: reading captures needs no numpy

        rows, r = t.shape
        words = np.empty((rows, r, 2), dtype="<u4")  # the two u32 time words of each record
        if self._fmt == "pcap":
            sec, nsec = np.divmod(t, NS_PER_S)
            words[:, :, 0] = sec
            words[:, :, 1] = nsec
        else:
            words[:, :, 0] = t >> 32
            words[:, :, 1] = t & 0xFFFFFFFF
        unit = layout.stamp_unit
        at = layout.stamp_index[: words.nbytes // unit.itemsize]
        layout.image.reshape(-1).view(unit)[at] = words.reshape(-1).view(unit)

    @staticmethod
    def _place(
        layout: _Layout, offset: int, values: npt.NDArray[np.uint8], k: int
    ) -> tuple[int, npt.NDArray[np.uint8]]:
        """A fill's image column and values, checked: inside one frame, k rows of uint8."""
        import numpy as np  # here, not at the top: reading captures needs no numpy

        v = np.asarray(values)
        if v.dtype != np.uint8:
            raise TypeError(f"fill values must be uint8, not {v.dtype}")
        if v.ndim != 2 or v.shape[0] != k:
            raise CaptureError(f"capture block: fill of shape {v.shape} for {k} rows")
        offset = operator.index(offset)
        j = bisect.bisect_right(layout.sources, offset) - 1
        if j >= 0:
            at, src, n = layout.frames[j]
            if offset + v.shape[1] <= src + n:
                return at + offset - src, v
        raise CaptureError(
            f"capture block: a fill of {v.shape[1]} bytes at {offset} is not inside one frame"
        )

    def _layout_for(
        self,
        lengths: npt.NDArray[np.integer],
        ports: npt.NDArray[np.integer] | None,
        outbound: npt.NDArray[np.bool_] | None,
        r: int,
    ) -> _Layout:
        """The row layout of a block: built once from :meth:`_record`, reused while it holds."""
        import numpy as np  # here, not at the top: reading captures needs no numpy

        lens = _integers("lengths", lengths, 1)
        if lens.shape != (r,):
            raise CaptureError(f"capture block: {lens.shape[0]} lengths for {r} records per row")
        if r and (int(lens.min()) < 0 or int(lens.max()) > CAPTURE_SNAPLEN):
            raise FrameTooLargeError(
                f"capture block: frame lengths must be 0..{CAPTURE_SNAPLEN}", field="lengths"
            )
        port = np.zeros(r, np.int64) if ports is None else _integers("ports", ports, 1)
        if port.shape != (r,):
            raise CaptureError(f"capture block: {port.shape[0]} ports for {r} records per row")
        if r:
            self._check_port(int(port.min()))
            self._check_port(int(port.max()))
        out = None if outbound is None else np.asarray(outbound)
        if out is not None:
            if out.dtype != np.bool_:
                raise TypeError(f"outbound must be a bool array, not {out.dtype}")
            if out.shape != (r,):
                raise CaptureError(f"capture block: {out.shape} outbound flags for {r} records")
        key = (lens.tobytes(), port.tobytes(), None if out is None else out.tobytes())
        if self._layout is not None and self._layout.key == key:
            return self._layout
        gaps: list[tuple[int, bytes]] = []
        stamps: list[int] = []
        frames: list[tuple[int, int, int]] = []
        head_bytes = PCAP_RECORD_HEADER_BYTES if self._fmt == "pcap" else EPB_HEADER_BYTES
        time_offset = _PCAP_TIME_OFFSET if self._fmt == "pcap" else _EPB_TIME_OFFSET
        pending = b""  # the previous record's tail, joined to this record's header
        at = src = 0
        for j, n in enumerate(lens.tolist()):
            direction = None if out is None else bool(out[j])
            record = self._record(0, bytes(n), int(port[j]), direction, False, None)
            gap = pending + record[:head_bytes]
            gaps.append((at, gap))
            stamps.append(at + len(pending) + time_offset)
            frames.append((at + len(gap), src, n))
            at += len(gap) + n
            src += n
            pending = record[head_bytes + n :]
        gaps.append((at, pending))
        row_bytes = at + len(pending)
        chunk_rows = max(1, _CHUNK_BYTES // row_bytes) if row_bytes else 1
        image = np.zeros((chunk_rows, row_bytes), dtype=np.uint8)
        for at, gap in gaps:
            image[:, at : at + len(gap)] = np.frombuffer(gap, dtype=np.uint8)
        rows = np.arange(len(image), dtype=np.intp)[:, None, None] * row_bytes
        # stamps at 4-byte aligned places (as in rows of frames whose lengths are multiples of
        # 4): scatter u32 words, a quarter of the indices of a byte scatter
        unit = 4 if row_bytes % 4 == 0 and all(x % 4 == 0 for x in stamps) else 1
        places = rows + np.array(stamps, dtype=np.intp)[:, None] + np.arange(0, 8, unit)
        stamp_index = places.reshape(-1) // unit
        stamp_unit = np.dtype("<u4") if unit == 4 else np.dtype(np.uint8)
        sources = tuple(s for _, s, _ in frames)
        self._layout = _Layout(key, src, tuple(frames), image, stamp_index, stamp_unit, sources)
        return self._layout


def _integers(name: str, values: npt.ArrayLike, ndim: int) -> npt.NDArray[np.int64]:
    """``values`` as an int64 array of ``ndim`` dimensions (TypeError for another dtype)."""
    import numpy as np  # here, not at the top: reading captures needs no numpy

    arr = np.asarray(values)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"{name} must be an integer array, not {arr.dtype}")
    if arr.ndim != ndim:
        raise CaptureError(f"capture block: {name} has {arr.ndim} dimensions, expected {ndim}")
    if arr.dtype == np.uint64 and arr.size and int(arr.max()) > np.iinfo(np.int64).max:
        raise FieldRangeError(f"capture block: {name} does not fit int64", field=name)
    return arr.astype(np.int64, copy=False)


def _runs_of(
    places: list[tuple[int, npt.NDArray[np.uint8]]], k: int
) -> list[tuple[int, int, npt.NDArray[np.uint8]]]:
    """The fills of :meth:`CaptureWriter.write_repeated` in their order, consecutive ones that
    are one strided copy joined: m fills of equal shape and strides, equally spaced in the image
    (``step`` >= their width: they do not overlap) and in memory (e.g. the nodes' taxels of one
    (k, nodes, bytes) array) become (at, step, (k, m, n) view). One numpy copy instead of m
    (the 160 PRes of an EPL cycle: 4x faster). A lone fill is (at, 0, values)."""
    import numpy as np  # here, not at the top: reading captures needs no numpy

    out: list[tuple[int, int, npt.NDArray[np.uint8]]] = []
    i = 0
    while i < len(places):
        at, v = places[i]
        address = v.__array_interface__["data"][0]
        j, step, gap = i + 1, 0, 0
        if j < len(places):
            step = places[j][0] - at
            gap = places[j][1].__array_interface__["data"][0] - address
        while (
            j < len(places)
            and step >= max(v.shape[1], 1)
            and places[j][1].shape == v.shape
            and places[j][1].strides == v.strides
            and places[j][0] - at == (j - i) * step
            and places[j][1].__array_interface__["data"][0] - address == (j - i) * gap
        ):
            j += 1
        if j - i < 2:
            out.append((at, 0, v))
            i += 1
            continue
        shape, strides = (k, j - i, v.shape[1]), (v.strides[0], gap, v.strides[1])
        out.append((at, step, np.lib.stride_tricks.as_strided(v, shape, strides, writeable=False)))
        i = j
    return out
