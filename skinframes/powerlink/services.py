"""The ASnd services (DS 301 7.3, 6.3.2; DS 302-B): the bytes after the 4-byte ASnd header.

Each service class writes its bytes in ``to_bytes`` and reads them in ``_decode``, both with its
schema of record (:mod:`.schemas`); NMTRequest and NMTCommand (two command bytes, then data) by
hand, RawService as plain bytes. :func:`decode_service` picks the class for a ServiceID.
"""

from __future__ import annotations

import ipaddress
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, Final

from skinframes import ethernet
from skinframes.errors import InvalidFieldError, TruncatedError, encoding
from skinframes.findings import Finding, info, warning
from skinframes.powerlink.enums import EPL_VERSION_2_0, NmtCommandId, NmtState, ServiceId, known
from skinframes.powerlink.schemas import (
    ASND_HEADER_BYTES,
    ERROR_ENTRY_BYTES,
    IDENT_RESPONSE_BYTES,
    SDO_COMMAND_HEADER_BYTES,
    SDO_SEQUENCE_BYTES,
    STATUS_RESPONSE_FIXED_BYTES,
    SYNC_RESPONSE_BYTES,
    build,
    error_entry_schema,
    field_values,
    ident_response_schema,
    init_kwargs,
    sdo_command_schema,
    sdo_sequence_schema,
    status_response_schema,
    sync_response_schema,
)

NO_ADDRESS: Final = ipaddress.IPv4Address(0)  # IdentResponse IP fields not set
# openPOWERLINK C_DLL_MINSIZE_STATUSRES (oplk/dll.h): the MN drops a shorter StatusResponse and
# marks the CN NotActive. 72 frame bytes = 14 Ethernet + 4 ASnd + 54 service bytes: the 14 fixed
# ones and a 40-byte error entry list that an all-zero entry ends (empty).
STATUS_RESPONSE_MIN_FRAME_BYTES: Final = 72
STATUS_RESPONSE_MIN_SERVICE_BYTES: Final = (
    STATUS_RESPONSE_MIN_FRAME_BYTES - ethernet.HEADER_BYTES - ASND_HEADER_BYTES
)


class _WiresharkFlags:
    """Wireshark's names for the flag bits of IdentResponse and StatusResponse
    (``epl.asnd.ires.*``, ``epl.asnd.sres.*``): flags1 EN 0x10, EC 0x08; flags2 FLS 0x80,
    SLS 0x40, PR 0x38, RS 0x07. Aliases: ``flags1`` and ``flags2`` stay the fields."""

    __slots__ = ()
    flags1: int
    flags2: int

    @property
    def en(self) -> bool:
        """Exception New (flags1 bit 4), Wireshark ``epl.asnd.sres.en`` / ``ires.en``."""
        return bool(self.flags1 & 0x10)

    @property
    def ec(self) -> bool:
        """Exception Clear (flags1 bit 3), Wireshark ``epl.asnd.sres.ec`` / ``ires.ec``."""
        return bool(self.flags1 & 0x08)

    @property
    def fls(self) -> bool:
        """First Link Status (flags2 bit 7), Wireshark ``epl.asnd.sres.fls`` / ``ires.fls``."""
        return bool(self.flags2 & 0x80)

    @property
    def sls(self) -> bool:
        """Second Link Status (flags2 bit 6), Wireshark ``epl.asnd.sres.sls`` / ``ires.sls``."""
        return bool(self.flags2 & 0x40)

    @property
    def pr(self) -> int:
        """Priority (flags2 bits 3-5), Wireshark ``epl.asnd.sres.pr`` / ``ires.pr``."""
        return (self.flags2 >> 3) & 0x7

    @property
    def rs(self) -> int:
        """RequestToSend (flags2 bits 0-2), Wireshark ``epl.asnd.sres.rs`` / ``ires.rs``."""
        return self.flags2 & 0x7


