"""The concise device configuration (CDC) an openPOWERLINK MN boots its network with.

Format (openPOWERLINK's ``obdconf`` reader; ../shared/tools/openpowerlink/README.md, "CDC
(mnobd.cdc) format"), little-endian: u32 entry count; per entry u16 index, u8 sub-index, u32
size, then ``size`` data bytes. The data of a 0x1F22/<node> entry (NMT_ConfigurationData, DS 301
7.2.1.4.5) is a nested block of the same format: the objects the MN writes to that CN by SDO at
boot. openCONFIGURATOR also writes the same entries as text (``mnobd.txt``): the count as eight
hex digits, then one ``INDEX<TAB>SUB<TAB>SIZE<TAB>VALUE`` line per entry (hex, the value as the
little-endian integer), a 0x1F22 line without a value followed by its nested count and entries.

:func:`skin_cdc` builds the entries with which the MN runs a robot skin: N patches as CNs, each
sending its B taxel bytes (0x6100/1, one TPDO entry of 8*B bits) and its sample number (0x6000/1)
in its PRes, receiving one byte (0x6200/1) in its PReq, as the kit's Demo_3CN (``mnobd.txt``)
does for its CiA 401 CNs. The numbers of time (cycle, timeouts) are the caller's: ``skinframes``
knows bytes, ``emulator.model.epl_config`` derives them from the model.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Final

from skinframes.errors import FieldRangeError, LengthMismatchError, TruncatedError
from skinframes.powerlink.enums import MAX_CN_NODE_ID, MIN_CN_NODE_ID
from skinframes.powerlink.schemas import MAX_PDO_PAYLOAD_BYTES

__all__ = [
    "CONFIGURATION_DATA_INDEX",
    "MN_PDO_CHANNELS",
    "CdcEntry",
    "SkinConfig",
    "check_skin",
    "decode_cdc",
    "encode_cdc",
    "mapping_entry",
    "skin_cdc",
    "to_text",
]

_COUNT = struct.Struct("<I")
_HEADER = struct.Struct("<HBI")  # index, sub-index, size

CONFIGURATION_DATA_INDEX: Final = 0x1F22  # NMT_ConfigurationData_ADOM (DS 301 7.2.1.4.5)

# openPOWERLINK V2.7.2's MN object dictionary (apps/common/objdicts/CiA302-4_MN/objdict.h in the
# kit's source): RPDO channels 0x1400-0x1427 / mappings 0x1600-0x1627 and TPDO channels
# 0x1800-0x1827 / 0x1A00-0x1A27, 40 each. The skin needs one of each per CN (the MN receives each
# CN's PRes on its own RPDO channel and sends each PReq on its own TPDO channel), so the stock MN
# runs at most 40 patches.
MN_PDO_CHANNELS: Final = 40
# The MN's process image objects (objdict.h: 0xA4C0 PI_Output_U8, 0xA040 PI_Input_U8, 252
# sub-indices each), mapped as mnobd.txt maps them: RPDO channel k to 0xA4C0/k+1, TPDO channel
# k from 0xA040/k+1.
MN_RX_IMAGE_INDEX: Final = 0xA4C0
MN_TX_IMAGE_INDEX: Final = 0xA040
MN_RPDO_COMM: Final = 0x1400
MN_TPDO_COMM: Final = 0x1800
RPDO_MAPPING: Final = 0x1600
TPDO_MAPPING: Final = 0x1A00

# Payload limits: DS 301 7.2.1.1.18 / openPOWERLINK's objdict.h ranges 36..1490 (36: the 46-byte
# minimum Ethernet payload less the 10-byte PReq/PRes header).
MIN_PAYLOAD_LIMIT_BYTES: Final = 36
SAMPLE_NUMBER_BYTES: Final = 1  # 0x6000/1 UNSIGNED8 behind the taxels
MAX_TAXEL_BYTES: Final = MAX_PDO_PAYLOAD_BYTES - SAMPLE_NUMBER_BYTES  # 1489
PREQ_DATA_BYTES: Final = 1  # 0x6200/1 UNSIGNED8, the demo's RPDO

# The CiA 401 objects the CN maps (emulator/epl/od.py serves them).
INPUTS_INDEX: Final = 0x6000
TAXELS_INDEX: Final = 0x6100
OUTPUTS_INDEX: Final = 0x6200

# Values taken from the kit's Demo_3CN (mnobd.txt): the node assignment 0x1F81 (bit 0 node
# exists, 1 is a CN, 2 may be started; bit 31 the entry is valid, written last), the loss
# thresholds, ConfDate/ConfTime, the loss-of-frame tolerance.
NODE_ASSIGNMENT: Final = 0x00000007
NODE_ASSIGNMENT_VALID: Final = 0x80000000
MN_LOSS_OF_PRES_THRESHOLD: Final = 40  # 0x1C09/<node>: each miss adds 8, a good cycle takes 1
MN_CYCLE_EXCEED_THRESHOLD: Final = 40  # 0x1C02/3
CN_LOSS_THRESHOLD: Final = 80  # 0x1C0B/3 (loss of SoC), 0x1C0D/3 (loss of PReq)
LOSS_OF_FRAME_TOLERANCE_NS: Final = 50_000_000  # 0x1C14
CONF_DATE: Final = 0x3124  # 0x1F26/<node> and the CN's 0x1020/1
CONF_TIME: Final = 0x03735955  # 0x1F27/<node> and the CN's 0x1020/2
NS_PER_US: Final = 1_000


@dataclass(frozen=True, slots=True)
class CdcEntry:
    """One object the CDC sets: ``index``/``subindex`` and its bytes (little-endian)."""

    index: int
    subindex: int
    data: bytes

    @property
    def value(self) -> int:
        """The data as a little-endian unsigned integer."""
        return int.from_bytes(self.data, "little")

    @property
    def nested(self) -> tuple[CdcEntry, ...]:
        """A 0x1F22 entry's block: the entries the MN writes to that node."""
        if self.index != CONFIGURATION_DATA_INDEX:
            return ()
        return decode_cdc(self.data)


