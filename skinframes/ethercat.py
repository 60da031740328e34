"""EtherCAT frames (EtherType 0x88A4): the frame header and datagrams with all commands.

Layouts: ETG.1000.4 / IEC 61158-4-12 section 5.3 (frame structure, Table 12 EtherCAT header, Table 13
datagram) as Wireshark's ``packet-ethercat-frame.c`` / ``packet-ethercat-datagram.c`` and SOEM's
``ethercattype.h`` implement them. All integers little-endian.

The construct schemas are the schema of record. Encoding and decoding of whole frames run on a
``struct`` fast path that the tests prove byte-identical to the schemas; a numpy batch path builds
and parses many frames of one fixed layout at once (:func:`pack_frames_batch`).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, fields
from enum import IntEnum
from typing import ClassVar, Final

import construct as cs
import numpy as np
import numpy.typing as npt

from skinframes import ethernet
from skinframes.errors import (
    FieldRangeError,
    FrameTooLargeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
)
from skinframes.findings import Finding, error, info, warning

__all__ = [
    "BROADCAST_MAC",
    "DATAGRAM_OVERHEAD_BYTES",
    "FRAME_HEADER_BYTES",
    "LOGICAL_COMMANDS",
    "MASTER_MAC",
    "MASTER_MAC_SECOND",
    "MAX_DATAGRAM_DATA_BYTES",
    "Command",
    "Datagram",
    "EcatFrame",
    "FrameType",
    "data_offsets",
    "datagrams_per_frame",
    "decode",
    "frame",
    "frames_needed",
    "pack_datagrams",
    "pack_frames_batch",
    "returned_mac",
    "unpack_frames_batch",
]

# --- sizes (ETG.1000.4 Table 12/13; paper eqs. 15, 17) --------------------------------------------
FRAME_HEADER_BYTES: Final = 2  # the paper's D_ecat_hd
DATAGRAM_HEADER_BYTES: Final = 10  # D_ecat_tgram_hd
WKC_BYTES: Final = 2  # D_ecat_wc
DATAGRAM_OVERHEAD_BYTES: Final = DATAGRAM_HEADER_BYTES + WKC_BYTES  # 12
MAX_LENGTH_FIELD: Final = 0x7FF  # 11 bits
MAX_DATAGRAM_DATA_BYTES: Final = (
    ethernet.MAX_PAYLOAD_BYTES - FRAME_HEADER_BYTES - DATAGRAM_OVERHEAD_BYTES
)  # 1486, SOEM EC_MAXLRWDATA

# The master's source MAC: RFC 7042 2.1.2's documentation range (unicast). Its first octet has bit
# 0x02 clear, so the bit an ESC sets in a processed frame (RETURNED_MAC_BIT) is visible.
MASTER_MAC: Final = bytes.fromhex("00005e005301")
MASTER_MAC_SECOND: Final = bytes.fromhex("00005e005302")  # the master's second (redundancy) port
BROADCAST_MAC: Final = b"\xff" * 6
RETURNED_MAC_BIT: Final = 0x02  # set by ESCs in the first source-MAC octet of a processed frame


class Command(IntEnum):
    """Datagram command (ETG.1000.4 Table 14); equals ``tshark -G values`` for ecat.cmd."""

    NOP = 0x00
    APRD = 0x01  # auto-increment physical read
    APWR = 0x02
    APRW = 0x03
    FPRD = 0x04  # configured-address physical read
    FPWR = 0x05
    FPRW = 0x06
    BRD = 0x07  # broadcast read
    BWR = 0x08
    BRW = 0x09
    LRD = 0x0A  # logical read
    LWR = 0x0B
    LRW = 0x0C
    ARMW = 0x0D  # auto-increment read multiple write
    FRMW = 0x0E  # configured-address read multiple write
    EXT = 0xFF  # Wireshark's name for 0xFF; not a datagram command of ETG.1000


class FrameType(IntEnum):
    """EtherCAT header Type (bits 12-15); equals ``tshark -G values`` for ecatf.type."""

    ECAT = 0x1  # EtherCAT commands (datagrams)
    ADS = 0x2
    RAW_IO = 0x3
    NV = 0x4  # network variables
    MAILBOX = 0x5


LOGICAL_COMMANDS: Final = frozenset({Command.LRD, Command.LWR, Command.LRW})

# --- construct schemas: the schema of record ------------------------------------------------------
frame_header_schema = cs.ByteSwapped(  # one LE word: type:4 | reserved:1 | length:11
    cs.BitStruct(
        "type" / cs.BitsInteger(4),
        "reserved" / cs.Flag,
        "length" / cs.BitsInteger(11),
    )
)

datagram_schema = cs.Struct(
    "cmd" / cs.Int8ul,
    "idx" / cs.Int8ul,
    "adp" / cs.Int16ul,  # position / station address; low half of a logical address
    "ado" / cs.Int16ul,  # register offset; high half of a logical address
    "flags"
    / cs.ByteSwapped(  # one LE word: M:1 | C:1 | reserved:3 | len:11
        cs.BitStruct(
            "more" / cs.Flag,
            "circulating" / cs.Flag,
            "reserved" / cs.BitsInteger(3),
            "length" / cs.Rebuild(cs.BitsInteger(11), cs.len_(cs.this._.data)),
        )
    ),
    "irq" / cs.Int16ul,
    "data" / cs.Bytes(cs.this.flags.length),
    "wkc" / cs.Int16ul,
)

frame_schema = cs.Struct(
    "header" / frame_header_schema,
    "datagrams" / cs.GreedyRange(datagram_schema),  # the M bits decide where the chain ends
)

# --- fast path: struct, proven byte-identical to the schemas (tests/skinframes/test_ethercat.py) --
_DG_HEAD = struct.Struct("<BBHHHH")  # cmd idx adp ado len|flags irq
_U16 = struct.Struct("<H")
_LEN_MASK: Final = 0x07FF
_RESERVED_MASK: Final = 0x3800
_CIRCULATING: Final = 0x4000
_MORE: Final = 0x8000


@dataclass(frozen=True, slots=True)
class Datagram:
    """One EtherCAT datagram (ETG.1000.4 Table 13): 10-byte header, data, 2-byte working counter.

    The length and the more-follows bit are derived when encoding. ``more`` is set only by a
    decoder that found an M bit contradicting the datagram's position (kept for byte-exactness).
    For LRD/LWR/LRW the 32-bit logical address is ``adp | ado << 16`` (see :attr:`lad`).
    """

    cmd: int
    adp: int
    ado: int
    data: bytes = b""
    idx: int = 0
    irq: int = 0
    wkc: int = 0
    circulating: bool = False
    more: bool | None = None
    reserved: int = 0

    @classmethod
    def logical(cls, cmd: int, lad: int, data: bytes, **kwargs: int | bool) -> Datagram:
        """A datagram addressed by a 32-bit logical address (LRD, LWR, LRW)."""
        if not 0 <= lad <= 0xFFFFFFFF:
            raise FieldRangeError(f"EtherCAT: logical address {lad:#x} does not fit 32 bits")
        return cls(cmd, lad & 0xFFFF, lad >> 16, data, **kwargs)  # type: ignore[arg-type]

    @property
    def lad(self) -> int:
        """The 32-bit logical address (meaningful for LRD/LWR/LRW)."""
        return self.adp | (self.ado << 16)

    @property
    def length(self) -> int:
        """The 11-bit length field: data bytes."""
        return len(self.data)

    @property
    def size_bytes(self) -> int:
        """Bytes the datagram occupies in a frame: 12 + data."""
        return DATAGRAM_OVERHEAD_BYTES + len(self.data)

    def to_bytes(self, more: bool = False) -> bytes:
        """Encode; ``more`` is the M bit the frame's layout calls for (unless overridden)."""
        n = len(self.data)
        if n > MAX_LENGTH_FIELD:
            raise FieldRangeError(
                f"EtherCAT datagram: {n} data bytes do not fit the 11-bit length", field="length"
            )
        if not 0 <= self.reserved <= 7:
            raise FieldRangeError("EtherCAT datagram: reserved bits are 3 bits", field="reserved")
        m = more if self.more is None else self.more
        word = n | (self.reserved << 11) | (_CIRCULATING if self.circulating else 0)
        word |= _MORE if m else 0
        try:
            head = _DG_HEAD.pack(self.cmd, self.idx, self.adp, self.ado, word, self.irq)
            tail = _U16.pack(self.wkc)
        except struct.error as exc:
            raise FieldRangeError(f"EtherCAT datagram: {exc}") from exc
        return head + self.data + tail


