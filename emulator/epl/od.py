"""The object dictionary of an emulated EPL skin patch (EPSG DS 301 V1.4.0 chapter 6, 7.2).

Every entry has a data type (DS 301 6.1.4, Table 36), an access type, a default and whether it
may be mapped into a PDO; values are kept as the little-endian bytes the SDO server carries.
:meth:`ObjectDictionary.write` enforces the rules whose breach an SDO client learns as an abort
code (DS 301 Table 58): unknown objects and sub-indices, access, sizes, value limits, and the
PDO mapping rules of 6.4.9 (a mapping is changed only while its sub-index 0 is 0; enabling it
checks every entry, mappability and the payload limit 0x1F98/4,5).

The patch: CiA 401 digital inputs 0x6000/1 (UNSIGNED8: the number of the taxel sample now
published, modulo 256, so a master sees the inputs move) and outputs 0x6200/1 (UNSIGNED8, what
the MN's PReq carries), which the openPOWERLINK demo maps, and the patch's taxel bytes as one
OCTET_STRING 0x6100/1, mappable with one TPDO entry of 8*B bits.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import Enum, IntEnum
from typing import Final

from emulator.errors import SdoAbortError
from skinframes.powerlink import MAX_PDO_PAYLOAD_BYTES, cdc
from skinframes.powerlink.cdc import mapping_entry as mapping_entry  # was defined here
from skinframes.powerlink.sdo import AbortCode


class DataType(IntEnum):
    """Static data types (DS 301 6.1.4, Table 36), those this dictionary uses."""

    BOOLEAN = 0x0001
    UNSIGNED8 = 0x0005
    UNSIGNED16 = 0x0006
    UNSIGNED32 = 0x0007
    VISIBLE_STRING = 0x0009
    OCTET_STRING = 0x000A
    UNSIGNED64 = 0x001B


FIXED_BYTES: Final = {
    DataType.BOOLEAN: 1,
    DataType.UNSIGNED8: 1,
    DataType.UNSIGNED16: 2,
    DataType.UNSIGNED32: 4,
    DataType.UNSIGNED64: 8,
}


class Access(Enum):
    """Access types (DS 301 6.2.1: const, ro, wo, rw)."""

    CONST = "const"
    RO = "ro"
    WO = "wo"
    RW = "rw"


# --- identity of the emulated device -------------------------------------------------------------
DEVICE_TYPE: Final = 0x000F0191  # 0x1000: CiA 401 (generic I/O), digital in + out + analogue
VENDOR_ID: Final = 0x00000000  # 0x1018/1: no EPSG vendor id (an emulator, not a product)
PRODUCT_CODE: Final = 0x534B494E  # 0x1018/2: "SKIN"
REVISION: Final = 0x00010000  # 0x1018/3
DEVICE_NAME: Final = b"skinframes skin patch"
HARDWARE_VERSION: Final = b"emulated"
SOFTWARE_VERSION: Final = b"skinframes"
# 0x1F82 NMT_FeatureFlags_U32 (DS 301 7.2.1.1.21): bit 0 isochronous, bit 2 SDO by ASnd, bit 5
# extended NMT state commands, bit 6 dynamic PDO mapping: what this CN implements.
FEATURE_FLAGS: Final = 0x00000065
# 0x1F98/3 PResMaxLatency_U32 (ns): the PReq -> PRes time this CN promises; the target
# (issue 40: as fast as openPOWERLINK's own CN, within the shipped CDC's 200 us PRes timeout).
PRES_MAX_LATENCY_NS: Final = 200_000
# 0x1F98/4,5 PReq/PResActPayloadLimit: default and lowest value 36 (DS 301 7.2.1.1.18; as
# openPOWERLINK's CN, apps/common/objdicts/CiA401_CN/objdict.h: range 36..1490)
DEFAULT_PAYLOAD_LIMIT_BYTES: Final = cdc.MIN_PAYLOAD_LIMIT_BYTES  # 36
DEFAULT_CYCLE_US: Final = 0  # 0x1006: 0 until the MN configures it
# 0x1C0B/3, 0x1C0D/3 thresholds and 0x1C14 LossOfFrameTolerance: openPOWERLINK's CN defaults
# (CiA401_CN/objdict.h: 15; 100000 ns); an MN's CDC writes its own (the kit's: 80, 50 ms)
DEFAULT_LOSS_THRESHOLD: Final = 15
DEFAULT_LOSS_TOLERANCE_NS: Final = 100_000
DEFAULT_BASIC_ETHERNET_TIMEOUT_US: Final = 5_000_000  # 0x1F99 (DS 301 7.2.1.1.20 default 5 s)
MAPPING_ENTRIES: Final = 16  # sub-indices 1..16 of each 0x1600/0x1A00 mapping
ETHERNET_INTERFACE_TYPE: Final = 6  # 0x1030/3: ethernetCsmacd (IANA ifType, DS 301 7.2.1.4.1)
ETHERNET_MTU_BYTES: Final = 1500

# the objects an MN's CDC names (skinframes.powerlink.cdc, as `skinframes epl-config` writes it)
MAP_INDEX_RX: Final = cdc.RPDO_MAPPING  # 0x1600
MAP_INDEX_TX: Final = cdc.TPDO_MAPPING  # 0x1A00
TAXELS_INDEX: Final = cdc.TAXELS_INDEX  # 0x6100
INPUTS_INDEX: Final = cdc.INPUTS_INDEX  # 0x6000
OUTPUTS_INDEX: Final = cdc.OUTPUTS_INDEX  # 0x6200


@dataclass(slots=True)
class Entry:
    """One sub-index: type, access, mappable, the default and the present value (bytes)."""

    dtype: DataType
    access: Access
    default: bytes
    mappable: bool = False
    max_bytes: int = 0  # strings: the longest value; fixed types: their size
    value: bytes = b""

    def __post_init__(self) -> None:
        self.max_bytes = FIXED_BYTES.get(self.dtype, self.max_bytes or len(self.default))
        self.value = self.default


@dataclass(frozen=True, slots=True)
class Mapped:
    """One PDO mapping entry (DS 301 6.4.9.2: u64 = length 16 | offset 16 | reserved 8 | sub 8
    | index 16 bits), in bytes."""

    index: int
    subindex: int
    offset_bytes: int
    length_bytes: int


def _u(dtype: DataType, value: int) -> bytes:
    return value.to_bytes(FIXED_BYTES[dtype], "little")


def _vs(text: bytes) -> Entry:
    return Entry(DataType.VISIBLE_STRING, Access.CONST, text)


@dataclass
class ObjectDictionary:
    """The dictionary of one CN (node ``node_id``) with ``taxel_bytes`` bytes at 0x6100/1."""

    node_id: int
    taxel_bytes: int
    entries: dict[tuple[int, int], Entry] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.entries = dict(self._defaults())

    # --- construction ------------------------------------------------------------------------
    def _defaults(self) -> Iterator[tuple[tuple[int, int], Entry]]:
        U8, U16, U32, U64 = (  # noqa: N806 - the spec's type names
            DataType.UNSIGNED8,
            DataType.UNSIGNED16,
            DataType.UNSIGNED32,
            DataType.UNSIGNED64,
        )
        ro, rw, const = Access.RO, Access.RW, Access.CONST

        def e(dtype: DataType, access: Access, value: int, mappable: bool = False) -> Entry:
            return Entry(dtype, access, _u(dtype, value), mappable)

        def count(n: int, access: Access = const) -> Entry:
            return e(U8, access, n)

        yield (0x1000, 0), e(U32, const, DEVICE_TYPE)
        yield (0x1006, 0), e(U32, rw, DEFAULT_CYCLE_US)  # NMT_CycleLen_U32 (us)
        yield (0x1008, 0), _vs(DEVICE_NAME)
        yield (0x1009, 0), _vs(HARDWARE_VERSION)
        yield (0x100A, 0), _vs(SOFTWARE_VERSION)
        # 0x1010 NMT_StoreParam_REC, 0x1011 NMT_RestoreDefParam_REC (DS 301 7.2.1.1.6-7): reading
        # sub 1 gives 0, "does not save/restore on command": every reset restores the defaults
        for index in (0x1010, 0x1011):
            yield (index, 0), count(1)
            yield (index, 1), e(U32, rw, 0)
        yield (0x1018, 0), count(4)  # NMT_IdentityObject_REC
        yield (0x1018, 1), e(U32, const, VENDOR_ID)
        yield (0x1018, 2), e(U32, const, PRODUCT_CODE)
        yield (0x1018, 3), e(U32, const, REVISION)
        yield (0x1018, 4), e(U32, const, self.node_id)  # serial number: the node id
        yield (0x1020, 0), count(2)  # CFM_VerifyConfiguration_REC: ConfDate, ConfTime
        yield (0x1020, 1), e(U32, rw, 0)
        yield (0x1020, 2), e(U32, rw, 0)
        yield (0x1030, 0), count(9)  # NWL_IfGroup_0h_REC (DS 301 7.2.1.4.1)
        yield (0x1030, 1), e(U16, ro, 1)  # InterfaceIndex
        yield (0x1030, 2), _vs(b"emulated veth")  # InterfaceDescription
        yield (0x1030, 3), e(U8, ro, ETHERNET_INTERFACE_TYPE)
        yield (0x1030, 4), e(U16, ro, ETHERNET_MTU_BYTES)
        yield (
            (0x1030, 5),
            Entry(DataType.OCTET_STRING, ro, bytes((0x02, 0, 0, 0, 0x0A, self.node_id))),
        )  # InterfacePhysAddress: the MAC the node sends from
        yield (0x1030, 6), _vs(b"skin")  # InterfaceName
        yield (0x1030, 7), e(U8, ro, 1)  # InterfaceOperStatus: up
        yield (0x1030, 8), e(U8, rw, 1)  # InterfaceAdminState: up
        yield (0x1030, 9), e(DataType.BOOLEAN, rw, 1)  # Valid
        for index in (0x1C0B, 0x1C0D):  # DLL_CNLossSoC_REC, DLL_CNLossPReq_REC (7.2.1.2)
            yield (index, 0), count(3)
            yield (index, 1), e(U32, rw, 0)  # CumulativeCnt
            yield (index, 2), e(U32, ro, 0)  # ThresholdCnt
            yield (index, 3), e(U32, rw, DEFAULT_LOSS_THRESHOLD)
        yield (0x1C14, 0), e(U32, rw, DEFAULT_LOSS_TOLERANCE_NS)  # DLL_LossOfFrameTolerance
        yield (0x1F82, 0), e(U32, const, FEATURE_FLAGS)
        yield (0x1F98, 0), count(9)  # NMT_CycleTiming_REC (DS 301 7.2.1.1.18)
        yield (0x1F98, 1), e(U16, const, MAX_PDO_PAYLOAD_BYTES)  # IsochrTxMaxPayload
        yield (0x1F98, 2), e(U16, const, MAX_PDO_PAYLOAD_BYTES)  # IsochrRxMaxPayload
        yield (0x1F98, 3), e(U32, const, PRES_MAX_LATENCY_NS)
        yield (0x1F98, 4), e(U16, rw, DEFAULT_PAYLOAD_LIMIT_BYTES)  # PReqActPayloadLimit
        yield (0x1F98, 5), e(U16, rw, DEFAULT_PAYLOAD_LIMIT_BYTES)  # PResActPayloadLimit
        yield (0x1F98, 6), e(U32, const, PRES_MAX_LATENCY_NS)  # ASndMaxLatency
        yield (0x1F98, 7), e(U8, rw, 0)  # MultiplCycleCnt
        yield (0x1F98, 8), e(U16, rw, ETHERNET_MTU_BYTES)  # AsyncMTU
        yield (0x1F98, 9), e(U16, rw, 2)  # Prescaler
        yield (0x1F99, 0), e(U32, rw, DEFAULT_BASIC_ETHERNET_TIMEOUT_US)
        for comm, mapping in ((0x1400, MAP_INDEX_RX), (0x1800, MAP_INDEX_TX)):
            yield (comm, 0), count(2)  # PDO_Rx/TxCommParam_00h_REC
            yield (comm, 1), e(U8, rw, 0)  # NodeID_U8: 0 = PReq (RPDO) / broadcast PRes
            yield (comm, 2), e(U8, rw, 0)  # MappingVersion_U8
            yield (mapping, 0), count(0, rw)  # NumberOfEntries: the mapping is off
            for sub in range(1, MAPPING_ENTRIES + 1):
                yield (mapping, sub), e(U64, rw, 0)
        yield (INPUTS_INDEX, 0), count(1)
        yield (INPUTS_INDEX, 1), e(U8, ro, 0, mappable=True)
        yield (TAXELS_INDEX, 0), count(1)
        yield (
            (TAXELS_INDEX, 1),
            Entry(DataType.OCTET_STRING, ro, bytes(self.taxel_bytes), mappable=True),
        )
        yield (OUTPUTS_INDEX, 0), count(1)
        yield (OUTPUTS_INDEX, 1), e(U8, rw, 0, mappable=True)

    # --- access ------------------------------------------------------------------------------
    def _entry(self, index: int, subindex: int) -> Entry:
        entry = self.entries.get((index, subindex))
        if entry is None:
            if (index, 0) in self.entries:
                raise SdoAbortError(AbortCode.NO_SUBINDEX, f"no sub-index {index:#06x}/{subindex}")
            raise SdoAbortError(AbortCode.NO_OBJECT, f"no object {index:#06x}")
        return entry

    def read(self, index: int, subindex: int) -> bytes:
        """The value an SDO read returns.

        Raises:
            SdoAbortError: no such object or sub-index, or write-only.
        """
        entry = self._entry(index, subindex)
        if entry.access is Access.WO:
            raise SdoAbortError(AbortCode.READ_WRITE_ONLY, f"{index:#06x}/{subindex} write-only")
        return entry.value

    def write(self, index: int, subindex: int, data: bytes) -> None:
        """An SDO write (DS 301 6.3.2.4.2.1.1), checked as the spec says.

        Raises:
            SdoAbortError: with the abort code of DS 301 Table 58.
        """
        entry = self._entry(index, subindex)
        where = f"{index:#06x}/{subindex}"
        if entry.access in (Access.RO, Access.CONST):
            raise SdoAbortError(AbortCode.WRITE_READ_ONLY, f"{where} is read-only")
        fixed = FIXED_BYTES.get(entry.dtype)
        if fixed is not None and len(data) != fixed:
            code = AbortCode.LENGTH_TOO_HIGH if len(data) > fixed else AbortCode.LENGTH_TOO_LOW
            raise SdoAbortError(code, f"{where}: {len(data)} bytes, the object has {fixed}")
        if fixed is None and len(data) > entry.max_bytes:
            raise SdoAbortError(
                AbortCode.LENGTH_TOO_HIGH, f"{where}: {len(data)} bytes, at most {entry.max_bytes}"
            )
        value = int.from_bytes(data, "little") if fixed is not None else 0
        if index in (0x1010, 0x1011):  # store/restore on command: this CN keeps nothing
            raise SdoAbortError(AbortCode.CANNOT_STORE, f"{where}: nothing is stored")
        if entry.dtype is DataType.BOOLEAN and value > 1:
            raise SdoAbortError(AbortCode.VALUE_TOO_HIGH, f"{where}: BOOLEAN {value}")
        if index == 0x1F98 and subindex in (4, 5):
            limit = self.u(0x1F98, 2 if subindex == 4 else 1)
            if value > limit:
                raise SdoAbortError(AbortCode.VALUE_TOO_HIGH, f"{where}: {value} > {limit}")
            if value < DEFAULT_PAYLOAD_LIMIT_BYTES:
                raise SdoAbortError(
                    AbortCode.VALUE_TOO_LOW, f"{where}: {value} < {DEFAULT_PAYLOAD_LIMIT_BYTES}"
                )
        if index in (MAP_INDEX_RX, MAP_INDEX_TX):
            self._check_mapping_write(index, subindex, value)
        entry.value = bytes(data)

    def u(self, index: int, subindex: int) -> int:
        """An unsigned entry's value as an int."""
        return int.from_bytes(self.entries[(index, subindex)].value, "little")

    def set_value(self, index: int, subindex: int, data: bytes) -> None:
        """The device's own update of an entry (its application), without access checks."""
        self.entries[(index, subindex)].value = data

    # --- PDO mapping (DS 301 6.4.9) ----------------------------------------------------------
    def _check_mapping_write(self, index: int, subindex: int, value: int) -> None:
        where = f"{index:#06x}/{subindex}"
        enabled = self.u(index, 0)
        if subindex > 0:
            if enabled:  # 6.4.9.2: change entries only while NumberOfEntries is 0
                raise SdoAbortError(AbortCode.DEVICE_STATE, f"{where}: the mapping is enabled")
            return
        if value > MAPPING_ENTRIES:
            raise SdoAbortError(AbortCode.VALUE_TOO_HIGH, f"{where}: {value} > {MAPPING_ENTRIES}")
        entries = [self.u(index, sub) for sub in range(1, value + 1)]
        self.layout(index, entries)  # raises when an entry cannot be mapped

    def layout(self, index: int, raw: list[int] | None = None) -> tuple[Mapped, ...]:
        """The enabled mapping of ``index`` (0x1600 RPDO or 0x1A00 TPDO), checked.

        Raises:
            SdoAbortError: an entry names no object, a non-mappable one, not whole bytes, a
                length past the object, or the PDO grows past its limit (0x1F98/4 RPDO, /5 TPDO).
        """
        if raw is None:
            raw = [self.u(index, sub) for sub in range(1, self.u(index, 0) + 1)]
        out: list[Mapped] = []
        end_bytes = 0
        for entry in raw:
            obj, sub = entry & 0xFFFF, entry >> 16 & 0xFF
            offset_bits, length_bits = entry >> 32 & 0xFFFF, entry >> 48 & 0xFFFF
            target = self._entry(obj, sub)
            if not target.mappable:
                raise SdoAbortError(AbortCode.NOT_MAPPABLE, f"{obj:#06x}/{sub} is not mappable")
            if offset_bits % 8 or length_bits % 8 or not length_bits:
                raise SdoAbortError(
                    AbortCode.PARAMETER_INCOMPATIBLE,
                    f"{obj:#06x}/{sub}: offset {offset_bits}, length {length_bits} bits: this CN "
                    "maps whole bytes only",
                )
            if length_bits > 8 * target.max_bytes:
                raise SdoAbortError(
                    AbortCode.PDO_TOO_LONG,
                    f"{obj:#06x}/{sub}: {length_bits} bits, the object has {8 * target.max_bytes}",
                )
            m = Mapped(obj, sub, offset_bits // 8, length_bits // 8)
            end_bytes = max(end_bytes, m.offset_bytes + m.length_bytes)
            out.append(m)
        limit = self.u(0x1F98, 4 if index == MAP_INDEX_RX else 5)
        if end_bytes > limit:
            raise SdoAbortError(
                AbortCode.PDO_TOO_LONG,
                f"{index:#06x}: {end_bytes} mapped bytes, the payload limit (0x1F98) is {limit}",
            )
        return tuple(out)

    # --- resets (DS 301 7.1.3.2) -------------------------------------------------------------
    def reset_communication(self) -> None:
        """NMT_GS_RESET_COMMUNICATION: the communication profile area (0x1000-0x1FFF) to its
        defaults."""
        for (index, _), entry in self.entries.items():
            if index < 0x2000:
                entry.value = entry.default

    def reset_application(self) -> None:
        """NMT_GS_RESET_APPLICATION: the device profile area (0x6000-0x9FFF) to its defaults,
        then the communication area too (a reset node passes through reset communication)."""
        for (index, _), entry in self.entries.items():
            if 0x6000 <= index < 0xA000:
                entry.value = entry.default
        self.reset_communication()
