"""Capture files: a reader for pcap, pcapng and gzip; the writers (re-exported here) live in
:mod:`skinframes.capture_writer`.

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
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from skinframes.capture_writer import (
    CAPTURE_SNAPLEN,
    EPB_CRC_ERROR,
    EPB_INBOUND,
    EPB_OUTBOUND,
    LINKTYPE_CAN_SOCKETCAN,
    LINKTYPE_ETHERNET,
    MAGIC_NS,
    MAGIC_US,
    NS_PER_S,
    PCAP_HEADER_BYTES,
    SNAPLEN,
    CaptureWriter,
    MarkedRecord,
    PcapWriter,
    pcap_bytes,
    pcap_header,
    pcapng_bytes,
    record_header,
    write_pcap,
)
from skinframes.errors import PcapFormatError

__all__ = [
    "CAPTURE_SNAPLEN",
    "EPB_CRC_ERROR",
    "EPB_INBOUND",
    "EPB_OUTBOUND",
    "LINKTYPE_CAN_SOCKETCAN",
    "LINKTYPE_ETHERNET",
    "NS_PER_S",
    "Capture",
    "CaptureWriter",
    "MarkedRecord",
    "PcapWriter",
    "Record",
    "Skipped",
    "parse_capture",
    "pcap_bytes",
    "pcap_header",
    "pcapng_bytes",
    "read_capture",
    "record_header",
    "write_pcap",
]

logger = logging.getLogger(__name__)

PCAPNG_MAGIC: Final = b"\x0a\x0d\x0d\x0a"
GZIP_MAGIC: Final = b"\x1f\x8b"


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
    if len(raw) < PCAP_HEADER_BYTES:
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
    pos = PCAP_HEADER_BYTES
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
