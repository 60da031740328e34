"""The CoE object dictionary of a slave described by an ESI file.

The objects are the ESI's ``Profile/Dictionary`` (ETG.2000: ``DataTypes`` and ``Objects``), each
as the SDO server of :mod:`emulator.slave.objects` serves it (ETG.1000.6 5.6.2, 5.6.3):

* a VAR where the object's type is a base type (``UDINT``, ``STRING(11)``, ...); an ARRAY or a
  RECORD where the type lists sub items; a sub item whose type has ``ArrayInfo`` stands for
  that many elements (subindex ``LBound`` on), and makes the object an ARRAY (0x1C00,
  0x1C12, ...); a gap in a record's subindices answers "subindex does not exist" to an SDO
  and is described as an unused entry (data type 0, 0 bits) by SDO information;
* values: ``DefaultValue`` (a number, little-endian in the entry's bytes), ``DefaultData``
  (the bytes), ``DefaultString``; sub items of ``Info`` in order; none: zeros;
* access: ``Flags/Access`` ``ro``/``rw``/``wo`` with ``ReadRestrictions``/``WriteRestrictions``
  (``PreOP``, ``PreOP_SafeOP``, ``SafeOP_OP``, ...; ETG.1000.6 Table 48 bits per state);
  ``PdoMapping`` ``R``/``T``, and every entry the ESI's RxPdo/TxPdo elements map, are mappable;
* the identity 0x1018 holds the ESI's vendor, product code and revision and the SII's serial;
* a modular device's 0xF030/0xF050 (configured/detected module idents, ETG.5001) hold the
  idents of the modules in its slots;
* 0x1C00, the PDO assignments 0x1C10 + n and the PDOs' mapping objects, which a CoE slave
  always has (ETG.1000.6 5.6.7.3, 5.6.7.4), are made when the ESI's dictionary lacks them
  (:func:`skinframes.esi.missing_communication_objects`): 0x1C00 the types of the ESI's Sm
  elements (1 MBoxOut, 2 MBoxIn, 3 Outputs, 4 Inputs, 0 an unused one), read-only; 0x1C10 + n
  with room for every PDO that may be assigned to Sm n (none: subindex 0 alone); a mapping
  object with room for the PDO's entries; filled in below as the ESI's own would be;
* the PDO assignment 0x1C10 + n of each process-data SyncManager n holds the PDOs the ESI
  assigns to it by default (their ``Sm`` attribute; ETG.2000 "default assignment", the SII's
  PdoDefault flag) and the PDO mapping objects the entries of the ESI's RxPdo/TxPdo elements,
  whatever the dictionary's DefaultValues say (SOES's dynpdo lists 8 PDOs, 6 of them 0). A
  master may change them in PRE-OP as far as the ESI allows (:class:`PdoAssignment`,
  :class:`PdoMapping`): an assignment with ``CoE PdoAssign``, of PDOs of the SyncManager's
  direction not assigned to another one, none excluding another (``Exclude``), every
  ``Mandatory`` one kept; a mapping with ``CoE PdoConfig`` of a PDO not ``Fixed``, of mappable
  entries of their own bit length (or index 0: a gap); entries only while subindex 0 is 0.

Input entries (those the TxPdos map) read live: their value is what the application publishes
(:class:`emulator.slave.esi_slave.EsiApplication`: a counter).
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final

from emulator.errors import TopologyError
from emulator.slave.objects import (
    ACCESS_RO,
    ACCESS_RW_PREOP,
    READ_OP,
    READ_PREOP,
    READ_SAFEOP,
    RXPDO_MAPPABLE,
    TXPDO_MAPPABLE,
    WRITE_OP,
    WRITE_PREOP,
    WRITE_SAFEOP,
    Entry,
    ObjectCode,
    ObjectDictionary,
    OdObject,
)
from skinframes.ecat_mailbox import SdoAbort
from skinframes.esi import (
    EsiDataType,
    EsiDevice,
    EsiFile,
    EsiObject,
    EsiObjectSubItem,
    EsiPdo,
    missing_communication_objects,
    parse_number,
)
from skinframes.sii import DATA_TYPE_CODES, ESI_SM_TYPES

__all__ = ["EsiDictionary", "PdoAssignment", "PdoMapping", "esi_dictionary", "pdo_assign_index"]

PDO_ASSIGN_BASE: Final = 0x1C10  # 0x1C10 + n: the PDO assignment of SyncManager n (ETG.1000.6)
IDENTITY: Final = 0x1018
ERROR_REGISTER: Final = 0x1001
DATA_TYPE_PDO_MAPPING: Final = 0x0021  # ETG.1000.6 Table 64
DATA_TYPE_IDENTITY: Final = 0x0023
UNSIGNED8: Final = 0x0005  # ETG.1000.6 Table 63
UNSIGNED16: Final = 0x0006
UNSIGNED32: Final = 0x0007
SM_COMMUNICATION_TYPES: Final = 0x1C00
MODULE_IDENT_LISTS: Final = (0xF030, 0xF050)  # configured / detected module idents (ETG.5001)
MAX_SUBINDEX: Final = 0xFF  # a CoE subindex is one byte (ETG.1000.6 SDO header)
_STRINGS: Final = re.compile(r"^(STRING|OCTET_STRING|UNICODE_STRING)\((\d+)\)$")
_STRING_CODES: Final = {"STRING": 0x09, "OCTET_STRING": 0x0A, "UNICODE_STRING": 0x0B}
_STATE_BITS: Final = {  # ESI restriction words -> (read bit, write bit)
    "preop": (READ_PREOP, WRITE_PREOP),
    "safeop": (READ_SAFEOP, WRITE_SAFEOP),
    "op": (READ_OP, WRITE_OP),
}
_GAP: Final = "\x00gap"  # the name of a subindex a record does not have


def pdo_assign_index(sync_manager: int) -> int:
    """The PDO assignment object of SyncManager ``sync_manager`` (0x1C12 for SM2)."""
    return PDO_ASSIGN_BASE + sync_manager


def _states(restriction: str | None, which: int) -> int:
    """The read (``which`` 0) or write (1) bits of ``restriction`` (None: every state)."""
    words = ["preop", "safeop", "op"] if not restriction else restriction.lower().split("_")
    bits = 0
    for word in words:
        pair = _STATE_BITS.get(word)
        if pair is not None:
            bits |= pair[which]
    return bits


def access_bits(access: str | None, read: str | None = None, write: str | None = None) -> int:
    """ETG.1000.6 Table 48 access bits of an ESI ``Access`` (default ``ro``)."""
    text = (access or "ro").strip().lower()
    return (_states(read, 0) if "r" in text else 0) | (_states(write, 1) if "w" in text else 0)


def _mapping_bits(flag: str | None) -> int:
    text = (flag or "").upper()
    return (RXPDO_MAPPABLE if "R" in text else 0) | (TXPDO_MAPPABLE if "T" in text else 0)


def base_type_code(name: str | None) -> int | None:
    """The CoE data type code of an ESI base type name, or None."""
    if not name:
        return None
    upper = name.strip().upper()
    if upper in DATA_TYPE_CODES:
        return DATA_TYPE_CODES[upper]
    m = _STRINGS.match(upper)
    return _STRING_CODES[m.group(1)] if m else None


def _value(
    bits: int,
    code: int,
    text: str | None,
    data: bytes | None,
    string: str | None,
    where: str,
) -> bytes:
    """An entry's initial bytes from its ESI defaults."""
    size = (bits + 7) // 8
    if string is not None:
        raw = string.encode("utf-8")
        return raw if bits == 0 else raw[:size].ljust(size, b"\x00")
    if data is not None:
        return data if bits == 0 else data[:size].ljust(size, b"\x00")
    if text is None or size == 0:
        return bytes(size)
    if code in _STRING_CODES.values():
        raw = text.encode("utf-8")
        return raw[:size].ljust(size, b"\x00")
    try:
        number = parse_number(text)
    except ValueError:
        raise TopologyError(f"ESI dictionary: {where}: default {text!r} is not a number") from None
    return (number % (1 << (8 * size))).to_bytes(size, "little")


