"""Capture files: a deterministic nanosecond pcap writer and a reader for pcap, pcapng and gzip.

Formats: classic pcap (tcpdump.org, "draft-ietf-opsawg-pcap"): magic 0xA1B2C3D4 (microseconds) or
0xA1B23C4D (nanoseconds), in either byte order; pcapng ("draft-ietf-opsawg-pcapng") is read with
scapy's ``RawPcapNgReader``, several interfaces and time resolutions included. Either may be gzip
compressed (Wireshark reads such files transparently).

Reading accounts for every record: ``len(capture.records) + len(capture.skipped) == capture.total``.
A damaged tail is reported as one skipped entry after the good records before it.
"""

from __future__ import annotations

import gzip
import io
import logging
import struct
import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO, Final

from skinframes.errors import PcapFormatError

__all__ = [
    "LINKTYPE_CAN_SOCKETCAN",
    "LINKTYPE_ETHERNET",
    "Capture",
    "MarkedRecord",
    "PcapWriter",
    "Record",
    "Skipped",
    "pcap_bytes",
    "pcapng_bytes",
    "read_capture",
    "write_pcap",
]

logger = logging.getLogger(__name__)

LINKTYPE_ETHERNET: Final = 1  # IEEE 802.3, no FCS
LINKTYPE_CAN_SOCKETCAN: Final = 227  # Linux SocketCAN header + data

MAGIC_US: Final = 0xA1B2C3D4
MAGIC_NS: Final = 0xA1B23C4D
PCAPNG_MAGIC: Final = b"\x0a\x0d\x0d\x0a"
GZIP_MAGIC: Final = b"\x1f\x8b"
SNAPLEN: Final = 262144  # Wireshark's default and its largest accepted record
_GLOBAL = struct.Struct("<IHHiIII")
_RECORD = struct.Struct("<IIII")
NS_PER_S: Final = 1_000_000_000


@dataclass(frozen=True, slots=True)
class Record:
    """One captured frame.

    Attributes:
        index: position in the file, counting from 0 (skipped records included).
        time_ns: capture timestamp, nanoseconds since the epoch (or since 0 for emulated time).
        data: the captured bytes.
        linktype: LINKTYPE of the interface (1 Ethernet, 227 SocketCAN).
        orig_len: the frame's length on the wire as the capture says (>= len(data)).
        interface: pcapng interface id (0 for pcap).
        comments: pcapng packet comments (opt_comment), e.g. the mark of a deliberately corrupted
            frame written by the emulator.
    """

    index: int
    time_ns: int
    data: bytes
    linktype: int
    orig_len: int
    interface: int = 0
    comments: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class Skipped:
    """A record that could not be read, with the reason."""

    index: int
    reason: str


@dataclass(frozen=True, slots=True)
class Capture:
    """Everything read from a capture file; iterating yields the records."""

    path: str
    format: str  # "pcap" or "pcapng", with "+gzip" when compressed
    records: tuple[Record, ...]
    skipped: tuple[Skipped, ...]

    @property
    def total(self) -> int:
        """Records found in the file: decoded + skipped."""
        return len(self.records) + len(self.skipped)

    def __iter__(self) -> Iterator[Record]:
        return iter(self.records)

    def __len__(self) -> int:
        return len(self.records)


