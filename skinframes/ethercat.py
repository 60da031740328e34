"""EtherCAT frames (EtherType 0x88A4): the frame header and datagrams with all commands.

Layouts: ETG.1000.4 / IEC 61158-4-12 section 5.3 (frame structure, Table 12 EtherCAT header, Table 13
datagram) as Wireshark's ``packet-ethercat-frame.c`` / ``packet-ethercat-datagram.c`` and SOEM's
``ethercattype.h`` implement them. All integers little-endian.

Frame types (the header's Type, ETG.1000.4 Table 12): 1 carries datagrams; 4 network variables
(a publisher header and its variables, as Wireshark's ``packet-nv.c`` dissects them); 5 a mailbox
(the mailbox header of ETG.1000.4 5.6 and its data, Wireshark ``packet-ecatmb.c``). The other
types are reserved in ETG.1000.4 (Wireshark names 2 ADS and 3 RAW-IO, Beckhoff's): their bytes
are kept and a warning says so.

The construct schemas are the schema of record. Encoding and decoding of whole frames run on a
``struct`` fast path that the tests prove byte-identical to the schemas; a numpy batch path builds
and parses many frames of one fixed layout at once (:func:`pack_frames_batch`).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, fields
from enum import IntEnum
from typing import TYPE_CHECKING, ClassVar, Final

import construct as cs

from skinframes import ethernet
from skinframes.errors import (
    FieldRangeError,
    FrameTooLargeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
)
from skinframes.findings import Finding, error, info, warning

if TYPE_CHECKING:  # numpy is imported where an array is made: reading needs none
    import numpy as np
    import numpy.typing as npt

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
    "Mailbox",
    "NetworkVariable",
    "NvPublication",
    "content_fields",
    "data_offsets",
    "datagram_head",
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

# Type 4, network variables (Wireshark packet-nv.h NvParserHDR, ETYPE_88A4_NV_DATA_HEADER).
NV_HEADER_BYTES: Final = 12
NV_VARIABLE_HEADER_BYTES: Final = 8
nv_header_schema = cs.Struct(
    "publisher" / cs.Bytes(6),
    "count" / cs.Int16ul,
    "cycle_index" / cs.Int16ul,
    "reserved" / cs.Int16ul,
)
nv_variable_schema = cs.Struct(
    "id" / cs.Int16ul,
    "hash" / cs.Int16ul,
    "length" / cs.Rebuild(cs.Int16ul, cs.len_(cs.this.data)),
    "quality" / cs.Int16ul,
    "data" / cs.Bytes(cs.this.length),
)

# Type 5, mailbox (ETG.1000.4 5.6 Table 29 mailbox header; Wireshark packet-ecatmb.h).
MAILBOX_HEADER_BYTES: Final = 6
mailbox_header_schema = cs.Struct(
    "length" / cs.Int16ul,
    "address" / cs.Int16ul,
    "control"
    / cs.ByteSwapped(  # one LE word: counter:3 reserved:1 | type:4 | priority:2 channel:6
        cs.BitStruct(
            "reserved" / cs.Flag,
            "counter" / cs.BitsInteger(3),
            "type" / cs.BitsInteger(4),
            "priority" / cs.BitsInteger(2),
            "channel" / cs.BitsInteger(6),
        )
    ),
)

# --- fast path: struct, proven byte-identical to the schemas (tests/skinframes/test_ethercat.py) --
_DG_HEAD = struct.Struct("<BBHHHH")  # cmd idx adp ado len|flags irq
_NV_HEAD = struct.Struct("<6sHHH")
_NV_VAR = struct.Struct("<HHHH")
_MBX_HEAD = struct.Struct("<HHH")
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
class NetworkVariable:
    """One network variable of a type-4 frame: id, hash, length, quality, then the data."""

    id: int
    data: bytes = b""
    hash: int = 0
    quality: int = 0

    def to_bytes(self) -> bytes:
        """The 8-byte variable header and the data."""
        try:
            return _NV_VAR.pack(self.id, self.hash, len(self.data), self.quality) + self.data
        except struct.error as exc:
            raise FieldRangeError(f"EtherCAT network variable: {exc}") from exc


@dataclass(frozen=True, slots=True)
class NvPublication:
    """The content of a type-4 frame: the publisher header and its network variables.

    ``count`` None means "the number of variables"; a decoder keeps a disagreeing value.
    """

    publisher: bytes
    variables: tuple[NetworkVariable, ...] = ()
    cycle_index: int = 0
    reserved: int = 0
    count: int | None = None

    def __post_init__(self) -> None:
        if len(self.publisher) != 6:
            raise FieldRangeError("EtherCAT NV: the publisher is 6 bytes", field="publisher")
        if not isinstance(self.variables, tuple):
            object.__setattr__(self, "variables", tuple(self.variables))

    def to_bytes(self) -> bytes:
        """Publisher header (12 bytes) and the variables."""
        count = len(self.variables) if self.count is None else self.count
        try:
            head = _NV_HEAD.pack(self.publisher, count, self.cycle_index, self.reserved)
        except struct.error as exc:
            raise FieldRangeError(f"EtherCAT NV header: {exc}") from exc
        return head + b"".join(v.to_bytes() for v in self.variables)

    @classmethod
    def decode(cls, buf: bytes) -> NvPublication:
        """Decode the bytes after the EtherCAT header (without padding past the variables).

        Raises:
            TruncatedError: the header or a variable runs past the bytes.
        """
        if len(buf) < NV_HEADER_BYTES:
            raise TruncatedError(f"EtherCAT NV: {len(buf)} bytes, the header needs 12", offset=0)
        publisher, count, cycle_index, reserved = _NV_HEAD.unpack_from(buf)
        pos, variables = NV_HEADER_BYTES, []
        for k in range(count):
            if len(buf) - pos < NV_VARIABLE_HEADER_BYTES:
                raise TruncatedError(f"EtherCAT NV: variable {k} of {count} missing", offset=pos)
            ident, hsh, n, quality = _NV_VAR.unpack_from(buf, pos)
            start = pos + NV_VARIABLE_HEADER_BYTES
            if start + n > len(buf):
                raise TruncatedError(
                    f"EtherCAT NV: variable {k} length {n} runs past the frame", offset=pos + 4
                )
            variables.append(NetworkVariable(ident, buf[start : start + n], hsh, quality))
            pos = start + n
        return cls(publisher, tuple(variables), cycle_index, reserved)

    @property
    def size_bytes(self) -> int:
        """Bytes the publication occupies."""
        return NV_HEADER_BYTES + sum(NV_VARIABLE_HEADER_BYTES + len(v.data) for v in self.variables)


@dataclass(frozen=True, slots=True)
class Mailbox:
    """The content of a type-5 frame (mailbox gateway): mailbox header (ETG.1000.4 5.6) + data.

    ``mailbox_type``: 1 AoE, 2 EoE, 3 CoE, 4 FoE, 5 SoE, 15 VoE (ETG.1000.6 5.6 Table 29).
    """

    address: int
    mailbox_type: int
    data: bytes = b""
    channel: int = 0
    priority: int = 0
    counter: int = 0
    reserved: bool = False

    def to_bytes(self) -> bytes:
        """Header (length, address, control word) and data."""
        if not (0 <= self.channel < 64 and 0 <= self.priority < 4 and 0 <= self.counter < 8):
            raise FieldRangeError("EtherCAT mailbox: channel 6, priority 2, counter 3 bits")
        if not 0 <= self.mailbox_type <= 0xF:
            raise FieldRangeError("EtherCAT mailbox: type is 4 bits", field="mailbox_type")
        control = self.channel | self.priority << 6 | self.mailbox_type << 8 | self.counter << 12
        control |= 0x8000 if self.reserved else 0
        try:
            return _MBX_HEAD.pack(len(self.data), self.address, control) + self.data
        except struct.error as exc:
            raise FieldRangeError(f"EtherCAT mailbox: {exc}") from exc

    @classmethod
    def decode(cls, buf: bytes) -> Mailbox:
        """Decode the mailbox header and its ``length`` data bytes.

        Raises:
            TruncatedError: the header or the data runs past the bytes.
        """
        if len(buf) < MAILBOX_HEADER_BYTES:
            raise TruncatedError(f"EtherCAT mailbox: {len(buf)} bytes, the header needs 6")
        n, address, control = _MBX_HEAD.unpack_from(buf)
        if MAILBOX_HEADER_BYTES + n > len(buf):
            raise TruncatedError(
                f"EtherCAT mailbox: length {n} runs past the frame "
                f"({len(buf) - MAILBOX_HEADER_BYTES} bytes left)",
                field="length",
                offset=0,
            )
        return cls(
            address,
            control >> 8 & 0xF,
            buf[MAILBOX_HEADER_BYTES : MAILBOX_HEADER_BYTES + n],
            control & 0x3F,
            control >> 6 & 0x3,
            control >> 12 & 0x7,
            bool(control & 0x8000),
        )

    @property
    def size_bytes(self) -> int:
        """Bytes the mailbox occupies."""
        return MAILBOX_HEADER_BYTES + len(self.data)


Content = NvPublication | Mailbox | bytes


@dataclass(frozen=True, slots=True)
class EcatFrame:
    """An EtherCAT frame: the 2-byte header (ETG.1000.4 Table 12) and its datagrams (type 1) or
    its ``content`` (type 4 :class:`NvPublication`, type 5 :class:`Mailbox`, other types raw bytes).

    ``length`` None means "the sum of the datagrams" (or the content's size), which the encoder
    computes; a decoder sets it only when the received header disagreed (kept for
    byte-exactness, reported as a finding).
    """

    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_ECAT
    datagrams: tuple[Datagram, ...]
    frame_type: int = FrameType.ECAT
    reserved: bool = False
    length: int | None = None
    content: Content | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.datagrams, tuple):
            object.__setattr__(self, "datagrams", tuple(self.datagrams))

    @property
    def datagram_bytes(self) -> int:
        """Sum over the datagrams of 12 + data: the value of a consistent length field."""
        return sum(DATAGRAM_OVERHEAD_BYTES + len(d.data) for d in self.datagrams)

    @property
    def length_field(self) -> int:
        """The header's Length as sent (Wireshark ``ecatf.length``)."""
        if self.length is not None:
            return self.length
        if self.content is not None:
            return len(_content_bytes(self.content))
        return self.datagram_bytes

    def to_bytes(self) -> bytes:
        """The EtherCAT bytes (header + datagrams or content), without Ethernet padding."""
        if self.content is not None:
            body = _content_bytes(self.content)
            total = len(body)
        else:
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
        if self.content is not None:
            return _U16.pack(header) + body
        last = len(self.datagrams) - 1
        parts = [_U16.pack(header)]
        parts += [d.to_bytes(more=i < last) for i, d in enumerate(self.datagrams)]
        return b"".join(parts)


def content_fields(ecat: EcatFrame) -> dict[str, object]:
    """JSON fields of a type-4 or type-5 frame's content, named as Wireshark's ``tc_nv.*`` and
    ``ecat_mailbox.*`` fields; empty for datagram frames."""
    c = ecat.content
    if isinstance(c, NvPublication):
        return {
            "nv": {
                "publisher": c.publisher.hex(":"),
                "count": len(c.variables) if c.count is None else c.count,
                "cycleindex": c.cycle_index,
                "variables": [
                    {"id": v.id, "hash": v.hash, "length": len(v.data), "quality": v.quality}
                    for v in c.variables
                ],
            }
        }
    if isinstance(c, Mailbox):
        return {
            "mailbox": {
                "length": len(c.data),
                "address": c.address,
                "priority": c.priority,
                "type": c.mailbox_type,
                "counter": c.counter,
            }
        }
    if c is not None:
        return {"content_length": len(c)}
    return {}


def _content_bytes(content: Content) -> bytes:
    return bytes(content) if isinstance(content, bytes | bytearray) else content.to_bytes()


RESERVED_TYPE_NAMES: Final = {2: "ADS", 3: "RAW-IO"}  # Wireshark's names for reserved types


def _decode_content(
    buf: bytes, frame_type: int, length: int, reserved: bool, strict: bool
) -> tuple[EcatFrame, int, list[Finding]]:
    """Frame types other than 1: network variables, mailbox, reserved (kept as bytes)."""
    findings: list[Finding] = []
    body = buf[FRAME_HEADER_BYTES:]
    content: Content
    if frame_type == FrameType.NV:
        content = NvPublication.decode(body)
        size = content.size_bytes
        if content.reserved:
            findings.append(warning("ecat.nv.reserved", "EtherCAT NV: reserved word not zero"))
    elif frame_type == FrameType.MAILBOX:
        content = Mailbox.decode(body)
        size = content.size_bytes
    else:
        name = RESERVED_TYPE_NAMES.get(frame_type, "reserved")
        msg = (
            f"EtherCAT header: type {frame_type} ({name}) is reserved in ETG.1000.4 Table 12; "
            "its bytes are kept undecoded"
        )
        if strict:
            raise InvalidFieldError(msg, field="header.type", offset=0)
        findings.append(warning("ecat.type.reserved", msg))
        size = min(length, len(body))
        content = body[:size]
    explicit: int | None = None
    if length != size:
        msg = f"EtherCAT header: length {length}, the type-{frame_type} content occupies {size}"
        if strict:
            raise LengthMismatchError(msg, field="header.length", offset=0)
        findings.append(error("ecat.header.length", msg))
        explicit = length
    frame = EcatFrame((), frame_type, reserved, explicit, content)
    return frame, FRAME_HEADER_BYTES + size, findings


def decode(payload: bytes, *, strict: bool = True) -> tuple[EcatFrame, int, list[Finding]]:
    """Decode the EtherCAT part of a frame (the bytes after the EtherType).

    Datagrams are read as Wireshark reads them (``packet-ethercat-datagram.c``): while the
    previous datagram's M bit is set and bytes remain, whatever the header length says. Where
    the chain and the header length disagree, one finding names both: ``ecat.more.last`` when
    a datagram has its M bit set where the header length ends (or where the frame ends),
    ``ecat.header.length`` otherwise; an M bit pointing at bytes too short for a datagram is
    ``ecat.more.truncated`` (Wireshark: malformed). Types 4 and 5 decode their content
    (:class:`NvPublication`, :class:`Mailbox`), reserved types are kept as bytes.

    Returns:
        The frame, how many bytes it occupies (the rest is padding), and findings.

    Raises:
        DecodeError: a truncated first datagram or content, or (strict) an inconsistent header
            length, reserved bits or types, or a wrong more-follows chain.
    """
    findings: list[Finding] = []
    buf = bytes(payload)
    if len(buf) < FRAME_HEADER_BYTES:
        raise TruncatedError(f"EtherCAT: {len(buf)} bytes, the header needs 2", offset=0)
    (header,) = _U16.unpack_from(buf)
    length, frame_type, reserved = header & _LEN_MASK, header >> 12, bool(header & 0x0800)
    if reserved:
        msg = "EtherCAT header: reserved bit 11 set"
        if strict:
            raise InvalidFieldError(msg, field="header.reserved", offset=0)
        findings.append(warning("ecat.header.reserved", msg))
    if frame_type != FrameType.ECAT:
        frame, used, more_findings = _decode_content(buf, frame_type, length, reserved, strict)
        return frame, used, findings + more_findings
    datagrams: list[Datagram] = []
    append = datagrams.append
    unpack_head = _DG_HEAD.unpack_from
    buf_len = len(buf)
    pos = FRAME_HEADER_BYTES
    more = True
    more_at_length: int | None = None  # the datagram whose M bit is set where the length ends
    while more and pos < buf_len:
        k = len(datagrams)
        n = (unpack_head(buf, pos)[4] & _LEN_MASK) if buf_len - pos >= DATAGRAM_HEADER_BYTES else 0
        if buf_len - pos < DATAGRAM_HEADER_BYTES or pos + DATAGRAM_OVERHEAD_BYTES + n > buf_len:
            left = buf_len - pos
            text = (
                f"EtherCAT datagram {k}: {left} bytes left, header needs 10"
                if left < DATAGRAM_HEADER_BYTES
                else f"EtherCAT datagram {k}: length {n} runs past the frame "
                f"({left - DATAGRAM_OVERHEAD_BYTES} bytes left)"
            )
            if strict or not datagrams:
                raise TruncatedError(
                    text, field=f"datagrams[{k}]", offset=pos if left < 10 else pos + 6
                )
            findings.append(
                error(
                    "ecat.more.truncated",
                    f"EtherCAT datagram {k - 1}: M bit set, but {text[len('EtherCAT ') :]} "
                    "(Wireshark: malformed); the bytes stay padding",
                )
            )
            datagrams[-1] = _with_more(datagrams[-1])
            break
        cmd, idx, adp, ado, word, irq = unpack_head(buf, pos)
        end = pos + DATAGRAM_HEADER_BYTES + n
        more = word & _MORE != 0
        wkc = buf[end] | buf[end + 1] << 8  # little-endian u16, without a struct call
        res = (word & _RESERVED_MASK) >> 11
        if res:
            msg = f"EtherCAT datagram {k}: reserved length bits {res:#x} set"
            if strict:
                raise InvalidFieldError(msg, field=f"datagrams[{k}].reserved")
            findings.append(warning("ecat.datagram.reserved", msg))
        command: int | None = _COMMAND_OF[cmd]
        if command is None:
            msg = f"EtherCAT datagram {k}: unknown command {cmd:#04x}"
            if strict:
                raise InvalidFieldError(msg, field=f"datagrams[{k}].cmd", offset=pos)
            findings.append(error("ecat.cmd.unknown", msg))
            command = cmd
        pos = end + WKC_BYTES
        override: bool | None = None
        if more and (pos - FRAME_HEADER_BYTES == length or pos >= buf_len):
            if strict:
                raise InvalidFieldError(
                    f"EtherCAT datagram {k}: more-follows set on the last datagram",
                    field=f"datagrams[{k}].more",
                )
            if pos >= buf_len:
                override = True  # nothing follows: the chain ends with the frame
                if more_at_length is None:
                    findings.append(
                        warning(
                            "ecat.more.last",
                            f"EtherCAT datagram {k}: more-follows set on the last datagram "
                            f"(the frame ends; header length {length})",
                        )
                    )
            elif more_at_length is None:
                more_at_length = k
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
    if datagrams and datagrams[-1].more is None and more and pos >= buf_len:
        datagrams[-1] = _with_more(datagrams[-1])
    total = pos - FRAME_HEADER_BYTES
    explicit: int | None = None
    if length != total:
        if more_at_length is not None:
            findings.append(
                warning(
                    "ecat.more.last",
                    f"EtherCAT datagram {more_at_length}: M bit set where the header length "
                    f"({length}) ends; the M bits chain {len(datagrams)} datagrams of {total} "
                    "bytes (Wireshark shows them all)",
                )
            )
        else:
            msg = (
                f"EtherCAT header: length {length}, the M bits chain {len(datagrams)} "
                f"datagrams of {total} bytes"
            )
            if strict:
                raise LengthMismatchError(msg, field="header.length", offset=0)
            findings.append(error("ecat.header.length", msg))
        explicit = length
    if not datagrams:
        findings.append(info("ecat.empty", "EtherCAT frame without datagrams"))
    return EcatFrame(tuple(datagrams), frame_type, reserved, explicit), pos, findings


def _with_more(d: Datagram) -> Datagram:
    """``d`` with its M bit kept set (it ends the chain although the bit says more follows)."""
    return Datagram(
        d.cmd, d.adp, d.ado, d.data, d.idx, d.irq, d.wkc, d.circulating, True, d.reserved
    )


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


def datagram_head(buf: bytes | bytearray, at: int) -> tuple[int, int, int, int, int, int]:
    """The 10-byte header of the datagram at ``buf[at:]`` (ETG.1000.4 Table 12): (cmd, idx,
    ADP, ADO, the length word (length bits 0-10, circulating bit 14, M bit 15), IRQ)."""
    return _DG_HEAD.unpack_from(buf, at)


def returned_mac(src: bytes) -> bytes:
    """The source MAC of a frame after it passed an ESC: bit 0x02 of the first octet set."""
    return bytes((src[0] | RETURNED_MAC_BIT,)) + src[1:]


def frame(
    ecat: EcatFrame,
    *,
    src: bytes = MASTER_MAC,
    returned: bool = False,
    tags: tuple[ethernet.Tag, ...] = (),
) -> ethernet.EthernetFrame:
    """Wrap an EtherCAT frame in Ethernet as a master sends it (broadcast destination), with
    VLAN ``tags`` if given (ETG.1000.4 5.3: EtherCAT frames may carry an 802.1Q tag)."""
    mac = returned_mac(src) if returned else src
    return ethernet.EthernetFrame(BROADCAST_MAC, mac, ecat, tags=tags)


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
    import numpy as np  # here, not at the top: reading captures needs no numpy

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
    import numpy as np  # here, not at the top: reading captures needs no numpy

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