def _u(value: int, size_bytes: int) -> bytes:
    if not 0 <= value < 1 << (8 * size_bytes):
        raise FieldRangeError(f"CDC: {value} does not fit {size_bytes} bytes")
    return value.to_bytes(size_bytes, "little")


def _entry(index: int, subindex: int, value: int, size_bytes: int) -> CdcEntry:
    """An entry of an unsigned integer ``value`` of ``size_bytes``."""
    return CdcEntry(index, subindex, _u(value, size_bytes))


def encode_cdc(entries: Iterable[CdcEntry]) -> bytes:
    """The binary block of ``entries`` (count, then each header and data)."""
    items = list(entries)
    out = [_COUNT.pack(len(items))]
    for e in items:
        if not (0 <= e.index <= 0xFFFF and 0 <= e.subindex <= 0xFF):
            raise FieldRangeError(f"CDC: object {e.index:#x}/{e.subindex:#x}")
        out += [_HEADER.pack(e.index, e.subindex, len(e.data)), e.data]
    return b"".join(out)


def decode_cdc(data: bytes) -> tuple[CdcEntry, ...]:
    """The entries of a binary block; strict: a short entry or leftover bytes raise.

    Raises:
        TruncatedError: fewer bytes than the count or an entry's size says.
        LengthMismatchError: bytes after the last entry.
    """
    if len(data) < _COUNT.size:
        raise TruncatedError(f"CDC: {len(data)} bytes, no entry count", offset=0)
    (count,) = _COUNT.unpack_from(data)
    at = _COUNT.size
    entries = []
    for k in range(count):
        if at + _HEADER.size > len(data):
            raise TruncatedError(f"CDC: entry {k} of {count} past the end", offset=at)
        index, sub, size = _HEADER.unpack_from(data, at)
        at += _HEADER.size
        if at + size > len(data):
            raise TruncatedError(
                f"CDC: entry {k} ({index:#06x}/{sub:#04x}) of {size} bytes past the end", offset=at
            )
        entries.append(CdcEntry(index, sub, bytes(data[at : at + size])))
        at += size
    if at != len(data):
        raise LengthMismatchError(f"CDC: {len(data) - at} bytes after {count} entries", offset=at)
    return tuple(entries)