@dataclass(frozen=True, slots=True)
class EcatFrame:
    """An EtherCAT frame: the 2-byte header (ETG.1000.4 Table 12) and its datagrams.

    ``length`` None means "the sum of the datagrams", which the encoder computes; a decoder sets it
    only when the received header disagreed (kept for byte-exactness, reported as a finding).
    """

    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_ECAT
    datagrams: tuple[Datagram, ...]
    frame_type: int = FrameType.ECAT
    reserved: bool = False
    length: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.datagrams, tuple):
            object.__setattr__(self, "datagrams", tuple(self.datagrams))

    @property
    def datagram_bytes(self) -> int:
        """Sum over the datagrams of 12 + data: the value of a consistent length field."""
        return sum(DATAGRAM_OVERHEAD_BYTES + len(d.data) for d in self.datagrams)

    def to_bytes(self) -> bytes:
        """The EtherCAT bytes (header + datagrams), without Ethernet padding."""
        total = self.datagram_bytes
        if FRAME_HEADER_BYTES + total > ethernet.MAX_PAYLOAD_BYTES:
            raise FrameTooLargeError(
                f"EtherCAT frame: {FRAME_HEADER_BYTES + total} bytes exceed the "
                f"{ethernet.MAX_PAYLOAD_BYTES}-byte Ethernet payload",
                field="datagrams",
            )
        length = total if self.length is None else self.length
        if not 0 <= length <= MAX_LENGTH_FIELD or not 0 <= self.frame_type <= 0xF:
            raise FieldRangeError("EtherCAT header: length is 11 bits, type 4 bits", field="header")
        header = length | (0x0800 if self.reserved else 0) | (self.frame_type << 12)
        last = len(self.datagrams) - 1
        parts = [_U16.pack(header)]
        parts += [d.to_bytes(more=i < last) for i, d in enumerate(self.datagrams)]
        return b"".join(parts)


