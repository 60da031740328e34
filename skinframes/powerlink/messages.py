"""The EPL messages (DS 301 4.6.1.1): SoC, PReq, PRes, SoA, ASnd and RawMessage.

Each class writes its bytes in ``to_bytes`` and reads them in ``_decode``: SoC, PReq and SoA with
their schemas of record (:mod:`.schemas`), ASnd's 4-byte header and RawMessage as plain bytes.
The PRes, sent by every CN in every cycle, uses one ``struct`` call both ways (:func:`pack_pres`,
``PRES_HEAD``; tests prove them equal to ``pres_schema``).

``_decode`` takes the EPL bytes (the message plus any Ethernet padding) and returns the message
and how many bytes it occupies; :func:`skinframes.powerlink.decode` picks the class by
MessageType. The ASnd services are in :mod:`.services`; the numpy batch (:mod:`.batch`) copies a
frame encoded here and writes only the columns that differ.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import ClassVar

import construct as cs

from skinframes import ethernet
from skinframes.errors import (
    FieldRangeError,
    FrameTooLargeError,
    InvalidFieldError,
    TruncatedError,
    encoding,
)
from skinframes.findings import Finding, error, info
from skinframes.powerlink.enums import (
    BROADCAST_NODE_ID,
    EPL_VERSION_2_0,
    MN_NODE_ID,
    MessageType,
    NmtState,
    PReqFlag,
    PResFlag,
    RequestedService,
    known,
)
from skinframes.powerlink.schemas import (
    ASND_HEADER_BYTES,
    HEADER_BYTES,
    MAX_PDO_PAYLOAD_BYTES,
    PDO_HEADER_BYTES,
    PDO_SIZE_OFFSET,
    PREQ_HEAD,
    PRES_HEAD,
    SOA_BYTES,
    SOA_STRUCT,
    SOA_SYNC_REQUEST,
    SOC_BYTES,
    SOC_STRUCT,
    SYNC_REQUEST_BYTES,
    build,
    field_values,
    preq_schema,
    soa_schema,
    soc_schema,
)
from skinframes.powerlink.services import Service, decode_service


@dataclass(frozen=True, slots=True)
class SoC:
    """Start of Cycle (DS 301 4.6.1.1.1): the MN's multicast that opens each cycle."""

    MESSAGE_TYPE: ClassVar[int] = MessageType.SOC
    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_EPL
    dest: int = BROADCAST_NODE_ID
    src: int = MN_NODE_ID
    flags: int = 0
    net_time_s: int = 0
    net_time_ns: int = 0
    relative_time_us: int = 0
    reserved_3: int = 0
    reserved_5: int = 0

    def to_bytes(self) -> bytes:
        """The EPL bytes (22), without Ethernet padding."""
        return _build(soc_schema, self)

    @classmethod
    def _decode(cls, buf: bytes, strict: bool, findings: list[Finding]) -> tuple[SoC, int]:
        """By one ``struct`` call: the fields ``soc_schema.parse`` gives (tested)."""
        if len(buf) < SOC_BYTES:
            raise TruncatedError(f"EPL SoC: {len(buf)} bytes, needs {SOC_BYTES}")
        _, dest, src, reserved_3, flags, reserved_5, s, ns, rel = SOC_STRUCT.unpack_from(buf)
        message = cls(dest, src, flags, s, ns, rel, reserved_3, reserved_5)
        if reserved_3 or reserved_5:
            _reserved("reserved_3", reserved_3, strict, findings)
            _reserved("reserved_5", reserved_5, strict, findings)
        return message, SOC_BYTES


