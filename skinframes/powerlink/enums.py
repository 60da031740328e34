"""The numbers DS 301 gives names: node ids, message types, NMT states, services and flags.

EPSG DS 301 V1.4.0; values as Wireshark's ``packet-epl.c`` and openPOWERLINK's ``oplkdefs.h`` and
``frame.h`` use them.
"""

from __future__ import annotations

from enum import IntEnum, IntFlag
from typing import Final

# --- node ids (DS 301 4.2.5.1.1; openPOWERLINK oplkdefs.h) ---------------------------------------
MN_NODE_ID: Final = 240  # C_ADR_MN_DEF_NODE_ID
BROADCAST_NODE_ID: Final = 255  # C_ADR_BROADCAST
MIN_CN_NODE_ID: Final = 1
MAX_CN_NODE_ID: Final = 239
DIAGNOSTIC_NODE_ID: Final = 253
ROUTER_NODE_ID: Final = 254

EPL_VERSION_2_0: Final = 0x20


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


# --- Wireshark's names of the flag bits ------------------------------------------------------------
# Per message: Wireshark field name (the last part of ``epl.<message>.<name>``, packet-epl.c, checked
# with tshark 4.0 ``-G fields``) -> (the flags byte's attribute, mask). A one-bit mask reads as a
# bool, a wider one as the number its bits hold (PR 0x38: 0..7, RS 0x07: 0..7). FLS/SLS (first and
# second link status, DS 301 V1.4.0 4.6.1.1.3-4, 7.3.3.2.1, 7.3.3.3.1) sit in byte 5 (flags2).
FlagBits = dict[str, tuple[str, int]]
SOC_FLAG_BITS: Final[FlagBits] = {
    "mc": ("flags", 0x80),
    "ps": ("flags", 0x40),
    "an": ("flags", 0x08),
}
PREQ_FLAG_BITS: Final[FlagBits] = {
    "ms": ("flags1", 0x20),
    "ea": ("flags1", 0x04),
    "rd": ("flags1", 0x01),
    "fls": ("flags2", 0x80),
    "sls": ("flags2", 0x40),
}
PRES_FLAG_BITS: Final[FlagBits] = {
    "ms": ("flags1", 0x20),
    "en": ("flags1", 0x10),
    "rd": ("flags1", 0x01),
    "fls": ("flags2", 0x80),
    "sls": ("flags2", 0x40),
    "pr": ("flags2", 0x38),
    "rs": ("flags2", 0x07),
}
SOA_FLAG_BITS: Final[FlagBits] = {"ea": ("flags1", 0x04), "er": ("flags1", 0x02)}
# IdentResponse (epl.asnd.ires.*) and StatusResponse (epl.asnd.sres.*) share their flag bytes
RESPONSE_FLAG_BITS: Final[FlagBits] = {
    "en": ("flags1", 0x10),
    "ec": ("flags1", 0x08),
    "fls": ("flags2", 0x80),
    "sls": ("flags2", 0x40),
    "pr": ("flags2", 0x38),
    "rs": ("flags2", 0x07),
}


def flag_bits(message: object, table: FlagBits) -> dict[str, bool | int]:
    """The flag bits of ``message`` under Wireshark's names (``table``: one of the above).

    Looked up per flags byte in tables built once per ``table`` (every PRes of a capture
    passes here when it is described)."""
    out: dict[str, bool | int] = {}
    for attr, lut in _lookup(table):
        value = getattr(message, attr)
        out.update(lut[value] if 0 <= value <= 0xFF else _bits(value, table, attr))
    return out


def _bits(value: int, table: FlagBits, attr: str) -> dict[str, bool | int]:
    """The bits of one flags byte: one-bit masks as bools, wider ones shifted down."""
    out: dict[str, bool | int] = {}
    for name, (field, mask) in table.items():
        if field == attr:
            shift = (mask & -mask).bit_length() - 1
            out[name] = bool(value & mask) if mask >> shift == 1 else (value & mask) >> shift
    return out


_LUTS: dict[int, tuple[FlagBits, tuple[tuple[str, tuple[dict[str, bool | int], ...]], ...]]] = {}


def _lookup(table: FlagBits) -> tuple[tuple[str, tuple[dict[str, bool | int], ...]], ...]:
    """Per flags attribute of ``table``, the bits of each of the 256 byte values."""
    hit = _LUTS.get(id(table))
    if hit is None or hit[0] is not table:
        attrs = dict.fromkeys(attr for attr, _ in table.values())
        luts = tuple((a, tuple(_bits(v, table, a) for v in range(256))) for a in attrs)
        hit = _LUTS[id(table)] = (table, luts)
    return hit[1]


def known(enum: type[IntEnum], value: int) -> int:
    """``enum(value)`` when the value is known, else the plain int (capture mode keeps it).

    A dict lookup: ``enum(value)`` costs about a microsecond, paid by every decoded PRes.
    """
    members = _MEMBERS.get(enum)
    if members is None:
        members = _MEMBERS[enum] = {int(m): m for m in enum}
    return members.get(value, value)


_MEMBERS: dict[type[IntEnum], dict[int, IntEnum]] = {}
