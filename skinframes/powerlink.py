"""Ethernet POWERLINK v2 frames (EtherType 0x88AB): SoC, PReq, PRes, SoA, ASnd, AInv, AMNI.

Layouts follow EPSG DS 301 V1.4.0 section 4.6.1 (frame structures) as Wireshark's ``packet-epl.c``
and openPOWERLINK's ``frame.h`` implement them; byte offsets below count from the first byte after
the EtherType. All integers are little-endian.

Decoding has two modes. ``strict=True`` raises on anything the spec does not allow (unknown
message types and services, reserved bytes set, sizes past the frame). ``strict=False`` (capture
mode) decodes what it can, keeps every byte, and reports deviations as findings.
"""

from __future__ import annotations

import ipaddress
import struct
from collections.abc import Callable
from dataclasses import dataclass, fields
from enum import IntEnum, IntFlag
from typing import Any, ClassVar, Final

import construct as cs
import numpy as np
import numpy.typing as npt

from skinframes import ethernet
from skinframes.errors import (
    FieldRangeError,
    FrameTooLargeError,
    InvalidFieldError,
    TruncatedError,
    decoding,
    encoding,
)
from skinframes.findings import Finding, error, info, warning

__all__ = [
    "BROADCAST_NODE_ID",
    "MAX_CN_NODE_ID",
    "MAX_PDO_PAYLOAD_BYTES",
    "MN_NODE_ID",
    "ASnd",
    "EplMessage",
    "ErrorEntry",
    "IdentResponse",
    "MessageType",
    "NmtCommand",
    "NmtCommandId",
    "NmtRequest",
    "NmtState",
    "PReq",
    "PRes",
    "RawMessage",
    "RawService",
    "RequestedService",
    "Sdo",
    "SdoCommand",
    "ServiceId",
    "SoA",
    "SoC",
    "StatusResponse",
    "SyncResponse",
    "decode",
    "destination_mac",
    "frame",
    "node_mac",
]

# --- node ids and MAC addresses (DS 301 4.2.5.1.1; openPOWERLINK oplkdefs.h) ------------------
MN_NODE_ID: Final = 240  # C_ADR_MN_DEF_NODE_ID
BROADCAST_NODE_ID: Final = 255  # C_ADR_BROADCAST
MIN_CN_NODE_ID: Final = 1
MAX_CN_NODE_ID: Final = 239
DIAGNOSTIC_NODE_ID: Final = 253
ROUTER_NODE_ID: Final = 254

MAC_SOC: Final = bytes.fromhex("01111e000001")  # C_DLL_MULTICAST_SOC
MAC_PRES: Final = bytes.fromhex("01111e000002")  # C_DLL_MULTICAST_PRES
MAC_SOA: Final = bytes.fromhex("01111e000003")  # C_DLL_MULTICAST_SOA
MAC_ASND: Final = bytes.fromhex("01111e000004")  # C_DLL_MULTICAST_ASND
MAC_AMNI: Final = bytes.fromhex("01111e000005")  # C_DLL_MULTICAST_AMNI

# --- sizes ---------------------------------------------------------------------------------------
HEADER_BYTES: Final = 3  # MessageType, Destination, Source
SOC_BYTES: Final = 22
PDO_HEADER_BYTES: Final = 10  # PReq/PRes: the paper's H_PReq = H_PRes = 10
SOA_BYTES: Final = 10
SYNC_REQUEST_BYTES: Final = 30  # SoA svid 6 extension: SyncControl + 5 x u32 + DestMAC
ASND_HEADER_BYTES: Final = 4  # common header + ServiceID
IDENT_RESPONSE_BYTES: Final = 162  # openPOWERLINK tIdentResponse incl. the 4-byte ASnd header
STATUS_RESPONSE_FIXED_BYTES: Final = 18
ERROR_ENTRY_BYTES: Final = 20
SDO_SEQUENCE_BYTES: Final = 4
SDO_COMMAND_HEADER_BYTES: Final = 8
SYNC_RESPONSE_BYTES: Final = 30
MAX_PDO_PAYLOAD_BYTES: Final = 1490  # C_DLL_ISOCHR_MAX_PAYL
EPL_VERSION_2_0: Final = 0x20
NO_ADDRESS: Final = ipaddress.IPv4Address(0)  # IdentResponse IP fields not set


class MessageType(IntEnum):
    """MessageType, byte 0 bits 0-6 (DS 301 Table 23); equals ``tshark -G values`` for epl.mtyp."""

    SOC = 0x01
    PREQ = 0x03
    PRES = 0x04
    SOA = 0x05
    ASND = 0x06
    AMNI = 0x07
    AINV = 0x0D


class NmtState(IntEnum):
    """NMTStatus values (DS 301 7.1.4; Wireshark ``epl_nmt_cs_vals``)."""

    GS_OFF = 0x00
    GS_INITIALISING = 0x19
    GS_RESET_APPLICATION = 0x29
    GS_RESET_COMMUNICATION = 0x39
    GS_RESET_CONFIGURATION = 0x79
    NOT_ACTIVE = 0x1C
    PRE_OPERATIONAL_1 = 0x1D
    PRE_OPERATIONAL_2 = 0x5D
    READY_TO_OPERATE = 0x6D
    OPERATIONAL = 0xFD
    STOPPED = 0x4D
    BASIC_ETHERNET = 0x1E


class RequestedService(IntEnum):
    """SoA RequestedServiceID (DS 301 Table 30); 160-254 are manufacturer-specific."""

    NO_SERVICE = 0
    IDENT_REQUEST = 1
    STATUS_REQUEST = 2
    NMT_REQUEST_INVITE = 3
    SYNC_REQUEST = 6
    UNSPECIFIED_INVITE = 255