@dataclass(frozen=True, slots=True)
class _Part:
    """One subindex as the data type describes it."""

    subindex: int
    name: str
    code: int
    bits: int
    access: int
    from_array: bool


class EsiDictionary(ObjectDictionary):
    """An ESI device's dictionary; :attr:`assignments` and :attr:`mappings` are the PDO
    objects the application follows (by SyncManager, by PDO index)."""

    def __init__(
        self,
        objects: list[OdObject],
        assignments: dict[int, PdoAssignment],
        mappings: dict[int, PdoMapping],
    ) -> None:
        super().__init__(objects)
        self.assignments = assignments
        self.mappings = mappings

    def entry(self, index: int, subindex: int) -> Entry | int:
        """The entry, or the abort code; a gap in a record's subindices does not exist."""
        e = super().entry(index, subindex)
        if isinstance(e, Entry) and e.name == _GAP:
            return SdoAbort.NO_SUBINDEX
        return e

    def description(self, index: int, subindex: int) -> Entry | int:
        """A gap in a record is described as an unused entry (data type 0, no bits, no
        access), as slave stacks describe the reserved subindices of 0x1C32; uploading it is
        refused (:meth:`entry`)."""
        e = super().entry(index, subindex)
        if isinstance(e, Entry) and e.name == _GAP:
            return Entry("", 0, 0, 0, b"")
        return e

    def assigned(self, sync_manager: int) -> list[int]:
        """The PDOs assigned to ``sync_manager`` now (its 0x1C1n, in order)."""
        a = self.assignments.get(sync_manager)
        return [] if a is None else a.pdos()

    def mapped(self, pdo: int) -> list[tuple[int, int, int]]:
        """(index, subindex, bits) of each entry PDO ``pdo`` maps now."""
        m = self.mappings.get(pdo)
        return [] if m is None else m.entries()