@dataclass(frozen=True, slots=True)
class IdentResponse(_WiresharkFlags):
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
        d = field_values(self)
        for k in ("ip_address", "subnet_mask", "default_gateway"):
            d[k] = int(d[k])
        return build("EPL IdentResponse", ident_response_schema, d)

    @classmethod
    def _decode(cls, body: bytes) -> tuple[IdentResponse, int]:
        c = ident_response_schema.parse(body)
        kw = init_kwargs(cls, c)
        for k in ("ip_address", "subnet_mask", "default_gateway"):
            kw[k] = ipaddress.IPv4Address(kw[k])
        kw["nmt_status"] = known(NmtState, kw["nmt_status"])
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
class StatusResponse(_WiresharkFlags):
    """StatusResponse (DS 301 7.3.3.3.1): NMT state, static error bits and error entries.

    The entry list has no length field; a decoder reads 20-byte entries until the frame ends or an
    all-zero entry starts (the rest is padding). Wireshark instead counts every 20 bytes, padding
    included, so a 60-byte frame shows one phantom all-zero entry there.

    Built 72 frame bytes long by default (:data:`STATUS_RESPONSE_MIN_FRAME_BYTES`, what an
    openPOWERLINK MN accepts): the entry list is padded with zeros to 54 service bytes. ``short``
    builds only the entries (18 EPL bytes without entries, a 60-byte frame after Ethernet
    padding), as a decoder reports a captured frame shorter than 72 bytes (``epl.sres.short``).
    """

    SERVICE_ID: ClassVar[int] = ServiceId.STATUS_RESPONSE
    nmt_status: int = NmtState.OPERATIONAL
    flags1: int = 0
    flags2: int = 0
    static_error_bit_field: bytes = bytes(8)
    error_entries: tuple[ErrorEntry, ...] = ()
    reserved_7: bytes = bytes(3)
    short: bool = False

    def to_bytes(self) -> bytes:
        """The service bytes after the 4-byte ASnd header: at least 54 unless ``short``."""
        d = field_values(self)
        del d["short"]
        d["error_entries"] = [field_values(e) for e in self.error_entries]
        body = build("EPL StatusResponse", status_response_schema, d)
        if self.short:
            return body
        return body.ljust(STATUS_RESPONSE_MIN_SERVICE_BYTES, b"\x00")

    @classmethod
    def _decode(cls, body: bytes) -> tuple[StatusResponse, int]:
        fixed = STATUS_RESPONSE_FIXED_BYTES - ASND_HEADER_BYTES
        c = status_response_schema.parse(body[:fixed])
        entries = []
        pos = fixed
        while len(body) - pos >= ERROR_ENTRY_BYTES and any(body[pos : pos + ERROR_ENTRY_BYTES]):
            e = error_entry_schema.parse(body[pos : pos + ERROR_ENTRY_BYTES])
            entries.append(ErrorEntry(**init_kwargs(ErrorEntry, e)))
            pos += ERROR_ENTRY_BYTES
        kw = init_kwargs(cls, c, skip=("error_entries",))
        kw["nmt_status"] = known(NmtState, kw["nmt_status"])
        # the zeros up to 54 bytes end the (empty) entry list of a full-size StatusResponse
        end = STATUS_RESPONSE_MIN_SERVICE_BYTES
        short = not (len(body) >= end and not any(body[pos:end]))
        kw["short"] = short
        return cls(**kw, error_entries=tuple(entries)), pos if short else max(pos, end)


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
        return cls(known(NmtCommandId, body[0]), bytes(body[2:]), body[1]), len(body)


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


# A multi-parameter entry with data (DS 301 6.3.2.4.2.2.2; Wireshark 4.0 packet-epl.c
# dissect_epl_sdo_command_write/read_multiple_by_index): u32 offset of the next entry from the
# command layer's first byte (0: the last entry), u16 index, u8 sub-index, u8 with bit 7 the
# sub-transfer abort and bits 0-1 the pad size (bytes after the data), then the data.
MULTI_PARAM_ENTRY_HEADER_BYTES: Final = 8
_SUB_ABORT: Final = 0x80
_PAD_SIZE: Final = 0x03
_U32: Final = 0xFFFFFFFF