@dataclass(frozen=True, slots=True)
class PReq:
    """Poll Request (DS 301 4.6.1.1.3): MN -> one CN, carrying the CN's output PDO."""

    MESSAGE_TYPE: ClassVar[int] = MessageType.PREQ
    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_EPL
    dest: int
    payload: bytes = b""
    src: int = MN_NODE_ID
    flags1: int = PReqFlag.RD
    flags2: int = 0
    pdo_version: int = 0
    reserved_3: int = 0
    reserved_7: int = 0

    @property
    def size(self) -> int:
        """The Size field: payload octets."""
        return len(self.payload)

    def to_bytes(self) -> bytes:
        """The EPL bytes (10 + payload), without Ethernet padding."""
        check_pdo_size(len(self.payload))
        return _build(preq_schema, self)

    @classmethod
    def _decode(cls, buf: bytes, strict: bool, findings: list[Finding]) -> tuple[PReq, int]:
        """By one ``struct`` call: the fields ``preq_schema.parse`` gives (tested)."""
        size = _pdo_size("PReq", buf)
        _, dest, src, reserved_3, flags1, flags2, version, reserved_7, _ = PREQ_HEAD.unpack_from(
            buf
        )
        end = PDO_HEADER_BYTES + size
        message = cls(
            dest, buf[PDO_HEADER_BYTES:end], src, flags1, flags2, version, reserved_3, reserved_7
        )
        if reserved_3 or reserved_7:
            _reserved("reserved_3", reserved_3, strict, findings)
            _reserved("reserved_7", reserved_7, strict, findings)
        return message, end


@dataclass(frozen=True, slots=True)
class PRes:
    """Poll Response (DS 301 4.6.1.1.4): a CN's multicast answer carrying its input PDO (taxels)."""

    MESSAGE_TYPE: ClassVar[int] = MessageType.PRES
    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_EPL
    src: int
    payload: bytes = b""
    dest: int = BROADCAST_NODE_ID
    nmt_status: int = NmtState.OPERATIONAL
    flags1: int = PResFlag.RD
    flags2: int = 0
    pdo_version: int = 0
    reserved_7: int = 0

    @property
    def size(self) -> int:
        """The Size field: payload octets."""
        return len(self.payload)

    @property
    def pr(self) -> int:
        """Priority of the pending asynchronous request (flags2 bits 3-5)."""
        return (self.flags2 >> 3) & 0x7

    @property
    def rs(self) -> int:
        """Number of pending requests to send (flags2 bits 0-2)."""
        return self.flags2 & 0x7

    def to_bytes(self) -> bytes:
        """The EPL bytes (10 + payload), without Ethernet padding."""
        check_pdo_size(len(self.payload))
        return pack_pres(
            self.src,
            self.payload,
            self.dest,
            self.nmt_status,
            self.flags1,
            self.flags2,
            self.pdo_version,
            self.reserved_7,
        )

    @classmethod
    def _decode(cls, buf: bytes, strict: bool, findings: list[Finding]) -> tuple[PRes, int]:
        """By one ``struct`` call: the fields ``pres_schema.parse`` gives (tested).

        A CN sends a PRes every cycle; with ``pres_schema.parse`` decoding one took about as long
        as scapy's dissection (benchmarks/bench_codecs.py), with ``struct`` it is several times
        faster.
        """
        size = _pdo_size("PRes", buf)
        _, dest, src, nmt, flags1, flags2, version, reserved_7, _ = PRES_HEAD.unpack_from(buf)
        end = PDO_HEADER_BYTES + size
        nmt_status = known(NmtState, nmt)
        message = cls(
            src, buf[PDO_HEADER_BYTES:end], dest, nmt_status, flags1, flags2, version, reserved_7
        )
        _reserved("reserved_7", reserved_7, strict, findings)
        return message, end


def pack_pres(
    src: int,
    payload: bytes,
    dest: int = BROADCAST_NODE_ID,
    nmt_status: int = NmtState.OPERATIONAL,
    flags1: int = PResFlag.RD,
    flags2: int = 0,
    pdo_version: int = 0,
    reserved_7: int = 0,
) -> bytes:
    """Encode a PRes message (EPL bytes) with one ``struct`` call; same bytes as ``pres_schema``."""
    try:
        head = PRES_HEAD.pack(
            MessageType.PRES,
            dest,
            src,
            nmt_status,
            flags1,
            flags2,
            pdo_version,
            reserved_7,
            len(payload),
        )
    except struct.error as exc:
        raise FieldRangeError(f"EPL PRes: {exc}") from exc
    return head + payload