# --- writing ---------------------------------------------------------------------------------------
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

    Use as a context manager; ``write(time_ns, data)`` appends one record.
    """

    def __init__(self, target: str | Path | BinaryIO, linktype: int = LINKTYPE_ETHERNET):
        self._own = isinstance(target, str | Path)
        self._f: BinaryIO = open(target, "wb") if isinstance(target, str | Path) else target  # noqa: SIM115
        self._f.write(pcap_header(linktype))
        self.count = 0

    def write(self, time_ns: int, data: bytes) -> None:
        """Append one record stamped ``time_ns`` (nanoseconds)."""
        self._f.write(record_header(time_ns, len(data)))
        self._f.write(data)
        self.count += 1

    def close(self) -> None:
        """Flush, and close the file if this writer opened it."""
        if self._own:
            self._f.close()
        else:
            self._f.flush()

    def __enter__(self) -> PcapWriter:
        return self

    def __exit__(
        self, t: type[BaseException] | None, e: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def pcap_bytes(records: Iterable[tuple[int, bytes]], linktype: int = LINKTYPE_ETHERNET) -> bytes:
    """A whole pcap file in memory from ``(time_ns, data)`` pairs."""
    buf = io.BytesIO()
    w = PcapWriter(buf, linktype)
    for t, d in records:
        w.write(t, d)
    return buf.getvalue()


# --- pcapng (draft-ietf-opsawg-pcapng): for captures that carry marks ------------------------------
EPB_INBOUND: Final = 0x1  # epb_flags bits 0-1: direction
EPB_OUTBOUND: Final = 0x2
EPB_CRC_ERROR: Final = 1 << 24  # epb_flags link-layer error bits 16-31: bit 24 = CRC error


def _option(code: int, value: bytes) -> bytes:
    return struct.pack("<HH", code, len(value)) + value + bytes(-len(value) % 4)


def _block(kind: int, body: bytes) -> bytes:
    size = 12 + len(body)
    return struct.pack("<II", kind, size) + body + struct.pack("<I", size)


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
    out = [
        _block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1) + struct.pack("<HH", 0, 0)),
        _block(
            1,
            struct.pack("<HHI", linktype, 0, SNAPLEN)
            + _option(9, bytes([9]))
            + struct.pack("<HH", 0, 0),
        ),
    ]
    for r in records:
        if r.time_ns < 0:
            raise PcapFormatError(f"pcapng: negative timestamp {r.time_ns} ns")
        opts = b""
        if r.comment is not None:
            opts += _option(1, r.comment.encode("utf-8"))
        if r.flags is not None:
            opts += _option(2, struct.pack("<I", r.flags))
        if opts:
            opts += struct.pack("<HH", 0, 0)
        n = len(r.data)
        head = struct.pack("<IIIII", 0, r.time_ns >> 32, r.time_ns & 0xFFFFFFFF, n, n)
        out.append(_block(6, head + r.data + bytes(-n % 4) + opts))
    return b"".join(out)


def write_pcap(
    path: str | Path, records: Iterable[tuple[int, bytes]], linktype: int = LINKTYPE_ETHERNET
) -> int:
    """Write ``(time_ns, data)`` pairs to ``path``; returns the number of records."""
    with PcapWriter(path, linktype) as w:
        for t, d in records:
            w.write(t, d)
        return w.count


# --- reading ---------------------------------------------------------------------------------------
def read_capture(path: str | Path) -> Capture:
    """Read every record of a pcap or pcapng file, gzip-compressed or not.

    Raises:
        PcapFormatError: the file cannot be opened, or is not a capture (bad magic or header).
    """
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise PcapFormatError(f"{path}: cannot read ({exc.strerror or exc})") from exc
    return parse_capture(raw, str(path))


def parse_capture(raw: bytes, name: str = "<bytes>") -> Capture:
    """Like :func:`read_capture`, for a file already in memory."""
    fmt_suffix = ""
    skipped: list[Skipped] = []
    if raw[:2] == GZIP_MAGIC:
        raw, damage = _gunzip(raw)
        fmt_suffix = "+gzip"
        if damage:
            skipped.append(
                Skipped(-1, f"gzip stream damaged ({damage}); records after it are lost")
            )
    if len(raw) < 4:
        raise PcapFormatError(f"{name}: {len(raw)} bytes, not a capture file")
    if raw[:4] == PCAPNG_MAGIC:
        records, more = _read_pcapng(raw, name)
        fmt = "pcapng"
    else:
        records, more = _read_pcap(raw, name)
        fmt = "pcap"
    n = len(records) + len(more)
    skipped = more + [Skipped(n, s.reason) for s in skipped]
    return Capture(name, fmt + fmt_suffix, tuple(records), tuple(skipped))


def _gunzip(raw: bytes) -> tuple[bytes, str]:
    try:
        return gzip.decompress(raw), ""
    except (OSError, EOFError, zlib.error) as exc:
        d = zlib.decompressobj(wbits=31)
        try:
            out = d.decompress(raw)
        except zlib.error:
            out = b""
        return out, str(exc)


def _read_pcap(raw: bytes, name: str) -> tuple[list[Record], list[Skipped]]:
    if len(raw) < _GLOBAL.size:
        raise PcapFormatError(f"{name}: {len(raw)} bytes, the pcap header needs 24")
    magic_le = struct.unpack_from("<I", raw)[0]
    magic_be = struct.unpack_from(">I", raw)[0]
    if magic_le in (MAGIC_US, MAGIC_NS):
        order, magic = "<", magic_le
    elif magic_be in (MAGIC_US, MAGIC_NS):
        order, magic = ">", magic_be
    else:
        raise PcapFormatError(
            f"{name}: magic {raw[:4].hex()} is neither pcap (a1b2c3d4 / a1b23c4d) nor pcapng"
        )
    scale = 1 if magic == MAGIC_NS else 1000
    major, _minor, _zone, _sig, snaplen, network = struct.unpack_from(order + "HHiIII", raw, 4)
    if major != 2:
        raise PcapFormatError(f"{name}: pcap version {major}, expected 2")
    linktype = network & 0xFFFF  # libpcap LT_LINKTYPE; bits 26-31: FCS length flags
    rec = struct.Struct(order + "IIII")
    limit = max(snaplen, SNAPLEN)
    records: list[Record] = []
    skipped: list[Skipped] = []
    pos = _GLOBAL.size
    index = 0
    while pos < len(raw):
        if len(raw) - pos < rec.size:
            skipped.append(
                Skipped(
                    index, f"truncated record header at byte {pos} ({len(raw) - pos} of 16 bytes)"
                )
            )
            break
        sec, frac, incl, orig = rec.unpack_from(raw, pos)
        if incl > limit:
            skipped.append(
                Skipped(
                    index,
                    f"record at byte {pos} claims {incl} bytes, more than the "
                    f"snap length {limit}; rest of file unreadable",
                )
            )
            break
        if pos + rec.size + incl > len(raw):
            skipped.append(
                Skipped(
                    index,
                    f"record at byte {pos} claims {incl} bytes, only "
                    f"{len(raw) - pos - rec.size} remain (truncated file)",
                )
            )
            break
        data = raw[pos + rec.size : pos + rec.size + incl]
        if (scale != 1 and frac >= 1_000_000) or (scale == 1 and frac >= NS_PER_S):
            skipped.append(Skipped(index, f"record at byte {pos}: fraction {frac} out of range"))
        else:
            records.append(
                Record(index, sec * NS_PER_S + frac * scale, data, linktype, max(orig, incl))
            )
        pos += rec.size + incl
        index += 1
    return records, skipped


def _pcapng_reader(fd: io.BytesIO) -> Any:
    """scapy's ``RawPcapNgReader``, plus what it does not report: the interface id of each packet
    (local to its section, as Wireshark's ``frame.interface_id``), where the last block started (a
    clean end is at the end of the file), and the packets it drops for an undescribed interface."""
    from scapy.utils import RawPcapNgReader

    class Reader(RawPcapNgReader):
        block_start = 0
        intid = 0
        undescribed: list[int]

        def _read_block(self, size: int = SNAPLEN) -> Any:
            self.block_start = self.f.tell()
            return super()._read_block(size)

        def _read_block_shb(self) -> None:
            # interface ids are local to a section; scapy keeps one list for the whole file
            self.interfaces = []
            self.undescribed = getattr(self, "undescribed", [])  # the first SHB comes from __init__
            super()._read_block_shb()

        def _read_block_epb(self, block: bytes, size: int) -> Any:
            self.intid = struct.unpack_from(self.endian + "I", block)[0] if len(block) >= 4 else 0
            return super()._read_block_epb(block, size)

        def _read_block_pkt(self, block: bytes, size: int) -> Any:
            self.intid = struct.unpack_from(self.endian + "H", block)[0] if len(block) >= 2 else 0
            return super()._read_block_pkt(block, size)

        def _read_block_spb(self, block: bytes, size: int) -> Any:
            self.intid = 0
            return super()._read_block_spb(block, size)

        def _check_interface_id(self, intid: int) -> bool:
            ok = bool(super()._check_interface_id(intid))
            if not ok:
                self.undescribed.append(intid)
            return ok

    return Reader(fd)  # type: ignore[arg-type]  # scapy accepts a file object


def _read_pcapng(raw: bytes, name: str) -> tuple[list[Record], list[Skipped]]:
    from scapy.error import Scapy_Exception  # lazy: scapy takes ~0.2 s to import

    fd = io.BytesIO(raw)
    # scapy logs (rather than raises) on damaged blocks and then reports EOF; keep its logger
    # quiet and compare the position reached with the file size to report a damaged tail
    scapy_log = logging.getLogger("scapy.runtime")
    level = scapy_log.level
    scapy_log.setLevel(logging.CRITICAL)
    records: list[Record] = []
    skipped: list[Skipped] = []
    try:
        try:
            reader = _pcapng_reader(fd)
        except (Scapy_Exception, struct.error, EOFError, ValueError) as exc:
            raise PcapFormatError(f"{name}: not a readable pcapng ({exc})") from exc
        index = 0

        def drain_undescribed() -> None:
            nonlocal index
            for intid in reader.undescribed:
                skipped.append(Skipped(index, f"packet block names undescribed interface {intid}"))
                index += 1
            reader.undescribed.clear()

        while True:
            try:
                data, meta = reader._read_packet(size=SNAPLEN)
            except EOFError:
                drain_undescribed()
                if reader.block_start < len(raw):
                    skipped.append(
                        Skipped(
                            index,
                            f"damaged pcapng block at byte "
                            f"{reader.block_start} of {len(raw)}; rest unreadable",
                        )
                    )
                break
            except Exception as exc:  # scapy raises assorted types on damaged blocks
                drain_undescribed()
                skipped.append(
                    Skipped(
                        index,
                        f"damaged pcapng block after record {index} "
                        f"({type(exc).__name__}: {exc}); rest unreadable",
                    )
                )
                break
            ts = ((meta.tshigh or 0) << 32) | (meta.tslow or 0)
            time_ns = ts * NS_PER_S // meta.tsresol if meta.tsresol else 0
            drain_undescribed()
            iface = reader.intid
            comments = tuple(
                c.decode("utf-8", "replace") if isinstance(c, bytes) else str(c)
                for c in (meta.comments or ())
            )
            records.append(
                Record(
                    index,
                    time_ns,
                    bytes(data),
                    meta.linktype,
                    max(meta.wirelen or 0, len(data)),
                    iface,
                    comments,
                )
            )
            index += 1
    finally:
        scapy_log.setLevel(level)
    return records, skipped