def decode(payload: bytes, *, strict: bool = True) -> tuple[EcatFrame, int, list[Finding]]:
    """Decode the EtherCAT part of a frame (the bytes after the EtherType).

    Datagrams are read as Wireshark reads them: while bytes remain and the previous datagram's
    M bit is set. A chain whose last M bit is set ends where the header length says it ends.

    Returns:
        The frame, how many bytes it occupies (the rest is padding), and findings.

    Raises:
        DecodeError: truncated datagrams, a non-command frame type, or (strict) an inconsistent
            header length, reserved bits, or a wrong more-follows chain.
    """
    findings: list[Finding] = []
    buf = bytes(payload)
    if len(buf) < FRAME_HEADER_BYTES:
        raise TruncatedError(f"EtherCAT: {len(buf)} bytes, the header needs 2", offset=0)
    (header,) = _U16.unpack_from(buf)
    length, frame_type, reserved = header & _LEN_MASK, header >> 12, bool(header & 0x0800)
    if frame_type != FrameType.ECAT:
        raise InvalidFieldError(
            f"EtherCAT: header type {frame_type} is not 1 (EtherCAT commands); not decoded",
            field="header.type",
            offset=0,
        )
    if reserved:
        msg = "EtherCAT header: reserved bit 11 set"
        if strict:
            raise InvalidFieldError(msg, field="header.reserved", offset=0)
        findings.append(warning("ecat.header.reserved", msg))
    datagrams: list[Datagram] = []
    append = datagrams.append
    unpack_head = _DG_HEAD.unpack_from
    buf_len = len(buf)
    pos = FRAME_HEADER_BYTES
    more = True
    while more and pos < buf_len:
        if buf_len - pos < DATAGRAM_HEADER_BYTES:
            raise TruncatedError(
                f"EtherCAT datagram {len(datagrams)}: {buf_len - pos} bytes left, header needs 10",
                field=f"datagrams[{len(datagrams)}]",
                offset=pos,
            )
        cmd, idx, adp, ado, word, irq = unpack_head(buf, pos)
        n = word & _LEN_MASK
        end = pos + DATAGRAM_HEADER_BYTES + n
        if end + WKC_BYTES > buf_len:
            raise TruncatedError(
                f"EtherCAT datagram {len(datagrams)}: length {n} runs past the frame "
                f"({buf_len - pos - DATAGRAM_OVERHEAD_BYTES} bytes left)",
                field=f"datagrams[{len(datagrams)}].length",
                offset=pos + 6,
            )
        more = word & _MORE != 0
        wkc = buf[end] | buf[end + 1] << 8  # little-endian u16, without a struct call
        res = (word & _RESERVED_MASK) >> 11
        if res:
            msg = f"EtherCAT datagram {len(datagrams)}: reserved length bits {res:#x} set"
            if strict:
                raise InvalidFieldError(msg, field=f"datagrams[{len(datagrams)}].reserved")
            findings.append(warning("ecat.datagram.reserved", msg))
        command: int | None = _COMMAND_OF[cmd]
        if command is None:
            msg = f"EtherCAT datagram {len(datagrams)}: unknown command {cmd:#04x}"
            if strict:
                raise InvalidFieldError(msg, field=f"datagrams[{len(datagrams)}].cmd", offset=pos)
            findings.append(error("ecat.cmd.unknown", msg))
            command = cmd
        pos = end + WKC_BYTES
        override: bool | None = None
        if more and (pos - FRAME_HEADER_BYTES == length or pos >= buf_len):
            msg = f"EtherCAT datagram {len(datagrams)}: more-follows set on the last datagram"
            if strict:
                raise InvalidFieldError(msg, field=f"datagrams[{len(datagrams)}].more")
            findings.append(warning("ecat.more.last", msg))
            override, more = True, False
        # What Datagram(command, adp, ado, ...) builds, in half the time (see _new_datagram).
        d = _new_datagram(Datagram)
        _set_cmd(d, command)
        _set_adp(d, adp)
        _set_ado(d, ado)
        _set_data(d, buf[end - n : end])
        _set_idx(d, idx)
        _set_irq(d, irq)
        _set_wkc(d, wkc)
        _set_circulating(d, word & _CIRCULATING != 0)
        _set_more(d, override)
        _set_reserved(d, res)
        append(d)
    total = pos - FRAME_HEADER_BYTES
    explicit: int | None = None
    if length != total:
        msg = f"EtherCAT header: length {length}, datagrams occupy {total}"
        if strict:
            raise LengthMismatchError(msg, field="header.length", offset=0)
        findings.append(error("ecat.header.length", msg))
        explicit = length
    if not datagrams:
        findings.append(info("ecat.empty", "EtherCAT frame without datagrams"))
    return EcatFrame(tuple(datagrams), frame_type, reserved, explicit), pos, findings