@dataclass(frozen=True, slots=True)
class SoA:
    """Start of Asynchronous (DS 301 4.6.1.1.5): the MN invites one node to send an ASnd."""

    MESSAGE_TYPE: ClassVar[int] = MessageType.SOA
    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_EPL
    requested_service: int = RequestedService.NO_SERVICE
    requested_target: int = 0
    dest: int = BROADCAST_NODE_ID
    src: int = MN_NODE_ID
    nmt_status: int = NmtState.OPERATIONAL
    flags1: int = 0
    epl_version: int = EPL_VERSION_2_0
    flags3: int = 0
    sync_request: bytes | None = None  # 30 bytes, only with requested_service = SYNC_REQUEST
    reserved_5: int = 0

    def to_bytes(self) -> bytes:
        """The EPL bytes (10, or 40 with a SyncRequest), without Ethernet padding."""
        if (self.requested_service == RequestedService.SYNC_REQUEST) != (
            self.sync_request is not None
        ):
            raise FieldRangeError(
                "EPL SoA: sync_request goes with requested_service 6 and only there"
            )
        return _build(soa_schema, self)

    @classmethod
    def _decode(cls, buf: bytes, strict: bool, findings: list[Finding]) -> tuple[SoA, int]:
        """By one ``struct`` call: the fields ``soa_schema.parse`` gives (tested)."""
        if len(buf) < SOA_BYTES:
            raise TruncatedError(f"EPL SoA: {len(buf)} bytes, needs {SOA_BYTES}")
        (_, dest, src, nmt, flags1, reserved_5, service, target, version, flags3) = (
            SOA_STRUCT.unpack_from(buf)
        )
        used = SOA_BYTES
        sync_request = None
        if service == SOA_SYNC_REQUEST:
            used += SYNC_REQUEST_BYTES
            if len(buf) < used:
                raise TruncatedError(
                    f"EPL SoA: {len(buf)} bytes, a SyncRequest SoA needs {used}",
                    field="sync_request",
                    offset=SOA_BYTES,
                )
            sync_request = buf[SOA_BYTES:used]
        message = cls(
            known(RequestedService, service),
            target,
            dest,
            src,
            known(NmtState, nmt),
            flags1,
            version,
            flags3,
            sync_request,
            reserved_5,
        )
        if reserved_5:
            _reserved("reserved_5", reserved_5, strict, findings)
        return message, used


@dataclass(frozen=True, slots=True)
class ASnd:
    """Asynchronous Send (DS 301 4.6.1.1.6): one service frame in the asynchronous phase."""

    MESSAGE_TYPE: ClassVar[int] = MessageType.ASND
    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_EPL
    service: Service
    dest: int = BROADCAST_NODE_ID
    src: int = MN_NODE_ID

    @property
    def service_id(self) -> int:
        """The ServiceID byte (offset 3)."""
        return int(self.service.SERVICE_ID)

    def to_bytes(self) -> bytes:
        """The EPL bytes, without Ethernet padding."""
        check_node("dest", self.dest)
        check_node("src", self.src)
        if not 0 <= self.service_id <= 0xFF:
            raise FieldRangeError(f"EPL ASnd: service id {self.service_id} does not fit 8 bits")
        head = bytes((self.MESSAGE_TYPE, self.dest, self.src, self.service_id))
        return head + self.service.to_bytes()

    @classmethod
    def _decode(cls, buf: bytes, strict: bool, findings: list[Finding]) -> tuple[ASnd, int]:
        if len(buf) < ASND_HEADER_BYTES:
            raise TruncatedError(f"EPL ASnd: {len(buf)} bytes, needs {ASND_HEADER_BYTES}")
        body = buf[ASND_HEADER_BYTES:]
        service, used = decode_service(buf[3], body, len(buf), strict, findings)
        return cls(service, buf[1], buf[2]), ASND_HEADER_BYTES + used