class ServiceId(IntEnum):
    """ASnd ServiceID (DS 301 Table 34); 0xA0-0xFE are manufacturer-specific."""

    IDENT_RESPONSE = 1
    STATUS_RESPONSE = 2
    NMT_REQUEST = 3
    NMT_COMMAND = 4
    SDO = 5
    SYNC_RESPONSE = 6


class NmtCommandId(IntEnum):
    """NMTCommandId (DS 301 7.3.1.2; openPOWERLINK ``tNmtCommand``), a selection."""

    START_NODE = 0x21
    STOP_NODE = 0x22
    ENTER_PRE_OPERATIONAL_2 = 0x23
    ENABLE_READY_TO_OPERATE = 0x24
    RESET_NODE = 0x28
    RESET_COMMUNICATION = 0x29
    RESET_CONFIGURATION = 0x2A
    SW_RESET = 0x2B
    DNA = 0x2D
    NET_HOST_NAME_SET = 0x62
    FLUSH_ARP_ENTRY = 0x63
    PUBLISH_CONFIGURED_NODES = 0x80
    PUBLISH_TIME = 0xB0
    INVALID_SERVICE = 0xFF


class SocFlag(IntFlag):
    """SoC byte 4."""

    AN = 0x08  # asynchronous-send node-state global
    PS = 0x40  # prescaled slot
    MC = 0x80  # multiplexed cycle completed


class PReqFlag(IntFlag):
    """PReq byte 4 (flags1)."""

    RD = 0x01  # ready
    EA = 0x04  # exception acknowledge
    MS = 0x20  # multiplexed slot


class PResFlag(IntFlag):
    """PRes byte 4 (flags1)."""

    RD = 0x01
    EN = 0x10  # exception new
    MS = 0x20


class SoAFlag(IntFlag):
    """SoA byte 4 (flags1)."""

    ER = 0x02  # exception reset
    EA = 0x04
    AN = 0x08
    AN_LOCAL = 0x10


def _enum(enum: type[IntEnum], value: int) -> int:
    """``enum(value)`` when the value is known, else the plain int (capture mode keeps it)."""
    try:
        return enum(value)
    except ValueError:
        return value


# --- construct schemas: the schema of record ------------------------------------------------------
_header = (
    "message_type" / cs.Int8ul,  # bit 7 reserved (Wireshark masks it off)
    "dest" / cs.Int8ul,
    "src" / cs.Int8ul,
)

soc_schema = cs.Struct(
    *_header,
    "reserved_3" / cs.Int8ul,
    "flags" / cs.Int8ul,  # SocFlag
    "reserved_5" / cs.Int8ul,
    "net_time_s" / cs.Int32ul,  # NetTime: seconds
    "net_time_ns" / cs.Int32ul,  # NetTime: nanoseconds
    "relative_time_us" / cs.Int64ul,
)

_pdo = (
    "pdo_version" / cs.Int8ul,  # high nibble main, low nibble sub version
    "reserved_7" / cs.Int8ul,
    "size" / cs.Rebuild(cs.Int16ul, cs.len_(cs.this.payload)),
    "payload" / cs.Bytes(cs.this.size),
)

preq_schema = cs.Struct(
    *_header,
    "reserved_3" / cs.Int8ul,
    "flags1" / cs.Int8ul,  # PReqFlag
    "flags2" / cs.Int8ul,  # reserved in DS 301
    *_pdo,
)

pres_schema = cs.Struct(
    *_header,
    "nmt_status" / cs.Int8ul,
    "flags1" / cs.Int8ul,  # PResFlag
    "flags2" / cs.Int8ul,  # PR bits 3-5, RS bits 0-2
    *_pdo,
)

soa_schema = cs.Struct(
    *_header,
    "nmt_status" / cs.Int8ul,
    "flags1" / cs.Int8ul,  # SoAFlag
    "reserved_5" / cs.Int8ul,
    "requested_service" / cs.Int8ul,
    "requested_target" / cs.Int8ul,
    "epl_version" / cs.Int8ul,
    "flags3" / cs.Int8ul,  # redundancy: MR 0x01, CR 0x02, RR 0x04
    "sync_request" / cs.If(cs.this.requested_service == 6, cs.Bytes(SYNC_REQUEST_BYTES)),
)

ident_response_schema = cs.Struct(  # after the 4-byte ASnd header
    "flags1" / cs.Int8ul,  # EN 0x10, EC 0x08
    "flags2" / cs.Int8ul,  # PR, RS
    "nmt_status" / cs.Int8ul,
    "reserved_7" / cs.Int8ul,
    "epl_version" / cs.Int8ul,
    "reserved_9" / cs.Int8ul,
    "feature_flags" / cs.Int32ul,
    "mtu" / cs.Int16ul,
    "poll_in_size" / cs.Int16ul,
    "poll_out_size" / cs.Int16ul,
    "response_time" / cs.Int32ul,
    "reserved_24" / cs.Int16ul,
    "device_type" / cs.Int32ul,  # low 16 bits: profile (401 = generic I/O)
    "vendor_id" / cs.Int32ul,
    "product_code" / cs.Int32ul,
    "revision_number" / cs.Int32ul,
    "serial_number" / cs.Int32ul,
    "vendor_specific_ext1" / cs.Bytes(8),
    "verify_conf_date" / cs.Int32ul,
    "verify_conf_time" / cs.Int32ul,
    "app_sw_date" / cs.Int32ul,
    "app_sw_time" / cs.Int32ul,
    "ip_address" / cs.Int32ul,  # little-endian on the wire, as real devices send it
    "subnet_mask" / cs.Int32ul,
    "default_gateway" / cs.Int32ul,
    "host_name" / cs.Bytes(32),
    "vendor_specific_ext2" / cs.Bytes(48),
)

