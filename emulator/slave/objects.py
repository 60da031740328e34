"""The CoE object dictionary of an emulated skin patch (ETG.1000.6 5.6, CiA 301 7.4, ETG.5001).

Objects and the index areas they live in:

* communication area: 0x1000 device type, 0x1001 error register, 0x1008 device name, 0x1009
  hardware version, 0x100A software version, 0x1018 identity (vendor, product, revision,
  serial: the SII's words 8-15), 0x1C00 SyncManager communication types (1 mailbox out,
  2 mailbox in, 3 outputs, 4 inputs), 0x1C12/0x1C13 the PDO assignment of SM2/SM3;
* PDO mapping: 0x1A00 + t, the TxPDO of triangle t, mapping 0x6000 + t:1..12 (8 bits each);
  0x1600 the RxPDO of the outputs when the patch has any;
* ETG.5001's areas: 0x6000 + t the taxels of triangle t (inputs), 0x7000 the outputs,
  0x8000 the patch's settings (sampling period, contact threshold).

One TxPDO per triangle, not one for the whole patch: a triangle is the unit a skin is built and
wired from (its own 12-taxel sensor chip, paper II-A), so it is also the unit a master wants to
leave out (a damaged triangle, a region that does not need the rate). With one PDO per triangle a
master selects triangles by PDO *assignment* (0x1C13, a list of PDO numbers, writable in PRE-OP),
which every CoE master supports, instead of PDO *mapping* reconfiguration, which many do not; and
each mapping stays small (12 entries), so a complete-access read of it fits one mailbox.

Access rights are the entry-description bits of ETG.1000.6 Table 48 (read/write per state,
RxPDO/TxPDO mappable). A value is bytes, little-endian, as it travels in an SDO.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Final

from emulator.slave.sii import DataType, SlaveInfo
from skinframes import __version__
from skinframes.ecat_mailbox import SdoAbort

__all__ = [
    "ACCESS_RO",
    "ACCESS_RW",
    "ACCESS_RW_PREOP",
    "CONTACT_THRESHOLD_DEFAULT",
    "SAMPLING_PERIOD_DEFAULT_US",
    "Entry",
    "ObjectCode",
    "ObjectDictionary",
    "OdObject",
    "SkinDictionary",
    "skin_dictionary",
]

# entry access bits (ETG.1000.6 Table 48, "ObjAccess")
READ_PREOP: Final = 0x0001
READ_SAFEOP: Final = 0x0002
READ_OP: Final = 0x0004
WRITE_PREOP: Final = 0x0008
WRITE_SAFEOP: Final = 0x0010
WRITE_OP: Final = 0x0020
RXPDO_MAPPABLE: Final = 0x0040
TXPDO_MAPPABLE: Final = 0x0080
ACCESS_RO: Final = READ_PREOP | READ_SAFEOP | READ_OP
ACCESS_RW: Final = ACCESS_RO | WRITE_PREOP | WRITE_SAFEOP | WRITE_OP
ACCESS_RW_PREOP: Final = ACCESS_RO | WRITE_PREOP
_PREOP, _SAFEOP, _OP = 0x2, 0x4, 0x8  # AL states (datasheet I Table 41; state_machine.AlState)
_READ_BIT: Final = {_PREOP: READ_PREOP, _SAFEOP: READ_SAFEOP, _OP: READ_OP}
_WRITE_BIT: Final = {_PREOP: WRITE_PREOP, _SAFEOP: WRITE_SAFEOP, _OP: WRITE_OP}

DEVICE_TYPE: Final = 0x00000000  # no CiA/ETG device profile is claimed (CiA 301 7.5.2.1)
SAMPLING_PERIOD_DEFAULT_US: Final = 1000  # serve's default --period-ms 1
SAMPLING_PERIOD_RANGE_US: Final = (100, 1_000_000)
CONTACT_THRESHOLD_DEFAULT: Final = 16  # raw 8-bit taxel units


class ObjectCode(IntEnum):
    """Object code of an object description (ETG.1000.6 Table 46)."""

    VAR = 0x07
    ARRAY = 0x08
    RECORD = 0x09


Reader = Callable[[], bytes]
Writer = Callable[[bytes], int | None]  # returns an abort code, or None when accepted


@dataclass(slots=True)
class Entry:
    """One subindex: description, access rights and the value (stored, or read live)."""

    name: str
    data_type: int
    bit_length: int
    access: int
    value: bytes = b""
    reader: Reader | None = None
    writer: Writer | None = None  # checks and applies a write; default: store the bytes

    def get(self) -> bytes:
        """The current value."""
        return self.reader() if self.reader is not None else self.value


@dataclass(slots=True)
class OdObject:
    """One object: a VAR (subindex 0 is the value) or an ARRAY/RECORD (subindex 0 = count)."""

    index: int
    name: str
    code: ObjectCode
    data_type: int
    entries: list[Entry] = field(default_factory=list)

    @property
    def max_subindex(self) -> int:
        """Highest subindex (0 for a VAR)."""
        return len(self.entries) - 1

    def count(self) -> int:
        """Subindex 0 of an ARRAY/RECORD: the entries in use."""
        return self.entries[0].get()[0]


def _u8(v: int) -> bytes:
    return struct.pack("<B", v)


def _u16(v: int) -> bytes:
    return struct.pack("<H", v)


def _u32(v: int) -> bytes:
    return struct.pack("<I", v)


class ObjectDictionary:
    """Objects by index, with the access rules of an SDO server (ETG.1000.6 5.6.2).

    ``error_register`` is the value of 0x1001 (CiA 301 7.5.2.2) the application keeps.
    """

    error_register: int = 0

    def __init__(self, objects: list[OdObject]) -> None:
        self.objects = {o.index: o for o in sorted(objects, key=lambda o: o.index)}

    def __contains__(self, index: int) -> bool:
        return index in self.objects

    def indices(self) -> list[int]:
        """Every index, ascending (the SDO information object list)."""
        return list(self.objects)

    def entry(self, index: int, subindex: int) -> Entry | int:
        """The entry, or the abort code for a missing object or subindex."""
        obj = self.objects.get(index)
        if obj is None:
            return SdoAbort.NO_OBJECT
        if subindex > obj.max_subindex:
            return SdoAbort.NO_SUBINDEX
        return obj.entries[subindex]

    def description(self, index: int, subindex: int) -> Entry | int:
        """The entry an SDO information entry description shows (ETG.1000.6 5.6.3.6), or the
        abort code: :meth:`entry` unless a subclass describes more."""
        return self.entry(index, subindex)

    # --- single subindex ----------------------------------------------------------------------
    def read(self, index: int, subindex: int, state: int) -> bytes | int:
        """Upload one entry: its bytes, or an abort code."""
        e = self.entry(index, subindex)
        if isinstance(e, int):
            return e
        if not e.access & _READ_BIT.get(state, 0):
            return SdoAbort.WRITE_ONLY if e.access & ACCESS_RO == 0 else SdoAbort.DEVICE_STATE
        return e.get()

    def write(self, index: int, subindex: int, data: bytes, state: int) -> int | None:
        """Download one entry; None when accepted, else the abort code."""
        e = self.entry(index, subindex)
        if isinstance(e, int):
            return e
        allowed = e.access & _WRITE_BIT.get(state, 0)
        if not allowed:
            writable = e.access & (WRITE_PREOP | WRITE_SAFEOP | WRITE_OP)
            return SdoAbort.DEVICE_STATE if writable else SdoAbort.READ_ONLY
        if e.data_type != DataType.VISIBLE_STRING and len(data) != e.bit_length // 8:
            return SdoAbort.LENGTH_MISMATCH
        if e.writer is not None:
            return e.writer(data)
        e.value = bytes(data)
        return None

    # --- complete access (ETG.1000.6 5.6.2.1.2: all subindices in one transfer) --------------
    def read_complete(self, index: int, subindex: int, state: int) -> bytes | int:
        """Upload subindex 0 (as 16 bits: the count and a padding byte) or 1 onwards, then every
        entry in use."""
        obj = self.objects.get(index)
        if obj is None:
            return SdoAbort.NO_OBJECT
        if obj.code == ObjectCode.VAR or subindex > 1:
            return SdoAbort.COMPLETE_ACCESS_UNSUPPORTED
        out = bytearray()
        if subindex == 0:
            head = self.read(index, 0, state)
            if isinstance(head, int):
                return head
            out += head + b"\x00"
        for sub in range(1, obj.count() + 1):
            value = self.read(index, sub, state)
            if isinstance(value, int):
                return value
            out += value
        return bytes(out)

    def write_complete(self, index: int, subindex: int, data: bytes, state: int) -> int | None:
        """Download subindex 0 (16 bits) and the entries it counts, or entries 1.. in place."""
        obj = self.objects.get(index)
        if obj is None:
            return SdoAbort.NO_OBJECT
        if obj.code == ObjectCode.VAR or subindex > 1:
            return SdoAbort.COMPLETE_ACCESS_UNSUPPORTED
        pos, count = 0, obj.count()
        if subindex == 0:
            if len(data) < 2:
                return SdoAbort.LENGTH_MISMATCH
            count, pos = data[0], 2
        if count > obj.max_subindex:
            return SdoAbort.VALUE_TOO_HIGH
        sizes = [obj.entries[s].bit_length // 8 for s in range(1, count + 1)]
        if len(data) - pos != sum(sizes):
            return SdoAbort.LENGTH_MISMATCH
        if subindex == 0:  # entries may only change while subindex 0 is 0 (ETG.1000.6 5.6.2)
            code = self.write(index, 0, b"\x00", state)
            if code is not None:
                return code
        for sub, size in enumerate(sizes, start=1):
            code = self.write(index, sub, data[pos : pos + size], state)
            if code is not None:
                return code
            pos += size
        if subindex == 0:
            return self.write(index, 0, bytes([count]), state)
        return None


# --- the skin patch's dictionary ------------------------------------------------------------------
def _var(index: int, name: str, dtype: int, bits: int, access: int, value: bytes) -> OdObject:
    return OdObject(index, name, ObjectCode.VAR, dtype, [Entry(name, dtype, bits, access, value)])


def _string(index: int, name: str, text: str) -> OdObject:
    raw = text.encode("ascii")
    return _var(index, name, DataType.VISIBLE_STRING, 8 * len(raw), ACCESS_RO, raw)


def _count(n: int, access: int = ACCESS_RO) -> Entry:
    return Entry("SubIndex 000", DataType.UNSIGNED8, 8, access, _u8(n))


class _Assignment:
    """0x1C12/0x1C13: PDO numbers, writable in PRE-OP, entries only while subindex 0 is 0."""

    def __init__(self, index: int, name: str, pdos: list[int], valid: set[int]) -> None:
        self.valid = valid
        self.obj = OdObject(index, name, ObjectCode.ARRAY, DataType.UNSIGNED16)
        self.obj.entries.append(
            Entry("SubIndex 000", DataType.UNSIGNED8, 8, ACCESS_RW_PREOP, _u8(len(pdos)))
        )
        self.obj.entries[0].writer = self._write_count
        for k in range(max(len(valid), 1)):
            value = pdos[k] if k < len(pdos) else 0
            e = Entry(
                f"SubIndex {k + 1:03d}", DataType.UNSIGNED16, 16, ACCESS_RW_PREOP, _u16(value)
            )
            e.writer = self._writer(e)
            self.obj.entries.append(e)

    def _write_count(self, data: bytes) -> int | None:
        n = data[0]
        if n > self.obj.max_subindex:
            return SdoAbort.VALUE_TOO_HIGH
        if any(self._pdo(s) not in self.valid for s in range(1, n + 1)):
            return SdoAbort.VALUE_RANGE
        self.obj.entries[0].value = bytes(data)
        return None

    def _writer(self, e: Entry) -> Writer:
        def write(data: bytes) -> int | None:
            if self.obj.count():
                return SdoAbort.SUBINDEX0_NOT_ZERO
            (pdo,) = struct.unpack("<H", data)
            if pdo not in self.valid:
                return SdoAbort.VALUE_RANGE
            e.value = bytes(data)
            return None

        return write

    def _pdo(self, sub: int) -> int:
        return int(struct.unpack("<H", self.obj.entries[sub].value)[0])

    def pdos(self) -> list[int]:
        """The PDOs assigned (subindices 1 to the count, UNSIGNED16 each)."""
        entries = self.obj.entries
        return [int.from_bytes(e.value, "little") for e in entries[1 : entries[0].get()[0] + 1]]


class SkinDictionary(ObjectDictionary):
    """The skin patch's dictionary and the state behind it (see the module docstring)."""

    def __init__(
        self,
        info: SlaveInfo,
        inputs: Reader,
        outputs: Reader,
        *,
        sampling_period_us: int = SAMPLING_PERIOD_DEFAULT_US,
    ) -> None:
        self.info = info
        self.error_register = 0
        objects: list[OdObject] = [
            _var(0x1000, "Device type", DataType.UNSIGNED32, 32, ACCESS_RO, _u32(DEVICE_TYPE)),
            OdObject(
                0x1001,
                "Error register",
                ObjectCode.VAR,
                DataType.UNSIGNED8,
                [
                    Entry(
                        "Error register",
                        DataType.UNSIGNED8,
                        8,
                        ACCESS_RO,
                        reader=lambda: _u8(self.error_register),
                    )
                ],
            ),
            _string(0x1008, "Device name", info.name),
            _string(0x1009, "Hardware version", "emulated ESC"),
            _string(0x100A, "Software version", f"skinframes {__version__}"),
        ]
        identity = OdObject(0x1018, "Identity", ObjectCode.RECORD, DataType.IDENTITY, [_count(4)])
        for name, value in (
            ("Vendor ID", info.vendor_id),
            ("Product code", info.product_code),
            ("Revision", info.revision),
            ("Serial number", info.serial),
        ):
            identity.entries.append(Entry(name, DataType.UNSIGNED32, 32, ACCESS_RO, _u32(value)))
        objects.append(identity)
        types = OdObject(0x1C00, "Sync manager type", ObjectCode.ARRAY, DataType.UNSIGNED8)
        types.entries.append(_count(len(info.sync_managers)))
        for k, sm in enumerate(info.sync_managers):
            types.entries.append(
                Entry(f"SubIndex {k + 1:03d}", DataType.UNSIGNED8, 8, ACCESS_RO, _u8(sm.type))
            )
        objects.append(types)
        for pdo in info.tx_pdos + info.rx_pdos:
            mapping = OdObject(pdo.index, pdo.name, ObjectCode.RECORD, DataType.PDO_MAPPING)
            mapping.entries.append(_count(len(pdo.entries)))
            for k, e in enumerate(pdo.entries):
                word = e.index << 16 | e.subindex << 8 | e.bit_length
                mapping.entries.append(
                    Entry(f"SubIndex {k + 1:03d}", DataType.UNSIGNED32, 32, ACCESS_RO, _u32(word))
                )
            objects.append(mapping)
        self.rx_assign = _Assignment(
            0x1C12, "RxPDO assign", [p.index for p in info.rx_pdos], {p.index for p in info.rx_pdos}
        )
        self.tx_assign = _Assignment(
            0x1C13, "TxPDO assign", [p.index for p in info.tx_pdos], {p.index for p in info.tx_pdos}
        )
        objects += [self.rx_assign.obj, self.tx_assign.obj]
        objects += self._data_objects(info, inputs, 0x6000, "Taxels", TXPDO_MAPPABLE, tx=True)
        objects += self._data_objects(info, outputs, 0x7000, "Outputs", RXPDO_MAPPABLE, tx=False)
        self.sampling_period_us = sampling_period_us
        self.contact_threshold = CONTACT_THRESHOLD_DEFAULT
        settings = OdObject(0x8000, "Skin settings", ObjectCode.RECORD, DataType.UNSIGNED8)
        settings.entries += [
            _count(2),
            Entry(
                "Sampling period us",
                DataType.UNSIGNED32,
                32,
                ACCESS_RW_PREOP,
                reader=lambda: _u32(self.sampling_period_us),
                writer=self._write_period,
            ),
            Entry(
                "Contact threshold",
                DataType.UNSIGNED8,
                8,
                ACCESS_RW,
                reader=lambda: _u8(self.contact_threshold),
                writer=self._write_threshold,
            ),
        ]
        objects.append(settings)
        super().__init__(objects)

    @staticmethod
    def _data_objects(
        info: SlaveInfo, image: Reader, base: int, label: str, mappable: int, *, tx: bool
    ) -> list[OdObject]:
        """One ARRAY of UNSIGNED8 per object the PDOs map (0x6000 + t, or 0x7000)."""
        subs: dict[int, int] = {}
        for pdo in info.tx_pdos if tx else info.rx_pdos:
            for e in pdo.entries:
                subs[e.index] = max(subs.get(e.index, 0), e.subindex)
        out: list[OdObject] = []
        offset = 0
        for index in sorted(subs):
            n = subs[index]
            name = f"{label} {index - base}" if tx else label
            obj = OdObject(index, name, ObjectCode.ARRAY, DataType.UNSIGNED8, [_count(n)])
            for k in range(n):
                at = offset + k
                obj.entries.append(
                    Entry(
                        f"SubIndex {k + 1:03d}",
                        DataType.UNSIGNED8,
                        8,
                        ACCESS_RO | mappable,
                        reader=lambda at=at: image()[at : at + 1],  # type: ignore[misc]
                    )
                )
            offset += n
            out.append(obj)
        return out

    def _write_period(self, data: bytes) -> int | None:
        (value,) = struct.unpack("<I", data)
        lo, hi = SAMPLING_PERIOD_RANGE_US
        if value < lo:
            return SdoAbort.VALUE_TOO_LOW
        if value > hi:
            return SdoAbort.VALUE_TOO_HIGH
        self.sampling_period_us = value
        return None

    def _write_threshold(self, data: bytes) -> int | None:
        self.contact_threshold = data[0]
        return None

    def tx_pdos(self) -> list[int]:
        """The TxPDOs assigned to the input SyncManager (0x1C13), in order."""
        return self.tx_assign.pdos()

    def rx_pdos(self) -> list[int]:
        """The RxPDOs assigned to the output SyncManager (0x1C12), in order."""
        return self.rx_assign.pdos()


def skin_dictionary(info: SlaveInfo, inputs: Reader, outputs: Reader) -> SkinDictionary:
    """The dictionary of a skin patch described by ``info``; taxels and outputs read live."""
    return SkinDictionary(info, inputs, outputs)