def _while_unused(obj: OdObject, e: Entry) -> Callable[[bytes], int | None]:
    """The writer of entry ``e`` of a PDO assignment or mapping ``obj``: an entry changes only
    while subindex 0 is 0 (ETG.1000.6 5.6.7.4: the object is not in use)."""

    def write(data: bytes) -> int | None:
        if obj.count():
            return SdoAbort.SUBINDEX0_NOT_ZERO
        e.value = bytes(data)
        return None

    return write


def _list_object(
    obj: OdObject,
    values: list[int],
    dtype: int,
    access: int,
    write_count: Callable[[bytes], int | None],
) -> None:
    """Subindex 1 on of a PDO assignment (UNSIGNED16 ``dtype`` 0x0006) or mapping (UNSIGNED32,
    0x0007) ``obj`` hold ``values`` and then 0, each changed only while subindex 0 is 0;
    subindex 0 holds their count and is written through ``write_count``."""
    bits, fmt = (16, "<H") if dtype == 0x0006 else (32, "<I")
    for k in range(1, max(len(values), obj.max_subindex) + 1):
        if k > obj.max_subindex:
            obj.entries.append(Entry(f"SubIndex {k:03d}", dtype, bits, access, b""))
        e = obj.entries[k]
        e.value = struct.pack(fmt, values[k - 1] if k <= len(values) else 0)
        e.access, e.writer, e.reader = access, _while_unused(obj, e), None
    count = obj.entries[0]
    count.value, count.access, count.reader = bytes([len(values)]), access, None
    count.writer = write_count


