"""Ethernet POWERLINK v2 frames (EtherType 0x88AB): SoC, PReq, PRes, SoA, ASnd, AInv, AMNI.

Layouts follow EPSG DS 301 V1.4.0 section 4.6.1 (frame structures) as Wireshark's ``packet-epl.c``
and openPOWERLINK's ``frame.h`` implement them. All integers are little-endian.

Decoding has two modes. ``strict=True`` raises on anything the spec does not allow (unknown
message types and services, reserved bytes set, sizes past the frame). ``strict=False`` (capture
mode) decodes what it can, keeps every byte, and reports deviations as findings.

Where things are (every name is importable from ``skinframes.powerlink``):

- ``enums``: node ids, MessageType, NmtState, RequestedService, ServiceId, NmtCommandId, flags.
- ``schemas``: byte sizes and the construct schemas of record; the PRes header as a ``struct``.
- ``messages``: SoC, PReq, PRes, SoA, ASnd, RawMessage; each writes and reads its own bytes.
- ``services``: the ASnd services (IdentResponse, StatusResponse, NMTRequest, NMTCommand, SDO,
  SyncResponse), the same way.
- ``frames``: MAC addresses, :func:`frame`, and :func:`decode` (MessageType -> message class).
- ``batch``: many PRes frames at once with numpy.
"""

from skinframes.powerlink.batch import pack_pres_frames as pack_pres_frames
from skinframes.powerlink.batch import pack_soc_frames as pack_soc_frames
from skinframes.powerlink.batch import unpack_pres_frames as unpack_pres_frames
from skinframes.powerlink.enums import (
    BROADCAST_NODE_ID,
    MAX_CN_NODE_ID,
    MN_NODE_ID,
    MessageType,
    NmtCommandId,
    NmtState,
    RequestedService,
    ServiceId,
)
from skinframes.powerlink.enums import DIAGNOSTIC_NODE_ID as DIAGNOSTIC_NODE_ID
from skinframes.powerlink.enums import EPL_VERSION_2_0 as EPL_VERSION_2_0
from skinframes.powerlink.enums import MIN_CN_NODE_ID as MIN_CN_NODE_ID
from skinframes.powerlink.enums import ROUTER_NODE_ID as ROUTER_NODE_ID
from skinframes.powerlink.enums import PReqFlag as PReqFlag
from skinframes.powerlink.enums import PResFlag as PResFlag
from skinframes.powerlink.enums import SoAFlag as SoAFlag
from skinframes.powerlink.enums import SocFlag as SocFlag
from skinframes.powerlink.frames import MAC_AMNI as MAC_AMNI
from skinframes.powerlink.frames import MAC_ASND as MAC_ASND
from skinframes.powerlink.frames import MAC_PRES as MAC_PRES
from skinframes.powerlink.frames import MAC_SOA as MAC_SOA
from skinframes.powerlink.frames import MAC_SOC as MAC_SOC
from skinframes.powerlink.frames import decode, destination_mac, frame, node_mac
from skinframes.powerlink.messages import ASnd, EplMessage, PReq, PRes, RawMessage, SoA, SoC
from skinframes.powerlink.messages import pack_pres as pack_pres
from skinframes.powerlink.schemas import ASND_HEADER_BYTES as ASND_HEADER_BYTES
from skinframes.powerlink.schemas import ERROR_ENTRY_BYTES as ERROR_ENTRY_BYTES
from skinframes.powerlink.schemas import HEADER_BYTES as HEADER_BYTES
from skinframes.powerlink.schemas import IDENT_RESPONSE_BYTES as IDENT_RESPONSE_BYTES
from skinframes.powerlink.schemas import MAX_PDO_PAYLOAD_BYTES
from skinframes.powerlink.schemas import PDO_HEADER_BYTES as PDO_HEADER_BYTES
from skinframes.powerlink.schemas import SDO_COMMAND_HEADER_BYTES as SDO_COMMAND_HEADER_BYTES
from skinframes.powerlink.schemas import SDO_SEQUENCE_BYTES as SDO_SEQUENCE_BYTES
from skinframes.powerlink.schemas import SOA_BYTES as SOA_BYTES
from skinframes.powerlink.schemas import SOC_BYTES as SOC_BYTES
from skinframes.powerlink.schemas import STATUS_RESPONSE_FIXED_BYTES as STATUS_RESPONSE_FIXED_BYTES
from skinframes.powerlink.schemas import SYNC_REQUEST_BYTES as SYNC_REQUEST_BYTES
from skinframes.powerlink.schemas import SYNC_RESPONSE_BYTES as SYNC_RESPONSE_BYTES
from skinframes.powerlink.schemas import error_entry_schema as error_entry_schema
from skinframes.powerlink.schemas import ident_response_schema as ident_response_schema
from skinframes.powerlink.schemas import preq_schema as preq_schema
from skinframes.powerlink.schemas import pres_schema as pres_schema
from skinframes.powerlink.schemas import sdo_command_schema as sdo_command_schema
from skinframes.powerlink.schemas import sdo_sequence_schema as sdo_sequence_schema
from skinframes.powerlink.schemas import soa_schema as soa_schema
from skinframes.powerlink.schemas import soc_schema as soc_schema
from skinframes.powerlink.schemas import status_response_schema as status_response_schema
from skinframes.powerlink.schemas import sync_response_schema as sync_response_schema
from skinframes.powerlink.services import NO_ADDRESS as NO_ADDRESS
from skinframes.powerlink.services import SDO_READ_MULTIPLE_PARAM as SDO_READ_MULTIPLE_PARAM
from skinframes.powerlink.services import SDO_WRITE_MULTIPLE_PARAM as SDO_WRITE_MULTIPLE_PARAM
from skinframes.powerlink.services import (
    ErrorEntry,
    IdentResponse,
    MultiParamEntry,
    NmtCommand,
    NmtRequest,
    RawService,
    Sdo,
    SdoCommand,
    StatusResponse,
    SyncResponse,
    multi_param_entries,
)
from skinframes.powerlink.services import Service as Service

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
    "MultiParamEntry",
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
    "multi_param_entries",
    "node_mac",
]