error_entry_schema = cs.Struct(
    "entry_type" / cs.Int16ul,
    "error_code" / cs.Int16ul,
    "time_s" / cs.Int32ul,
    "time_ns" / cs.Int32ul,
    "additional_info" / cs.Bytes(8),
)

status_response_schema = cs.Struct(
    "flags1" / cs.Int8ul,
    "flags2" / cs.Int8ul,
    "nmt_status" / cs.Int8ul,
    "reserved_7" / cs.Bytes(3),
    "static_error_bit_field" / cs.Bytes(8),  # byte 10 = ErrorRegister
    "error_entries" / cs.GreedyRange(error_entry_schema),
)

sdo_sequence_schema = cs.Struct(
    "receive" / cs.BitStruct("sequence" / cs.BitsInteger(6), "con" / cs.BitsInteger(2)),
    "send" / cs.BitStruct("sequence" / cs.BitsInteger(6), "con" / cs.BitsInteger(2)),
    "reserved_6" / cs.Int16ul,
)

sdo_command_schema = cs.Struct(
    "reserved_8" / cs.Int8ul,
    "transaction_id" / cs.Int8ul,
    "flags"
    / cs.BitStruct(
        "response" / cs.Flag,
        "abort" / cs.Flag,
        "segmentation" / cs.BitsInteger(2),  # 0 expedited, 1 initiate, 2 segment, 3 complete
        "reserved" / cs.BitsInteger(4),
    ),
    "command_id" / cs.Int8ul,
    "segment_size" / cs.Rebuild(cs.Int16ul, cs.len_(cs.this.data)),
    "reserved_14" / cs.Int16ul,
    "data" / cs.Bytes(cs.this.segment_size),
)

sync_response_schema = cs.Struct(
    "reserved_4" / cs.Int16ul,
    "sync_status" / cs.Int32ul,
    "latency" / cs.Int32ul,
    "sync_node_number" / cs.Int32ul,
    "sync_delay" / cs.Int32ul,
    "pres_time_first" / cs.Int32ul,
    "pres_time_second" / cs.Int32ul,
)


def _check_node(name: str, value: int) -> None:
    if not 0 <= value <= 0xFF:
        raise FieldRangeError(f"EPL: node id {name}={value} does not fit 8 bits", field=name)