class PdoAssignment:
    """0x1C10 + n: the PDOs of SyncManager n, writable in PRE-OP as the ESI allows."""

    def __init__(
        self,
        obj: OdObject,
        valid: list[EsiPdo],
        default: list[int],
        *,
        writable: bool,
    ) -> None:
        self.obj = obj
        self.valid = {p.index: p for p in valid}
        self.mandatory = [p.index for p in valid if p.mandatory and p.index in default]
        _list_object(obj, default, 0x0006, _pdo_access(obj, writable), self._write_count)

    def _write_count(self, data: bytes) -> int | None:
        n = data[0]
        if n > self.obj.max_subindex:
            return SdoAbort.VALUE_TOO_HIGH
        pdos = [self._pdo(s) for s in range(1, n + 1)]
        if n and (any(p not in self.valid for p in pdos) or len(set(pdos)) != n):
            return SdoAbort.VALUE_RANGE
        if n and any(m not in pdos for m in self.mandatory):
            return SdoAbort.VALUE_RANGE  # a Mandatory PDO stays assigned (ETG.2000)
        for p in pdos:
            if any(x in pdos for x in self.valid[p].excludes):
                return SdoAbort.INCOMPATIBLE_PARAMETER  # Exclude (ETG.2000)
        self.obj.entries[0].value = bytes(data)
        return None

    def _pdo(self, sub: int) -> int:
        return int(struct.unpack("<H", self.obj.entries[sub].value[:2].ljust(2, b"\0"))[0])

    def pdos(self) -> list[int]:
        """The PDOs assigned now."""
        return [self._pdo(s) for s in range(1, self.obj.count() + 1)]


class PdoMapping:
    """0x1600.../0x1A00...: the entries of one PDO, writable in PRE-OP as the ESI allows."""

    def __init__(
        self,
        obj: OdObject,
        pdo: EsiPdo,
        mappable: Callable[[int, int, int], bool],
        *,
        writable: bool,
    ) -> None:
        self.obj = obj
        self.mappable = mappable
        words = [e.index << 16 | e.subindex << 8 | e.bit_length for e in pdo.entries]
        _list_object(obj, words, 0x0007, _pdo_access(obj, writable), self._write_count)

    def _write_count(self, data: bytes) -> int | None:
        n = data[0]
        if n > self.obj.max_subindex:
            return SdoAbort.VALUE_TOO_HIGH
        for index, sub, bits in self._words(n):
            if index and not self.mappable(index, sub, bits):
                return SdoAbort.NOT_MAPPABLE
        self.obj.entries[0].value = bytes(data)
        return None

    def _words(self, n: int) -> list[tuple[int, int, int]]:
        out = []
        for s in range(1, n + 1):
            (word,) = struct.unpack("<I", self.obj.entries[s].value[:4].ljust(4, b"\0"))
            out.append((word >> 16, word >> 8 & 0xFF, word & 0xFF))
        return out

    def entries(self) -> list[tuple[int, int, int]]:
        """(index, subindex, bits) of each entry mapped now."""
        return self._words(self.obj.count())


_WRITES: Final = WRITE_PREOP | WRITE_SAFEOP | WRITE_OP


def _pdo_access(obj: OdObject, writable: bool) -> int:
    """A PDO object's access: the ESI's, written in PRE-OP only (ETG.1000.6 5.6.2: PDO
    assignment and mapping change in PRE-OP), and not at all unless the ESI allows it."""
    access = obj.entries[0].access & ~(WRITE_SAFEOP | WRITE_OP)
    return access if writable else access & ~_WRITES


