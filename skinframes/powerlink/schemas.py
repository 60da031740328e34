"""The EPL layouts of record: byte sizes and one construct schema per message and service.

Layouts follow EPSG DS 301 V1.4.0 section 4.6.1 (frame structures) as Wireshark's ``packet-epl.c``
and openPOWERLINK's ``frame.h`` implement them; byte offsets count from the first byte after the
EtherType. All integers are little-endian.

The message classes (:mod:`.messages`, :mod:`.services`) build and parse their bytes with these
schemas. The one exception is the PRes, sent by every CN in every cycle: :data:`PRES_HEAD` packs
its header with one ``struct`` call, and tests prove it equal to :data:`pres_schema`.
"""

from __future__ import annotations

import struct
from dataclasses import fields
from typing import Any, Final

import construct as cs

from skinframes.errors import encoding

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

# Offsets the fast paths read directly (the schemas below say the same)
SRC_OFFSET: Final = 2  # Source node id in the common header
FLAGS1_OFFSET: Final = 4  # PReq/PRes flags byte: RD (bit 0), EN, MS, ... (enums.PResFlag)
PDO_SIZE_OFFSET: Final = 8  # PReq/PRes Size (u16); the payload starts at PDO_HEADER_BYTES
SOC_NET_TIME_OFFSET: Final = 6  # SoC NetTime (s, ns), then RelativeTime: soc_schema below

# --- messages ------------------------------------------------------------------------------------
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

# pres_schema's header as one struct: message_type, dest, src, nmt_status, flags1, flags2,
# pdo_version, reserved_7, size (the fast path; equal to pres_schema, tested with hypothesis)
PRES_HEAD: Final = struct.Struct("<BBBBBBBBH")
# preq_schema's header: message_type, dest, src, reserved_3, flags1, flags2, pdo_version,
# reserved_7, size (same shape as the PRes header; tested equal to preq_schema)
PREQ_HEAD: Final = PRES_HEAD

# soc_schema as one struct: message_type, dest, src, reserved_3, flags, reserved_5, net_time_s,
# net_time_ns, relative_time_us (the decoding fast path; tested equal to soc_schema)
SOC_STRUCT: Final = struct.Struct("<BBBBBBIIQ")

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

# soa_schema without its optional SyncRequest, as one struct: message_type, dest, src,
# nmt_status, flags1, reserved_5, requested_service, requested_target, epl_version, flags3
SOA_STRUCT: Final = struct.Struct("<BBBBBBBBBB")
SOA_SYNC_REQUEST: Final = 6  # RequestedService.SYNC_REQUEST: the SoA carries a SyncRequest

# --- ASnd services: the bytes after the 4-byte ASnd header ---------------------------------------
ident_response_schema = cs.Struct(
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


# --- between schemas and dataclasses (the field names are the same) ------------------------------
def init_kwargs(cls: type[Any], container: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """Dataclass keyword arguments from a parsed construct container (same names)."""
    names = {f.name for f in fields(cls) if f.init}
    return {k: v for k, v in container.items() if k in names and k not in skip}


def field_values(obj: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """A dataclass's fields as the dict a schema builds from."""
    return {f.name: getattr(obj, f.name) for f in fields(obj) if f.name not in skip}


def build(what: str, schema: cs.Construct, values: dict[str, Any]) -> bytes:
    """``schema.build(values)``; a value that does not fit raises :class:`FieldRangeError`."""
    with encoding(what):
        return bytes(schema.build(values))