def _kwargs(cls: type[Any], container: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """Dataclass keyword arguments from a parsed construct container (same names)."""
    names = {f.name for f in fields(cls) if f.init}
    return {k: v for k, v in container.items() if k in names and k not in skip}


def _as_dict(obj: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    return {f.name: getattr(obj, f.name) for f in fields(obj) if f.name not in skip}


# --- messages ------------------------------------------------------------------------------------
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
        with encoding("EPL SoC"):
            return bytes(soc_schema.build(dict(_as_dict(self), message_type=self.MESSAGE_TYPE)))


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
        _check_pdo(self.payload)
        with encoding("EPL PReq"):
            return bytes(preq_schema.build(dict(_as_dict(self), message_type=self.MESSAGE_TYPE)))


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
        _check_pdo(self.payload)
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
        with encoding("EPL SoA"):
            return bytes(soa_schema.build(dict(_as_dict(self), message_type=self.MESSAGE_TYPE)))


# --- ASnd services ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class IdentResponse:
    """IdentResponse (DS 301 7.3.3.2.1): a node's identity, 162 EPL bytes."""

    SERVICE_ID: ClassVar[int] = ServiceId.IDENT_RESPONSE
    nmt_status: int = NmtState.OPERATIONAL
    flags1: int = 0
    flags2: int = 0
    epl_version: int = EPL_VERSION_2_0
    feature_flags: int = 0x45  # isochronous, SDO by ASnd, dynamic PDO mapping
    mtu: int = 300
    poll_in_size: int = 0
    poll_out_size: int = 0
    response_time: int = 0
    device_type: int = 0x0191  # profile 401, generic I/O module
    vendor_id: int = 0
    product_code: int = 0
    revision_number: int = 0
    serial_number: int = 0
    vendor_specific_ext1: bytes = bytes(8)
    verify_conf_date: int = 0
    verify_conf_time: int = 0
    app_sw_date: int = 0
    app_sw_time: int = 0
    ip_address: ipaddress.IPv4Address = NO_ADDRESS
    subnet_mask: ipaddress.IPv4Address = NO_ADDRESS
    default_gateway: ipaddress.IPv4Address = NO_ADDRESS
    host_name: bytes = bytes(32)
    vendor_specific_ext2: bytes = bytes(48)
    reserved_7: int = 0
    reserved_9: int = 0
    reserved_24: int = 0

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header (158)."""
        d = _as_dict(self)
        for k in ("ip_address", "subnet_mask", "default_gateway"):
            d[k] = int(d[k])
        with encoding("EPL IdentResponse"):
            return bytes(ident_response_schema.build(d))

    @classmethod
    def _decode(cls, body: bytes) -> tuple[IdentResponse, int]:
        c = ident_response_schema.parse(body)
        kw = _kwargs(cls, c)
        for k in ("ip_address", "subnet_mask", "default_gateway"):
            kw[k] = ipaddress.IPv4Address(kw[k])
        kw["nmt_status"] = _enum(NmtState, kw["nmt_status"])
        return cls(**kw), IDENT_RESPONSE_BYTES - ASND_HEADER_BYTES


@dataclass(frozen=True, slots=True)
class ErrorEntry:
    """One ErrorCodeList entry of a StatusResponse (DS 301 6.5.8.2), 20 bytes."""

    entry_type: int
    error_code: int
    time_s: int = 0
    time_ns: int = 0
    additional_info: bytes = bytes(8)


@dataclass(frozen=True, slots=True)
class StatusResponse:
    """StatusResponse (DS 301 7.3.3.3.1): NMT state, static error bits and error entries.

    The entry list has no length field; a decoder reads 20-byte entries until the frame ends or an
    all-zero entry starts (the rest is padding). Wireshark instead counts every 20 bytes, padding
    included, so a 60-byte frame shows one phantom all-zero entry there.
    """

    SERVICE_ID: ClassVar[int] = ServiceId.STATUS_RESPONSE
    nmt_status: int = NmtState.OPERATIONAL
    flags1: int = 0
    flags2: int = 0
    static_error_bit_field: bytes = bytes(8)
    error_entries: tuple[ErrorEntry, ...] = ()
    reserved_7: bytes = bytes(3)

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header."""
        d = _as_dict(self)
        d["error_entries"] = [_as_dict(e) for e in self.error_entries]
        with encoding("EPL StatusResponse"):
            return bytes(status_response_schema.build(d))

    @classmethod
    def _decode(cls, body: bytes) -> tuple[StatusResponse, int]:
        fixed = STATUS_RESPONSE_FIXED_BYTES - ASND_HEADER_BYTES
        c = status_response_schema.parse(body[:fixed])
        entries = []
        pos = fixed
        while len(body) - pos >= ERROR_ENTRY_BYTES and any(body[pos : pos + ERROR_ENTRY_BYTES]):
            e = error_entry_schema.parse(body[pos : pos + ERROR_ENTRY_BYTES])
            entries.append(ErrorEntry(**_kwargs(ErrorEntry, e)))
            pos += ERROR_ENTRY_BYTES
        kw = _kwargs(cls, c, skip=("error_entries",))
        kw["nmt_status"] = _enum(NmtState, kw["nmt_status"])
        return cls(**kw, error_entries=tuple(entries)), pos


@dataclass(frozen=True, slots=True)
class NmtRequest:
    """NMTRequest (DS 301 7.3.6.1): a CN asks the MN to issue an NMT command."""

    SERVICE_ID: ClassVar[int] = ServiceId.NMT_REQUEST
    requested_command_id: int
    requested_command_target: int
    data: bytes = b""

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header."""
        with encoding("EPL NMTRequest"):
            return (
                struct.pack("<BB", self.requested_command_id, self.requested_command_target)
                + self.data
            )

    @classmethod
    def _decode(cls, body: bytes) -> tuple[NmtRequest, int]:
        if len(body) < 2:
            raise TruncatedError(f"EPL NMTRequest: {len(body)} service bytes, needs 2")
        return cls(body[0], body[1], bytes(body[2:])), len(body)


@dataclass(frozen=True, slots=True)
class NmtCommand:
    """NMTCommand (DS 301 7.3.1): the MN commands a node's NMT state machine."""

    SERVICE_ID: ClassVar[int] = ServiceId.NMT_COMMAND
    command_id: int
    data: bytes = b""
    reserved_5: int = 0

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header."""
        with encoding("EPL NMTCommand"):
            return struct.pack("<BB", self.command_id, self.reserved_5) + self.data

    @classmethod
    def _decode(cls, body: bytes) -> tuple[NmtCommand, int]:
        if len(body) < 2:
            raise TruncatedError(f"EPL NMTCommand: {len(body)} service bytes, needs 2")
        return cls(_enum(NmtCommandId, body[0]), bytes(body[2:]), body[1]), len(body)


@dataclass(frozen=True, slots=True)
class SdoCommand:
    """SDO command layer (DS 301 6.3.2.4.1), 8 header bytes + segment data."""

    transaction_id: int
    command_id: int  # 1 WriteByIndex, 2 ReadByIndex, 0x31/0x32 Write/ReadMultipleParam, ...
    data: bytes = b""
    response: bool = False
    abort: bool = False
    segmentation: int = 0  # 0 expedited, 1 initiate, 2 segment, 3 complete
    flags_reserved: int = 0
    reserved_8: int = 0
    reserved_14: int = 0

    def _build_dict(self) -> dict[str, Any]:
        return {
            "reserved_8": self.reserved_8,
            "transaction_id": self.transaction_id,
            "flags": {
                "response": self.response,
                "abort": self.abort,
                "segmentation": self.segmentation,
                "reserved": self.flags_reserved,
            },
            "command_id": self.command_id,
            "reserved_14": self.reserved_14,
            "data": self.data,
        }


@dataclass(frozen=True, slots=True)
class Sdo:
    """SDO over ASnd (DS 301 6.3.2): sequence layer plus an optional command layer.

    As in Wireshark, the command layer is present when its CommandID is non-zero or Abort is set;
    otherwise the bytes after the sequence layer are padding.
    """

    SERVICE_ID: ClassVar[int] = ServiceId.SDO
    receive_sequence: int = 0
    receive_con: int = 0  # 0 no connection, 1 init, 2 valid, 3 error
    send_sequence: int = 0
    send_con: int = 0  # 0 no connection, 1 init, 2 valid, 3 valid + ack request
    command: SdoCommand | None = None
    reserved_6: int = 0

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header."""
        with encoding("EPL SDO"):
            seq = sdo_sequence_schema.build(
                {
                    "receive": {"sequence": self.receive_sequence, "con": self.receive_con},
                    "send": {"sequence": self.send_sequence, "con": self.send_con},
                    "reserved_6": self.reserved_6,
                }
            )
            if self.command is None:
                return bytes(seq)
            return bytes(seq) + bytes(sdo_command_schema.build(self.command._build_dict()))

    @classmethod
    def _decode(cls, body: bytes, findings: list[Finding]) -> tuple[Sdo, int]:
        s = sdo_sequence_schema.parse(body[:SDO_SEQUENCE_BYTES])
        pos = SDO_SEQUENCE_BYTES
        command = None
        rest = body[pos:]
        if len(rest) >= SDO_COMMAND_HEADER_BYTES and (rest[3] != 0 or rest[2] & 0x40):
            seg = int.from_bytes(rest[4:6], "little")
            avail = len(rest) - SDO_COMMAND_HEADER_BYTES
            if seg > avail:
                raise TruncatedError(
                    f"EPL SDO: segment size {seg}, only {avail} bytes follow", field="segment_size"
                )
            c = sdo_command_schema.parse(rest)
            command = SdoCommand(
                c.transaction_id,
                c.command_id,
                bytes(c.data),
                c.flags.response,
                c.flags.abort,
                c.flags.segmentation,
                c.flags.reserved,
                c.reserved_8,
                c.reserved_14,
            )
            pos += SDO_COMMAND_HEADER_BYTES + seg
            findings += _multi_param_findings(command, trailing=len(body) - pos)
        sdo = cls(
            s.receive.sequence, s.receive.con, s.send.sequence, s.send.con, command, s.reserved_6
        )
        return sdo, pos


SDO_WRITE_MULTIPLE_PARAM: Final = 0x31
SDO_READ_MULTIPLE_PARAM: Final = 0x32
# Expedited multi-parameter layouts (DS 301 6.3.2.4.2.2): a read request lists 4-byte entries
# (index u16, sub-index u8, reserved u8); a write response lists 8-byte entries (index u16,
# sub-index u8, flags u8 with bit 7 = abort, abort code u32).
_MULTI_ENTRY_BYTES: Final = {
    (SDO_READ_MULTIPLE_PARAM, False): 4,
    (SDO_WRITE_MULTIPLE_PARAM, True): 8,
}


def _multi_param_findings(c: SdoCommand, trailing: int) -> list[Finding]:
    """What to say about a Write/ReadMultipleParam segment (Wireshark 4.0 misreads padded ones)."""
    if c.command_id not in (SDO_WRITE_MULTIPLE_PARAM, SDO_READ_MULTIPLE_PARAM) or c.abort:
        return []
    out: list[Finding] = []
    entry = _MULTI_ENTRY_BYTES.get((c.command_id, c.response))
    if c.segmentation == 0 and entry and len(c.data) % entry:
        out.append(
            warning(
                "epl.sdo.multi_param.length",
                f"EPL SDO: {len(c.data)}-byte multi-parameter segment is not a whole number of "
                f"{entry}-byte entries",
            )
        )
    if trailing > 0:
        out.append(
            info(
                "epl.sdo.multi_param.padding",
                f"EPL SDO: {trailing} bytes (padding, FCS) follow the {len(c.data)}-byte "
                "multi-parameter segment; Wireshark 4.0 reads such segments on into them and can "
                "report the frame as Malformed, although the segment is complete",
            )
        )
    return out


@dataclass(frozen=True, slots=True)
class SyncResponse:
    """SyncResponse (DS 302-B): answer to a SoA SyncRequest."""

    SERVICE_ID: ClassVar[int] = ServiceId.SYNC_RESPONSE
    sync_status: int = 0
    latency: int = 0
    sync_node_number: int = 0
    sync_delay: int = 0
    pres_time_first: int = 0
    pres_time_second: int = 0
    reserved_4: int = 0

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header (26)."""
        with encoding("EPL SyncResponse"):
            return bytes(sync_response_schema.build(_as_dict(self)))

    @classmethod
    def _decode(cls, body: bytes) -> tuple[SyncResponse, int]:
        c = sync_response_schema.parse(body)
        return cls(**_kwargs(cls, c)), SYNC_RESPONSE_BYTES - ASND_HEADER_BYTES


@dataclass(frozen=True, slots=True)
class RawService:
    """An ASnd service skinframes does not model (manufacturer-specific 0xA0-0xFE, unknown)."""

    service_id: int
    data: bytes = b""

    @property
    def SERVICE_ID(self) -> int:  # noqa: N802 - mirrors the ClassVar of the modelled services
        """The ServiceID byte."""
        return self.service_id

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header."""
        return bytes(self.data)


Service = IdentResponse | StatusResponse | NmtRequest | NmtCommand | Sdo | SyncResponse | RawService


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
        _check_node("dest", self.dest)
        _check_node("src", self.src)
        if not 0 <= self.service_id <= 0xFF:
            raise FieldRangeError(f"EPL ASnd: service id {self.service_id} does not fit 8 bits")
        head = bytes((self.MESSAGE_TYPE, self.dest, self.src, self.service_id))
        return head + self.service.to_bytes()


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


EplMessage = SoC | PReq | PRes | SoA | ASnd | RawMessage


def _check_pdo(payload: bytes) -> None:
    if len(payload) > MAX_PDO_PAYLOAD_BYTES:
        raise FrameTooLargeError(
            f"EPL: PDO payload of {len(payload)} bytes exceeds {MAX_PDO_PAYLOAD_BYTES}",
            field="payload",
        )


# --- decoding ------------------------------------------------------------------------------------
def _reserved(name: str, value: int | bytes, strict: bool, findings: list[Finding]) -> None:
    if (value if isinstance(value, int) else any(value)) == 0:
        return
    msg = f"EPL: reserved field {name} is {value!r}, expected 0"
    if strict:
        raise InvalidFieldError(msg, field=name)
    findings.append(info("epl.reserved", msg))


def _pdo_size(kind: str, buf: bytes) -> int:
    """The Size field of a PReq/PRes, checked against the bytes present."""
    if len(buf) < PDO_HEADER_BYTES:
        raise TruncatedError(f"EPL {kind}: {len(buf)} bytes, header needs {PDO_HEADER_BYTES}")
    size = int.from_bytes(buf[8:10], "little")
    if size > len(buf) - PDO_HEADER_BYTES:
        raise TruncatedError(
            f"EPL {kind}: Size field says {size} payload bytes, only "
            f"{len(buf) - PDO_HEADER_BYTES} present",
            field="size",
            offset=8,
        )
    return size


def _pdo_kwargs(
    kind: str, schema: cs.Struct, cls: type[PReq] | type[PRes], buf: bytes
) -> tuple[dict[str, Any], int]:
    """PReq/PRes fields from the schema, and the bytes the message occupies (10 + Size)."""
    size = _pdo_size(kind, buf)
    return _kwargs(cls, schema.parse(buf)), PDO_HEADER_BYTES + size


def _decode_pres(buf: bytes) -> tuple[PRes, int]:
    """A PRes by one ``struct`` call (fast path): the fields ``pres_schema.parse`` gives.

    A CN sends a PRes every cycle; with ``pres_schema.parse`` decoding one took about as long as
    scapy's dissection (benchmarks/bench_codecs.py), with ``struct`` it is several times faster.
    """
    size = _pdo_size("PRes", buf)
    _, dest, src, nmt, flags1, flags2, version, reserved_7, _ = _PRES_HEAD.unpack_from(buf)
    end = PDO_HEADER_BYTES + size
    nmt_status = _enum(NmtState, nmt)
    message = PRes(
        src, buf[PDO_HEADER_BYTES:end], dest, nmt_status, flags1, flags2, version, reserved_7
    )
    return message, end


def _decode_service(
    service_id: int, body: bytes, total: int, strict: bool, findings: list[Finding]
) -> tuple[Service, int]:
    """Decode the service bytes after the ASnd header; returns the service and bytes consumed."""
    if service_id == ServiceId.IDENT_RESPONSE:
        return IdentResponse._decode(body)
    if service_id == ServiceId.STATUS_RESPONSE:
        return StatusResponse._decode(body)
    if service_id == ServiceId.SDO:
        return Sdo._decode(body, findings)
    if service_id == ServiceId.SYNC_RESPONSE:
        return SyncResponse._decode(body)
    decoder: Callable[[bytes], tuple[Service, int]]
    fixed = 2  # NMTRequest / NMTCommand: two command bytes before the data; RawService: none
    if service_id == ServiceId.NMT_REQUEST:
        decoder = NmtRequest._decode
    elif service_id == ServiceId.NMT_COMMAND:
        decoder = NmtCommand._decode
    else:
        fixed = 0
        msg = f"EPL ASnd: service id {service_id:#04x} is not modelled; kept as bytes"
        if strict and not 0xA0 <= service_id <= 0xFE:
            raise InvalidFieldError(msg, field="service_id")
        findings.append(info("epl.asnd.raw_service", msg))

        def decoder(b: bytes) -> tuple[Service, int]:
            return RawService(service_id, bytes(b)), len(b)

    # These services have no length field: in a frame of exactly the minimum size, trailing zeros
    # are taken as Ethernet padding (re-encoding pads with the same zeros).
    end = len(body)
    if total == ethernet.MIN_PAYLOAD_BYTES:
        while end > fixed and body[end - 1] == 0:
            end -= 1
    service, _ = decoder(body[:end])
    return service, end


def decode(payload: bytes, *, strict: bool = True) -> tuple[EplMessage, int, list[Finding]]:
    """Decode the EPL part of a frame (the bytes after the EtherType).

    Args:
        payload: EPL message plus any Ethernet padding.
        strict: raise on reserved fields, unknown types and services (see the module docstring).

    Returns:
        The message, how many bytes it occupies (the rest is padding), and findings.

    Raises:
        DecodeError: the message is truncated or (strict) deviates from the spec.
    """
    findings: list[Finding] = []
    buf = bytes(payload)
    if len(buf) < HEADER_BYTES:
        raise TruncatedError(f"EPL: {len(buf)} bytes, the common header needs {HEADER_BYTES}")
    raw_type = buf[0]
    mtype = raw_type & 0x7F  # bit 7 reserved; Wireshark masks it off
    with decoding("EPL"):
        if raw_type & 0x80 or mtype not in (1, 3, 4, 5, 6):
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
            return RawMessage(raw_type, buf[1], buf[2], buf[3:]), len(buf), findings
        message: EplMessage
        if mtype == MessageType.SOC:
            if len(buf) < SOC_BYTES:
                raise TruncatedError(f"EPL SoC: {len(buf)} bytes, needs {SOC_BYTES}")
            c = soc_schema.parse(buf)
            message, used = SoC(**_kwargs(SoC, c)), SOC_BYTES
            _reserved("reserved_3", message.reserved_3, strict, findings)
            _reserved("reserved_5", message.reserved_5, strict, findings)
        elif mtype == MessageType.PREQ:
            kw, used = _pdo_kwargs("PReq", preq_schema, PReq, buf)
            message = PReq(**kw)
            _reserved("reserved_3", kw["reserved_3"], strict, findings)
            _reserved("reserved_7", kw["reserved_7"], strict, findings)
        elif mtype == MessageType.PRES:
            message, used = _decode_pres(buf)
            _reserved("reserved_7", message.reserved_7, strict, findings)
        elif mtype == MessageType.SOA:
            if len(buf) < SOA_BYTES:
                raise TruncatedError(f"EPL SoA: {len(buf)} bytes, needs {SOA_BYTES}")
            c = soa_schema.parse(buf)
            kw = _kwargs(SoA, c)
            kw["requested_service"] = _enum(RequestedService, kw["requested_service"])
            kw["nmt_status"] = _enum(NmtState, kw["nmt_status"])
            if kw["sync_request"] is not None:
                kw["sync_request"] = bytes(kw["sync_request"])
            message = SoA(**kw)
            used = SOA_BYTES + (SYNC_REQUEST_BYTES if message.sync_request is not None else 0)
            _reserved("reserved_5", message.reserved_5, strict, findings)
        else:  # ASnd
            if len(buf) < ASND_HEADER_BYTES:
                raise TruncatedError(f"EPL ASnd: {len(buf)} bytes, needs {ASND_HEADER_BYTES}")
            service, used = _decode_service(
                buf[3], buf[ASND_HEADER_BYTES:], len(buf), strict, findings
            )
            message = ASnd(service, buf[1], buf[2])
            used += ASND_HEADER_BYTES
    return message, used, findings


# --- frames: the right MAC addresses for each message ------------------------------------------
def node_mac(node_id: int) -> bytes:
    """The locally administered unicast MAC skinframes gives node ``node_id``: 02:00:00:00:0a:NN."""
    _check_node("node_id", node_id)
    return bytes((0x02, 0, 0, 0, 0x0A, node_id))


def destination_mac(message: EplMessage) -> bytes:
    """The destination MAC openPOWERLINK uses for a message (multicast, or the CN's for PReq)."""
    if isinstance(message, SoC):
        return MAC_SOC
    if isinstance(message, PReq):
        return node_mac(message.dest)
    if isinstance(message, PRes):
        return MAC_PRES
    if isinstance(message, SoA):
        return MAC_SOA
    if isinstance(message, RawMessage) and message.message_type == MessageType.AMNI:
        return MAC_AMNI
    if isinstance(message, RawMessage) and message.message_type == MessageType.AINV:
        return MAC_SOA
    return MAC_ASND


def frame(message: EplMessage) -> ethernet.EthernetFrame:
    """Wrap a message in an Ethernet frame from its source node's MAC to its destination MAC."""
    return ethernet.EthernetFrame(destination_mac(message), node_mac(message.src), message)


# --- fast path: PRes with struct and numpy, byte-identical to pres_schema -----------------------
_PRES_HEAD = struct.Struct("<BBBBBBBBH")


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
        head = _PRES_HEAD.pack(
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


def pack_pres_frames(
    payloads: npt.NDArray[np.uint8],
    src_nodes: npt.ArrayLike,
    nmt_status: int = NmtState.OPERATIONAL,
    flags1: int = PResFlag.RD,
) -> npt.NDArray[np.uint8]:
    """Build n complete PRes Ethernet frames at once (batch fast path).

    Args:
        payloads: uint8 array of shape (n, B), B <= 1490: the PDO of each frame.
        src_nodes: n source node ids (1..239).
        nmt_status: NMTStatus byte of every frame.
        flags1: flags byte of every frame.

    Returns:
        uint8 array of shape (n, max(14 + 10 + B, 60)): each row a frame as ``frame(PRes(...))``
        encodes it (destination 01:11:1e:00:00:02, source ``node_mac(src)``, zero padding).
    """
    payloads = np.asarray(payloads)
    if payloads.dtype != np.uint8 or payloads.ndim != 2:
        raise TypeError("payloads must be a 2-D uint8 array")
    n, size = payloads.shape
    _check_pdo(bytes(size))
    src = np.asarray(src_nodes, dtype=np.int64).reshape(-1)
    if src.shape != (n,):
        raise FieldRangeError(f"EPL PRes batch: {src.shape[0]} source nodes for {n} payloads")
    if n and (src.min() < 0 or src.max() > 0xFF):
        raise FieldRangeError("EPL PRes batch: source node ids must fit 8 bits", field="src")
    head_len = ethernet.HEADER_BYTES + PDO_HEADER_BYTES
    length = max(head_len + size, ethernet.MIN_FRAME_BYTES)
    template = np.zeros(length, dtype=np.uint8)
    with encoding("EPL PRes batch"):  # nmt_status and flags1 must fit a byte
        head = _PRES_HEAD.pack(
            MessageType.PRES, BROADCAST_NODE_ID, 0, nmt_status, flags1, 0, 0, 0, size
        )
    template[:head_len] = np.frombuffer(
        MAC_PRES + node_mac(0) + struct.pack(">H", ethernet.ETHERTYPE_EPL) + head,
        dtype=np.uint8,
    )
    out = np.empty((n, length), dtype=np.uint8)
    out[:] = template
    out[:, 11] = src  # last octet of the source MAC
    out[:, 16] = src  # EPL source node id
    out[:, head_len : head_len + size] = payloads
    return out


def unpack_pres_frames(
    frames: npt.NDArray[np.uint8],
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]:
    """Decode n equal-length PRes frames at once (batch fast path).

    Args:
        frames: uint8 array of shape (n, L), each row a PRes Ethernet frame with the same Size.

    Returns:
        (source node ids, payloads of shape (n, Size)); both are views into ``frames``.

    Raises:
        InvalidFieldError: a row is not a PRes, or the rows disagree on Size.
    """
    frames = np.asarray(frames, dtype=np.uint8)
    if frames.ndim != 2 or frames.shape[1] < ethernet.HEADER_BYTES + PDO_HEADER_BYTES:
        raise TruncatedError("EPL PRes batch: rows shorter than the 24-byte PRes header")
    ethertype_ok = (frames[:, 12] == 0x88) & (frames[:, 13] == 0xAB)
    mtype_ok = (frames[:, 14] & 0x7F) == MessageType.PRES
    if not bool(np.all(ethertype_ok & mtype_ok)):
        raise InvalidFieldError(
            "EPL PRes batch: a row is not an EPL PRes frame", field="message_type"
        )
    sizes = frames[:, 22].astype(np.int64) | (frames[:, 23].astype(np.int64) << 8)
    size = int(sizes[0]) if len(sizes) else 0
    if not bool(np.all(sizes == size)):
        raise InvalidFieldError("EPL PRes batch: rows disagree on the Size field", field="size")
    if ethernet.HEADER_BYTES + PDO_HEADER_BYTES + size > frames.shape[1]:
        raise TruncatedError(f"EPL PRes batch: Size {size} runs past the frame", field="size")
    return frames[:, 16], frames[:, 24 : 24 + size]


# --- fast path: SoC with numpy, byte-identical to frame(SoC(...)) -------------------------------
def pack_soc_frames(
    net_time_s: npt.ArrayLike, net_time_ns: npt.ArrayLike, relative_time_us: npt.ArrayLike
) -> npt.NDArray[np.uint8]:
    """Build k complete SoC Ethernet frames at once (batch fast path, DS 301 4.6.1.1.1).

    Args:
        net_time_s: k NetTime seconds (u32); a scalar applies to every frame.
        net_time_ns: k NetTime nanoseconds (u32).
        relative_time_us: k RelativeTime values, microseconds (u64).

    Returns:
        uint8 array of shape (k, 60): each row a frame as ``frame(SoC(net_time_s=...,
        net_time_ns=..., relative_time_us=...)).to_bytes()`` encodes it (destination
        01:11:1e:00:00:01, source ``node_mac(240)``, dest 255, src 240, flags 0, zero padding).

    Raises:
        FieldRangeError: a value does not fit its field, or the lengths disagree.
    """
    fields = [
        _unsigned("net_time_s", net_time_s, 32),
        _unsigned("net_time_ns", net_time_ns, 32),
        _unsigned("relative_time_us", relative_time_us, 64),
    ]
    try:
        seconds, nanoseconds, relative = np.broadcast_arrays(*fields)
    except ValueError as exc:
        sizes = ", ".join(str(f.size) for f in fields)
        raise FieldRangeError(f"EPL SoC batch: {sizes} values do not line up") from exc
    head = ethernet.HEADER_BYTES
    length = max(head + SOC_BYTES, ethernet.MIN_FRAME_BYTES)
    template = np.zeros(length, dtype=np.uint8)
    template[: head + 6] = np.frombuffer(
        MAC_SOC
        + node_mac(MN_NODE_ID)
        + struct.pack(">H", ethernet.ETHERTYPE_EPL)
        + struct.pack("<BBBBBB", MessageType.SOC, BROADCAST_NODE_ID, MN_NODE_ID, 0, 0, 0),
        dtype=np.uint8,
    )
    k = seconds.shape[0]
    out = np.empty((k, length), dtype=np.uint8)
    out[:] = template
    # NetTime seconds, NetTime nanoseconds, RelativeTime: EPL bytes 6-9, 10-13, 14-21
    out[:, head + 6 : head + 10] = seconds.astype("<u4").view(np.uint8).reshape(k, 4)
    out[:, head + 10 : head + 14] = nanoseconds.astype("<u4").view(np.uint8).reshape(k, 4)
    out[:, head + 14 : head + 22] = relative.astype("<u8").view(np.uint8).reshape(k, 8)
    return out


def _unsigned(name: str, values: npt.ArrayLike, bits: int) -> npt.NDArray[np.uint64]:
    """``values`` as a 1-D uint64 array, each checked to fit ``bits`` (numpy would wrap)."""
    # Python ints stay Python ints: np.asarray([0, 2**63]) would round them through float64
    numeric = isinstance(values, np.ndarray | np.generic)
    arr = np.atleast_1d(values if numeric else np.asarray(values, dtype=object))
    if arr.ndim != 1:
        raise FieldRangeError(f"EPL SoC batch: {name} must be 1-D, not {arr.shape}", field=name)
    if arr.size == 0:
        return np.zeros(0, dtype=np.uint64)
    if arr.dtype == object:
        items = arr.tolist()
        if not all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in items):
            raise TypeError(f"{name} must be integers")
        low, high = int(min(items)), int(max(items))
    elif arr.dtype.kind in "iu":
        low, high = int(arr.min()), int(arr.max())
    else:
        raise TypeError(f"{name} must be integers, not {arr.dtype}")
    if low < 0 or high >= 1 << bits:
        raise FieldRangeError(
            f"EPL SoC batch: {name} values must be 0..2**{bits}-1, found {low}..{high}",
            field=name,
        )
    if arr.dtype == object:
        return np.array([int(v) for v in arr.tolist()], dtype=np.uint64)
    return arr.astype(np.uint64)