class _Builder:
    """Turns the ESI's objects into :class:`OdObject`; errors name the object."""

    def __init__(self, device: EsiDevice) -> None:
        types = () if device.dictionary is None else device.dictionary.data_types
        self.types = {t.name: t for t in types}
        self.rx_entries = {(e.index, e.subindex) for p in device.rx_pdos for e in p.entries}
        self.tx_entries = {(e.index, e.subindex) for p in device.tx_pdos for e in p.entries}

    def code_of(self, name: str) -> int:
        code = base_type_code(name)
        if code is not None:
            return code
        t = self.types.get(name)
        if t is not None and t.base_type and not t.sub_items:
            return self.code_of(t.base_type)
        return 0

    def parts(self, o: EsiObject, t: EsiDataType) -> tuple[list[_Part], bool]:
        """The subindices of a record/array type, and whether an array made them.

        A SubItem of an array type without ``SubIdx`` is the array's elements, one subindex
        each (how ESI writes ARRAY objects such as 0x1C12); with a ``SubIdx`` it is one entry
        holding the whole array (an Ingenia drive's 0x58B2:1, ``ARRAY [0..511] OF BYTE``).
        """
        parts: list[_Part] = []
        array = False
        next_sub = 0
        for s in t.sub_items:
            access = access_bits(s.access, s.read_restrictions, s.write_restrictions)
            access |= _mapping_bits(s.pdo_mapping)
            inner = self.types.get(s.type_name)
            if (
                inner is not None
                and inner.array_elements
                and not inner.sub_items
                and s.subindex is None
            ):
                array = True
                n = inner.array_elements
                sub0 = inner.array_lower_bound if inner.array_lower_bound is not None else 1
                bits = s.bit_size // n if n else 0
                code = self.code_of(inner.base_type or "")
                for k in range(n):
                    parts.append(_Part(sub0 + k, f"{s.name} {sub0 + k}", code, bits, access, True))
                next_sub = sub0 + n
                continue
            sub = s.subindex if s.subindex is not None else next_sub
            parts.append(_Part(sub, s.name, self.code_of(s.type_name), s.bit_size, access, False))
            next_sub = sub + 1
        if t.array_elements and not t.sub_items:  # the object's type itself is an array
            array = True
            n = t.array_elements
            sub0 = t.array_lower_bound if t.array_lower_bound is not None else 1
            parts.append(_Part(0, "SubIndex 000", 0x0005, 8, access_bits(o.access), False))
            bits = t.bit_size // n if n else 0
            for k in range(n):
                parts.append(
                    _Part(
                        sub0 + k,
                        f"SubIndex {sub0 + k:03d}",
                        self.code_of(t.base_type or ""),
                        bits,
                        access_bits(o.access, o.read_restrictions, o.write_restrictions),
                        True,
                    )
                )
        return parts, array

    def mappable_bits(self, index: int, sub: int) -> int:
        return (RXPDO_MAPPABLE if (index, sub) in self.rx_entries else 0) | (
            TXPDO_MAPPABLE if (index, sub) in self.tx_entries else 0
        )

    def build(self, o: EsiObject) -> OdObject:
        where = f"object {o.index:#06x}"
        t = self.types.get(o.type_name)
        if t is None or (not t.sub_items and not t.array_elements):
            code = self.code_of(o.type_name)
            access = access_bits(o.access, o.read_restrictions, o.write_restrictions)
            access |= _mapping_bits(o.pdo_mapping) | self.mappable_bits(o.index, 0)
            value = _value(
                o.bit_size, code, o.default_value, o.default_data, o.default_string, where
            )
            bits = o.bit_size or 8 * len(value)
            entry = Entry(o.name, code, bits, access, value)
            return OdObject(o.index, o.name, ObjectCode.VAR, code, [entry])
        parts, array = self.parts(o, t)
        if not parts or parts[0].subindex != 0:
            raise TopologyError(f"ESI dictionary: {where}: its type {t.name} has no subindex 0")
        top = max(p.subindex for p in parts)
        if top > MAX_SUBINDEX:
            raise TopologyError(
                f"ESI dictionary: {where}: subindex {top} (type {t.name}); CoE subindices are "
                f"0..{MAX_SUBINDEX}"
            )
        by_sub = {p.subindex: p for p in parts}
        infos = list(o.sub_items)
        entries: list[Entry] = []
        for sub in range(top + 1):
            part = by_sub.get(sub)
            if part is None:
                entries.append(Entry(_GAP, 0, 0, 0, b""))
                continue
            info = _info_for(infos, len(parts), parts.index(part), part.name)
            value = _value(
                part.bits,
                part.code,
                None if info is None else info.default_value,
                None if info is None else info.default_data,
                None if info is None else info.default_string,
                f"{where}:{sub}",
            )
            access = part.access | self.mappable_bits(o.index, sub)
            label = info.name if info is not None and info.name else part.name
            entries.append(Entry(label, part.code, part.bits or 8 * len(value), access, value))
        code = ObjectCode.ARRAY if array else ObjectCode.RECORD
        data_type = next((p.code for p in parts if p.from_array), 0) if array else 0
        if o.index == IDENTITY:
            data_type = DATA_TYPE_IDENTITY
        elif 0x1600 <= o.index <= 0x1BFF:
            data_type = DATA_TYPE_PDO_MAPPING
        return OdObject(o.index, o.name, code, data_type, entries)


