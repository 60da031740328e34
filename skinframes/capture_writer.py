"""Writing capture files: classic pcap and pcapng.

Formats (the ones :mod:`skinframes.pcap` reads back):

- classic pcap (draft-ietf-opsawg-pcap sections 4-5): a 24-byte file header (magic 0xA1B23C4D for
  nanosecond stamps, version 2.4, snaplen, link type), then per record a 16-byte header
  ``seconds, nanoseconds, captured length, original length`` and the frame. Little endian.
- pcapng (draft-ietf-opsawg-pcapng section 4): a Section Header Block, one Interface Description
  Block per interface (``if_tsresol`` 9: nanoseconds), then one Enhanced Packet Block per record
  with its ``epb_flags`` (direction, CRC error; section 4.3.1) and ``opt_comment``.

Each header is built in one place: :func:`pcap_header`, :func:`record_header`, and the block
builders ``_shb``, ``_idb`` and ``_epb``.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import BinaryIO, Final

from skinframes.errors import FieldRangeError, PcapFormatError

__all__ = [
    "EPB_CRC_ERROR",
    "EPB_INBOUND",
    "EPB_OUTBOUND",
    "LINKTYPE_CAN_SOCKETCAN",
    "LINKTYPE_ETHERNET",
    "NS_PER_S",
    "MarkedRecord",
    "PcapWriter",
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
NS_PER_S: Final = 1_000_000_000
_GLOBAL = struct.Struct("<IHHiIII")  # magic, major, minor, thiszone, sigfigs, snaplen, linktype
_RECORD = struct.Struct("<IIII")  # seconds, fraction, captured length, original length
PCAP_HEADER_BYTES: Final = _GLOBAL.size  # 24
PCAP_RECORD_HEADER_BYTES: Final = _RECORD.size  # 16


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
IF_TSRESOL: Final = 9
EPB_FLAGS: Final = 2
TSRESOL_NS: Final = 9  # if_tsresol: 10^-9 s
EPB_INBOUND: Final = 0x1  # epb_flags bits 0-1: direction
EPB_OUTBOUND: Final = 0x2
EPB_CRC_ERROR: Final = 1 << 24  # epb_flags link-layer error bits 16-31: bit 24 = CRC error
_EPB_HEAD = struct.Struct("<IIIIIII")  # type, length, interface, ts high, ts low, caplen, origlen
EPB_HEADER_BYTES: Final = _EPB_HEAD.size  # 28


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


def _idb(linktype: int, snaplen: int, name: str | None = None) -> bytes:
    """Interface Description Block (4.2) with nanosecond stamps and an optional ``if_name``."""
    opts = b"" if name is None else _option(IF_NAME, name.encode("utf-8"))
    opts += _option(IF_TSRESOL, bytes([TSRESOL_NS])) + struct.pack("<HH", OPT_ENDOFOPT, 0)
    return _block(BLOCK_IDB, struct.pack("<HHI", linktype, 0, snaplen) + opts)


def _epb(
    interface: int, time_ns: int, data: bytes, flags: int | None, comment: str | None
) -> bytes:
    """Enhanced Packet Block (4.3): the frame padded to 4 bytes, then comment and flags options."""
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
    head = _EPB_HEAD.pack(BLOCK_EPB, size, interface, time_ns >> 32, time_ns & 0xFFFFFFFF, n, n)
    return b"".join((head, data, bytes(-n % 4), opts, struct.pack("<I", size)))


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