def to_text(entries: Sequence[CdcEntry]) -> str:
    """openCONFIGURATOR's text form (as ``mnobd.txt``, without its comment lines)."""
    lines = [f"{len(entries):08X}"]
    for e in entries:
        head = f"{e.index:04X}\t{e.subindex:02X}\t{len(e.data):08X}"
        if e.index == CONFIGURATION_DATA_INDEX:
            lines += ["", f"//// Configuration Data for CN {e.subindex}", head]
            lines += to_text(e.nested).splitlines()
            lines.append("")
        else:
            lines.append(f"{head}\t{e.value:0{2 * len(e.data)}X}")
    return "\n".join(lines) + "\n"


def mapping_entry(index: int, subindex: int, offset_bits: int, length_bits: int) -> int:
    """The UNSIGNED64 of one PDO mapping entry (DS 301 6.4.9.2, Table 41): length 16 | offset
    16 | reserved 8 | sub-index 8 | index 16, most significant first."""
    return index | subindex << 16 | offset_bits << 32 | length_bits << 48


@dataclass(frozen=True, slots=True)
class SkinConfig:
    """What :func:`skin_cdc` configures; times in whole units as the objects hold them.

    Attributes:
        node_ids: the CNs, one per patch.
        taxel_bytes: B, each patch's taxel bytes (0x6100/1).
        cycle_us: the cycle (MN and CN 0x1006).
        pres_timeout_us: each CN's PRes timeout at the MN (0x1F92, written in ns).
        async_slot_us: the MN's asynchronous slot timeout (0x1F8A/2, written in ns).
    """

    node_ids: tuple[int, ...]
    taxel_bytes: int
    cycle_us: int
    pres_timeout_us: int
    async_slot_us: int

    @property
    def pres_payload_bytes(self) -> int:
        """A CN's PRes payload: the taxels, then 0x6000/1; at least the 36-byte lowest limit."""
        return max(MIN_PAYLOAD_LIMIT_BYTES, self.taxel_bytes + SAMPLE_NUMBER_BYTES)

    @property
    def preq_payload_bytes(self) -> int:
        """A PReq's payload limit: 0x6200/1 fits the lowest limit, 36 bytes."""
        return max(MIN_PAYLOAD_LIMIT_BYTES, PREQ_DATA_BYTES)


def check_skin(node_ids: Sequence[int], taxel_bytes: int) -> None:
    """Raise FieldRangeError for a skin the stock openPOWERLINK MN cannot run."""
    if not node_ids:
        raise FieldRangeError("epl-config: no CN")
    if len(node_ids) > MN_PDO_CHANNELS:
        raise FieldRangeError(
            f"epl-config: {len(node_ids)} CNs; the openPOWERLINK MN's object dictionary has "
            f"{MN_PDO_CHANNELS} RPDO and {MN_PDO_CHANNELS} TPDO channels, one of each per CN "
            f"(1..{MN_PDO_CHANNELS})"
        )
    bad = [n for n in node_ids if not MIN_CN_NODE_ID <= n <= MAX_CN_NODE_ID]
    if bad:
        raise FieldRangeError(f"epl-config: node id {bad[0]} ({MIN_CN_NODE_ID}..{MAX_CN_NODE_ID})")
    if len(set(node_ids)) != len(node_ids):
        raise FieldRangeError("epl-config: a node id twice")
    if not 1 <= taxel_bytes <= MAX_TAXEL_BYTES:
        raise FieldRangeError(
            f"epl-config: {taxel_bytes} taxel bytes (1..{MAX_TAXEL_BYTES}: the taxels and the "
            f"sample number 0x6000/1 fill a PRes payload of at most {MAX_PDO_PAYLOAD_BYTES})"
        )