def _communication_object(device: EsiDevice, index: int) -> OdObject:
    """0x1C00, 0x1C10 + n or a PDO's mapping object made from the ESI's Sm elements and PDOs,
    where its dictionary lacks them (ETG.1000.6 5.6.7.3, 5.6.7.4): the communication types
    (read-only), an assignment with one subindex for each PDO that may be assigned to
    SyncManager n, or a mapping with one for each of the PDO's entries (:class:`PdoAssignment`
    and :class:`PdoMapping` fill them in)."""
    if index == SM_COMMUNICATION_TYPES:
        types = [int(ESI_SM_TYPES[sm.kind]) for sm in device.sync_managers]
        obj = OdObject(index, "Sync manager type", ObjectCode.ARRAY, UNSIGNED8)
        obj.entries.append(Entry("SubIndex 000", UNSIGNED8, 8, ACCESS_RO, bytes([len(types)])))
        for k, t in enumerate(types, start=1):
            obj.entries.append(Entry(f"SubIndex {k:03d}", UNSIGNED8, 8, ACCESS_RO, bytes([t])))
        return obj
    pdo = next((p for p in device.rx_pdos + device.tx_pdos if p.index == index), None)
    if pdo is not None:
        obj = OdObject(index, pdo.name, ObjectCode.RECORD, DATA_TYPE_PDO_MAPPING)
        room, data_type, bits = len(pdo.entries), UNSIGNED32, 32
    else:
        n = index - PDO_ASSIGN_BASE
        kind = device.sync_managers[n].kind
        pdos = device.rx_pdos if kind == "Outputs" else device.tx_pdos
        name = f"{'RxPDO' if kind == 'Outputs' else 'TxPDO'} assign"
        obj = OdObject(index, name, ObjectCode.ARRAY, UNSIGNED16)
        room = sum(1 for p in pdos if p.sync_manager in (None, n))
        data_type, bits = UNSIGNED16, 16
    obj.entries.append(Entry("SubIndex 000", UNSIGNED8, 8, ACCESS_RW_PREOP, b"\x00"))
    for k in range(1, room + 1):
        obj.entries.append(
            Entry(f"SubIndex {k:03d}", data_type, bits, ACCESS_RW_PREOP, bytes(bits // 8))
        )
    return obj


def _module_idents(obj: OdObject | None, idents: tuple[int, ...]) -> None:
    """0xF030/0xF050 of a modular device (ETG.5001): subindex 0 the number of modules in its
    slots, subindex k the ident of module k (UDINT); left as the ESI has it without modules.

    Raises:
        TopologyError: the object has fewer subindices than there are modules.
    """
    if obj is None or not idents or obj.code == ObjectCode.VAR:
        return
    if obj.max_subindex < len(idents):
        raise TopologyError(
            f"ESI dictionary: object {obj.index:#06x} has room for {obj.max_subindex} module "
            f"idents, {len(idents)} modules are in the slots"
        )
    obj.entries[0].value = bytes([len(idents)]).ljust(len(obj.entries[0].value), b"\0")
    for k, ident in enumerate(idents, start=1):
        obj.entries[k].value = struct.pack("<I", ident)


def _info_for(
    infos: list[EsiObjectSubItem], parts: int, position: int, name: str
) -> EsiObjectSubItem | None:
    """The object's ``Info/SubItem`` for a subindex: by position when the object lists one per
    subindex, else the first of that name."""
    if len(infos) == parts:
        return infos[position]
    return next((i for i in infos if i.name == name), None)


def _live(
    input_value: Callable[[int, int, int], bytes], index: int, subindex: int, bits: int
) -> Callable[[], bytes]:
    return lambda: input_value(index, subindex, bits)


def esi_dictionary(
    esi: EsiFile,
    device: EsiDevice,
    *,
    serial: int,
    input_value: Callable[[int, int, int], bytes],
) -> EsiDictionary:
    """The dictionary of ``device``; ``input_value(index, subindex, bits)`` is an input
    entry's value now (the TxPdos' entries read it live). See the module docstring.

    Raises:
        TopologyError: a default that is no number, a record type without subindex 0.
    """
    builder = _Builder(device)
    esi_objects = () if device.dictionary is None else device.dictionary.objects
    objects = {o.index: builder.build(o) for o in esi_objects}
    for index in missing_communication_objects(device):
        objects[index] = _communication_object(device, index)
    for list_index in MODULE_IDENT_LISTS:
        _module_idents(objects.get(list_index), device.configured_modules)
    identity = objects.get(IDENTITY)
    if identity is not None:
        values = (esi.vendor.vendor_id, device.product_code, device.revision, serial)
        for sub, value in enumerate(values, start=1):
            if sub <= identity.max_subindex:
                identity.entries[sub].value = struct.pack("<I", value)
    for obj in objects.values():
        for sub, e in enumerate(obj.entries):
            key = (obj.index, sub if obj.code != ObjectCode.VAR else 0)
            if key in builder.tx_entries and e.bit_length:
                index, subindex, bits = obj.index, key[1], e.bit_length
                e.reader = _live(input_value, index, subindex, bits)
    coe = device.mailbox.coe if device.mailbox is not None else None
    can_assign = coe is not None and coe.pdo_assign
    can_config = coe is not None and coe.pdo_config

    def mappable(index: int, sub: int, bits: int, tx: bool) -> bool:
        obj = objects.get(index)
        if obj is None or sub > obj.max_subindex or obj.entries[sub].name == _GAP:
            return False
        e = obj.entries[sub]
        return bool(e.access & (TXPDO_MAPPABLE if tx else RXPDO_MAPPABLE)) and e.bit_length == bits

    mappings: dict[int, PdoMapping] = {}
    for tx, pdos in ((False, device.rx_pdos), (True, device.tx_pdos)):
        for pdo in pdos:
            mapping = objects.get(pdo.index)
            if mapping is None or mapping.code == ObjectCode.VAR:
                continue
            mappings[pdo.index] = PdoMapping(
                mapping,
                pdo,
                lambda i, s, b, tx=tx: mappable(i, s, b, tx),  # type: ignore[misc]
                writable=can_config and not pdo.fixed,
            )
    assignments: dict[int, PdoAssignment] = {}
    kinds = {"Outputs": device.rx_pdos, "Inputs": device.tx_pdos}
    for n, sm in enumerate(device.sync_managers):
        assign = objects.get(pdo_assign_index(n))
        if sm.kind not in kinds or assign is None or assign.code == ObjectCode.VAR:
            continue
        valid = [p for p in kinds[sm.kind] if p.sync_manager in (None, n)]
        default = [p.index for p in valid if p.sync_manager == n]
        assignments[n] = PdoAssignment(assign, valid, default, writable=can_assign)
    return EsiDictionary(list(objects.values()), assignments, mappings)