@dataclass(frozen=True, slots=True)
class RawMessage:
    """An EPL message skinframes keeps as bytes: AInv, AMNI (DS 302-A), or one it cannot model.

    Attributes:
        message_type: byte 0 as sent (bit 7 included).
        data: every byte after the 3-byte common header.
    """

    ETHERTYPE: ClassVar[int] = ethernet.ETHERTYPE_EPL
    message_type: int
    dest: int
    src: int
    data: bytes = b""

    def to_bytes(self) -> bytes:
        """The EPL bytes."""
        with encoding("EPL message"):
            return bytes((self.message_type, self.dest, self.src)) + self.data

    @classmethod
    def _decode(cls, buf: bytes, strict: bool, findings: list[Finding]) -> tuple[RawMessage, int]:
        """Any MessageType but SoC, PReq, PRes, SoA, ASnd: all bytes kept, AInv/AMNI noted."""
        raw_type = buf[0]
        mtype = raw_type & 0x7F  # bit 7 reserved; Wireshark masks it off
        if raw_type & 0x80:
            msg = f"EPL: reserved bit 7 of MessageType set ({raw_type:#04x})"
        elif mtype in (MessageType.AINV, MessageType.AMNI):
            msg = f"EPL: {MessageType(mtype).name} (DS 302-A) kept as bytes"
        else:
            msg = f"EPL: unknown MessageType {mtype:#04x}; Wireshark does not decode it as EPL"
        if strict and (raw_type & 0x80 or mtype not in (MessageType.AINV, MessageType.AMNI)):
            raise InvalidFieldError(msg, field="message_type", offset=0)
        findings.append(
            info("epl.raw", msg) if raw_type in (7, 13) else error("epl.message_type", msg)
        )
        return cls(raw_type, buf[1], buf[2], buf[HEADER_BYTES:]), len(buf)


EplMessage = SoC | PReq | PRes | SoA | ASnd | RawMessage


# --- helpers of the encoders and decoders --------------------------------------------------------
def check_node(name: str, value: int) -> None:
    """Raise :class:`FieldRangeError` when a node id does not fit its byte."""
    if not 0 <= value <= 0xFF:
        raise FieldRangeError(f"EPL: node id {name}={value} does not fit 8 bits", field=name)


def check_pdo_size(size: int) -> None:
    """Raise :class:`FrameTooLargeError` for a PDO payload past ``MAX_PDO_PAYLOAD_BYTES``."""
    if size > MAX_PDO_PAYLOAD_BYTES:
        raise FrameTooLargeError(
            f"EPL: PDO payload of {size} bytes exceeds {MAX_PDO_PAYLOAD_BYTES}",
            field="payload",
        )


def _build(schema: cs.Construct, message: SoC | PReq | SoA) -> bytes:
    """The message's bytes by its schema of record."""
    values = dict(field_values(message), message_type=message.MESSAGE_TYPE)
    return build(f"EPL {type(message).__name__}", schema, values)


def _pdo_size(kind: str, buf: bytes) -> int:
    """The Size field of a PReq/PRes, checked against the bytes present."""
    if len(buf) < PDO_HEADER_BYTES:
        raise TruncatedError(f"EPL {kind}: {len(buf)} bytes, header needs {PDO_HEADER_BYTES}")
    size = int.from_bytes(buf[PDO_SIZE_OFFSET:PDO_HEADER_BYTES], "little")
    if size > len(buf) - PDO_HEADER_BYTES:
        raise TruncatedError(
            f"EPL {kind}: Size field says {size} payload bytes, only "
            f"{len(buf) - PDO_HEADER_BYTES} present",
            field="size",
            offset=PDO_SIZE_OFFSET,
        )
    return size


def _reserved(name: str, value: int | bytes, strict: bool, findings: list[Finding]) -> None:
    if (value if isinstance(value, int) else any(value)) == 0:
        return
    msg = f"EPL: reserved field {name} is {value!r}, expected 0"
    if strict:
        raise InvalidFieldError(msg, field=name)
    findings.append(info("epl.reserved", msg))