# Command member per byte value, None for values that are no command: one index instead of a
# frozenset test plus an IntEnum call (about 1 us) per datagram.
_COMMAND_OF: Final[tuple[Command | None, ...]] = tuple(
    Command(v) if v in Command._value2member_map_ else None for v in range(256)
)

# ethercat.decode builds every Datagram through its slot descriptors instead of the frozen
# dataclass __init__, which calls object.__setattr__ once per field: that __init__ was the largest
# single cost of decoding a 7-datagram frame (cProfile, benchmarks/bench_codecs.py). The result is
# the same object; this is valid because Datagram has no __post_init__ and these are its fields.
_new_datagram = object.__new__
(
    _set_cmd,
    _set_adp,
    _set_ado,
    _set_data,
    _set_idx,
    _set_irq,
    _set_wkc,
    _set_circulating,
    _set_more,
    _set_reserved,
) = (getattr(Datagram, f.name).__set__ for f in fields(Datagram))
assert tuple(f.name for f in fields(Datagram)) == (
    "cmd",
    "adp",
    "ado",
    "data",
    "idx",
    "irq",
    "wkc",
    "circulating",
    "more",
    "reserved",
) and not hasattr(Datagram, "__post_init__")


# --- layout: how many datagrams fit a frame (paper eqs. 14-15) -------------------------------------
def datagrams_per_frame(
    data_bytes: int, max_payload_bytes: int = ethernet.MAX_PAYLOAD_BYTES
) -> int:
    """Largest number of equal datagrams of ``data_bytes`` that fit one frame (paper eq. 15).

    max_tgram = floor((1500 - 2) / (D_data + 10 + 2)).
    """
    if data_bytes < 0 or data_bytes > MAX_DATAGRAM_DATA_BYTES:
        raise FieldRangeError(f"EtherCAT: {data_bytes} data bytes per datagram (0..1486)")
    return (max_payload_bytes - FRAME_HEADER_BYTES) // (data_bytes + DATAGRAM_OVERHEAD_BYTES)