def _cn_block(config: SkinConfig) -> tuple[CdcEntry, ...]:
    """A CN's 0x1F22 block, in Demo_3CN's order: mappings off, cycle, ConfDate/Time, loss
    thresholds, tolerance, payload limits, the mappings, mappings on."""
    taxel_bits = 8 * config.taxel_bytes
    return (
        _entry(RPDO_MAPPING, 0, 0, 1),
        _entry(TPDO_MAPPING, 0, 0, 1),
        _entry(0x1006, 0, config.cycle_us, 4),
        _entry(0x1020, 1, CONF_DATE, 4),
        _entry(0x1020, 2, CONF_TIME, 4),
        _entry(0x1C0B, 3, CN_LOSS_THRESHOLD, 4),
        _entry(0x1C0D, 3, CN_LOSS_THRESHOLD, 4),
        _entry(0x1C14, 0, LOSS_OF_FRAME_TOLERANCE_NS, 4),
        _entry(0x1F98, 4, config.preq_payload_bytes, 2),
        _entry(0x1F98, 5, config.pres_payload_bytes, 2),
        _entry(RPDO_MAPPING, 1, mapping_entry(OUTPUTS_INDEX, 1, 0, 8 * PREQ_DATA_BYTES), 8),
        _entry(TPDO_MAPPING, 1, mapping_entry(TAXELS_INDEX, 1, 0, taxel_bits), 8),
        _entry(TPDO_MAPPING, 2, mapping_entry(INPUTS_INDEX, 1, taxel_bits, 8), 8),
        _entry(RPDO_MAPPING, 0, 1, 1),
        _entry(TPDO_MAPPING, 0, 2, 1),
    )


def skin_cdc(config: SkinConfig) -> tuple[CdcEntry, ...]:
    """The MN's entries for ``config``, in Demo_3CN's order (mnobd.txt): node assignment, the
    MN's mappings off, cycle and thresholds, ConfDate/ConfTime, async slot, payload limits, PRes
    timeouts, the MN's PDO channels (it reads each CN's first taxel byte, sends it one byte),
    mappings on, each CN's 0x1F22 block, the node assignment again with its valid bit.

    Raises:
        FieldRangeError: a skin the stock MN cannot run (:func:`check_skin`), or a time that
            does not fit its object.
    """
    ids = config.node_ids
    check_skin(ids, config.taxel_bytes)
    mn = [_entry(0x1F81, n, NODE_ASSIGNMENT, 4) for n in ids]
    mn += [_entry(RPDO_MAPPING + k, 0, 0, 1) for k in range(len(ids))]
    mn += [_entry(TPDO_MAPPING + k, 0, 0, 1) for k in range(len(ids))]
    mn += [_entry(0x1006, 0, config.cycle_us, 4), _entry(0x1C02, 3, MN_CYCLE_EXCEED_THRESHOLD, 4)]
    mn += [_entry(0x1C09, n, MN_LOSS_OF_PRES_THRESHOLD, 4) for n in ids]
    mn.append(_entry(0x1C14, 0, LOSS_OF_FRAME_TOLERANCE_NS, 4))
    mn += [_entry(0x1F26, n, CONF_DATE, 4) for n in ids]
    mn += [_entry(0x1F27, n, CONF_TIME, 4) for n in ids]
    mn.append(_entry(0x1F8A, 2, config.async_slot_us * NS_PER_US, 4))
    mn += [_entry(0x1F8B, n, config.preq_payload_bytes, 2) for n in ids]
    mn += [_entry(0x1F8D, n, config.pres_payload_bytes, 2) for n in ids]
    mn += [_entry(0x1F92, n, config.pres_timeout_us * NS_PER_US, 4) for n in ids]
    channels = range(len(ids))
    mn += [_entry(MN_RPDO_COMM + k, 1, ids[k], 1) for k in channels]
    mn += [
        _entry(RPDO_MAPPING + k, 1, mapping_entry(MN_RX_IMAGE_INDEX, k + 1, 0, 8), 8)
        for k in channels
    ]
    mn += [_entry(MN_TPDO_COMM + k, 1, ids[k], 1) for k in channels]
    mn += [
        _entry(TPDO_MAPPING + k, 1, mapping_entry(MN_TX_IMAGE_INDEX, k + 1, 0, 8), 8)
        for k in channels
    ]
    mn += [_entry(RPDO_MAPPING + k, 0, 1, 1) for k in channels]
    mn += [_entry(TPDO_MAPPING + k, 0, 1, 1) for k in channels]
    block = encode_cdc(_cn_block(config))
    mn += [CdcEntry(CONFIGURATION_DATA_INDEX, n, block) for n in ids]
    mn += [_entry(0x1F81, n, NODE_ASSIGNMENT_VALID | NODE_ASSIGNMENT, 4) for n in ids]
    return tuple(mn)