@dataclass(frozen=True, slots=True)
class MultiParamEntry:
    """One entry of a WriteMultipleParam request or ReadMultipleParam response.

    ``pad_size`` is Wireshark's ``epl.asnd.sdo.cmd.data.padding``; ``data`` excludes the pad.
    """

    next_offset: int
    index: int
    subindex: int
    sub_abort: bool
    pad_size: int
    data: bytes


def multi_param_entries(command: SdoCommand) -> tuple[MultiParamEntry, ...]:
    """The entries of an expedited WriteMultipleParam request or ReadMultipleParam response,
    walked as Wireshark 4.0 walks them: each entry runs to the offset of the next (u32
    arithmetic), the last (offset 0) to the end of the segment; the walk stops where an entry
    does not fit the segment. Empty for other commands, aborts and segmented transfers (which
    Wireshark reassembles before it reads entries)."""
    wanted = SDO_WRITE_MULTIPLE_PARAM if not command.response else SDO_READ_MULTIPLE_PARAM
    if command.command_id != wanted or command.abort or command.segmentation != 0:
        return ()
    data = command.data
    pos = 0  # in ``data``; the offsets count from the command layer, 8 bytes earlier
    entries: list[MultiParamEntry] = []
    while len(data) - pos >= MULTI_PARAM_ENTRY_HEADER_BYTES:
        remaining = len(data) - pos
        next_offset, index, subindex, bits = struct.unpack_from("<IHBB", data, pos)
        pad = bits & _PAD_SIZE
        if next_offset == 0:
            length = remaining
        else:
            length = (next_offset - (pos + SDO_COMMAND_HEADER_BYTES)) & _U32
            if (length + MULTI_PARAM_ENTRY_HEADER_BYTES) & _U32 > remaining or pad + 8 >= length:
                break
        start = pos + MULTI_PARAM_ENTRY_HEADER_BYTES
        size = length - MULTI_PARAM_ENTRY_HEADER_BYTES - (pad if next_offset else 0)
        if size > remaining - MULTI_PARAM_ENTRY_HEADER_BYTES:
            break  # an offset behind the entry wrapped round: Wireshark stops at its tree item
        entry = MultiParamEntry(
            next_offset, index, subindex, bool(bits & _SUB_ABORT), pad, data[start : start + size]
        )
        entries.append(entry)
        if next_offset == 0:
            break
        pos += length
    return tuple(entries)


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
        return build("EPL SyncResponse", sync_response_schema, field_values(self))

    @classmethod
    def _decode(cls, body: bytes) -> tuple[SyncResponse, int]:
        c = sync_response_schema.parse(body)
        return cls(**init_kwargs(cls, c)), SYNC_RESPONSE_BYTES - ASND_HEADER_BYTES


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


def decode_service(
    service_id: int, body: bytes, total: int, strict: bool, findings: list[Finding]
) -> tuple[Service, int]:
    """Decode the service bytes after the ASnd header; returns the service and bytes consumed."""
    if service_id == ServiceId.IDENT_RESPONSE:
        return IdentResponse._decode(body)
    if service_id == ServiceId.STATUS_RESPONSE:
        if len(body) < STATUS_RESPONSE_MIN_SERVICE_BYTES:
            findings.append(
                warning(
                    "epl.sres.short",
                    f"EPL StatusResponse: a {ethernet.HEADER_BYTES + ASND_HEADER_BYTES + len(body)}"
                    f"-byte frame; an openPOWERLINK MN needs {STATUS_RESPONSE_MIN_FRAME_BYTES} "
                    "(C_DLL_MINSIZE_STATUSRES) and marks the CN NotActive",
                )
            )
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