def frames_needed(datagrams: int, data_bytes: int) -> int:
    """Frames for ``datagrams`` equal datagrams: ceil(n / max_tgram).

    This is the paper's eq. (14) with the fraction the right way up; the print has
    ceil(max_tgram / n), see docs/paper-notes.md.
    """
    per = datagrams_per_frame(data_bytes)
    return -(-datagrams // per)


def pack_datagrams(
    datagrams: Iterable[Datagram], max_payload_bytes: int = ethernet.MAX_PAYLOAD_BYTES
) -> list[EcatFrame]:
    """Pack datagrams in order into as few frames as fit (each at most ``max_payload_bytes``)."""
    frames: list[EcatFrame] = []
    current: list[Datagram] = []
    used = FRAME_HEADER_BYTES
    for d in datagrams:
        size = d.size_bytes
        if FRAME_HEADER_BYTES + size > max_payload_bytes:
            raise FrameTooLargeError(f"EtherCAT: a datagram of {size} bytes fits no frame")
        if used + size > max_payload_bytes:
            frames.append(EcatFrame(tuple(current)))
            current, used = [], FRAME_HEADER_BYTES
        current.append(d)
        used += size
    if current:
        frames.append(EcatFrame(tuple(current)))
    return frames


def data_offsets(ecat: EcatFrame) -> tuple[int, ...]:
    """Where each datagram's data starts in the Ethernet frame :func:`frame` builds for ``ecat``
    (untagged; ETG.1000.4 Table 12/13: frame header, then per datagram a 10-byte header, the
    data and the working counter)."""
    at = ethernet.HEADER_BYTES + FRAME_HEADER_BYTES
    out = []
    for d in ecat.datagrams:
        out.append(at + DATAGRAM_HEADER_BYTES)
        at += d.size_bytes
    return tuple(out)


def returned_mac(src: bytes) -> bytes:
    """The source MAC of a frame after it passed an ESC: bit 0x02 of the first octet set."""
    return bytes((src[0] | RETURNED_MAC_BIT,)) + src[1:]


def frame(
    ecat: EcatFrame, *, src: bytes = MASTER_MAC, returned: bool = False
) -> ethernet.EthernetFrame:
    """Wrap an EtherCAT frame in Ethernet as a master sends it (broadcast destination)."""
    return ethernet.EthernetFrame(BROADCAST_MAC, returned_mac(src) if returned else src, ecat)


# --- batch fast path: numpy, one fixed layout (k datagrams of B bytes) per call ------------------
def _layout(k: int, size: int) -> tuple[int, int, int]:
    if k < 1 or size < 0:
        raise FieldRangeError("EtherCAT batch: need k >= 1 datagrams of size >= 0")
    body = FRAME_HEADER_BYTES + k * (DATAGRAM_OVERHEAD_BYTES + size)
    if body > ethernet.MAX_PAYLOAD_BYTES:
        raise FrameTooLargeError(f"EtherCAT batch: {k} x {size} bytes exceed one frame")
    stride = DATAGRAM_OVERHEAD_BYTES + size
    return body, stride, max(ethernet.HEADER_BYTES + body, ethernet.MIN_FRAME_BYTES)


def pack_frames_batch(
    cmds: Sequence[int],
    addresses: npt.ArrayLike,
    data: npt.NDArray[np.uint8],
    *,
    idx: npt.ArrayLike = 0,
    wkc: npt.ArrayLike = 0,
    src: bytes = MASTER_MAC,
    dst: bytes = BROADCAST_MAC,
) -> npt.NDArray[np.uint8]:
    """Build n Ethernet frames of k datagrams each at once.

    Args:
        cmds: the k commands, the same in every frame.
        addresses: (k,) or (n, k) 32-bit addresses (``adp | ado << 16``, or the logical address).
        data: uint8 array (n, k, B): the data of every datagram.
        idx: index byte per datagram, broadcast to (n, k).
        wkc: working counter per datagram, broadcast to (n, k).
        src: source MAC; dst: destination MAC.

    Returns:
        uint8 array (n, L): row i equals ``frame(EcatFrame(...)).to_bytes()`` for frame i.
    """
    data = np.asarray(data)
    if data.dtype != np.uint8 or data.ndim != 3:
        raise TypeError("data must be a uint8 array of shape (n, k, B)")
    n, k, size = data.shape
    if len(cmds) != k:
        raise FieldRangeError(f"EtherCAT batch: {len(cmds)} commands for {k} datagrams")
    if not all(0 <= c <= 0xFF for c in cmds):
        raise FieldRangeError("EtherCAT batch: commands must fit 8 bits", field="cmd")
    if len(src) != ethernet.MAC_BYTES or len(dst) != ethernet.MAC_BYTES:
        raise FieldRangeError("EtherCAT batch: MAC addresses must be 6 bytes", field="dst/src")
    body, stride, length = _layout(k, size)
    addr = np.broadcast_to(np.asarray(addresses, dtype=np.int64), (n, k))
    idx_a = np.broadcast_to(np.asarray(idx, dtype=np.int64), (n, k))
    wkc_a = np.broadcast_to(np.asarray(wkc, dtype=np.int64), (n, k))
    for name, arr, hi in (
        ("address", addr, 0xFFFFFFFF),
        ("idx", idx_a, 0xFF),
        ("wkc", wkc_a, 0xFFFF),
    ):
        if arr.size and (arr.min() < 0 or arr.max() > hi):
            raise FieldRangeError(f"EtherCAT batch: {name} out of range", field=name)
    template = np.zeros(length, dtype=np.uint8)
    head = dst + src + struct.pack(">H", ethernet.ETHERTYPE_ECAT)
    head += _U16.pack((body - FRAME_HEADER_BYTES) | (FrameType.ECAT << 12))
    template[: len(head)] = np.frombuffer(head, dtype=np.uint8)
    base = ethernet.HEADER_BYTES + FRAME_HEADER_BYTES
    for j, cmd in enumerate(cmds):
        word = size | (_MORE if j < k - 1 else 0)
        template[base + j * stride : base + j * stride + 10] = np.frombuffer(
            _DG_HEAD.pack(cmd, 0, 0, 0, word, 0), dtype=np.uint8
        )
    out = np.empty((n, length), dtype=np.uint8)
    out[:] = template
    dg = out[:, base : base + k * stride].reshape(n, k, stride)
    dg[:, :, 1] = idx_a
    dg[:, :, 2:6] = addr.astype("<u4")[..., None].view(np.uint8)
    dg[:, :, 10 : 10 + size] = data
    dg[:, :, 10 + size : 12 + size] = wkc_a.astype("<u2")[..., None].view(np.uint8)
    return out


def unpack_frames_batch(
    frames: npt.NDArray[np.uint8], k: int, size: int
) -> tuple[
    npt.NDArray[np.uint8], npt.NDArray[np.uint32], npt.NDArray[np.uint8], npt.NDArray[np.uint16]
]:
    """Parse n frames of one fixed layout (k datagrams of ``size`` bytes) at once.

    Every row is checked (EtherType, header length and type, each datagram's length and M bit)
    with vectorised tests; a batch that fails them raises, and the caller falls back to
    :func:`decode` frame by frame.

    Returns:
        (cmds (n, k), addresses (n, k), data (n, k, size) as a read-only view, wkc (n, k)).
    """
    frames = np.asarray(frames, dtype=np.uint8)
    body, stride, _ = _layout(k, size)
    if frames.ndim != 2 or frames.shape[1] < ethernet.HEADER_BYTES + body:
        raise TruncatedError("EtherCAT batch: rows shorter than the layout")
    n = frames.shape[0]
    ok = (frames[:, 12] == 0x88) & (frames[:, 13] == 0xA4)
    hdr = frames[:, 14].astype(np.uint16) | (frames[:, 15].astype(np.uint16) << 8)
    ok &= hdr == ((body - FRAME_HEADER_BYTES) | (FrameType.ECAT << 12))
    base = ethernet.HEADER_BYTES + FRAME_HEADER_BYTES
    dg = frames[:, base : base + k * stride].reshape(n, k, stride)
    words = dg[:, :, 6].astype(np.uint16) | (dg[:, :, 7].astype(np.uint16) << 8)
    expect = np.full(k, size | _MORE, dtype=np.uint16)
    expect[-1] = size
    ok &= np.all((words & ~np.uint16(_CIRCULATING)) == expect, axis=1)
    if not bool(np.all(ok)):
        bad = int(np.argmin(ok))
        raise LengthMismatchError(
            f"EtherCAT batch: frame {bad} does not have the {k}x{size} layout"
        )
    addr = np.ascontiguousarray(dg[:, :, 2:6]).view("<u4")[..., 0]
    wkc = np.ascontiguousarray(dg[:, :, 10 + size : 12 + size]).view("<u2")[..., 0]
    data = dg[:, :, 10 : 10 + size]
    data.flags.writeable = False
    return dg[:, :, 0], addr, data, wkc
