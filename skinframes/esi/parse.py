"""Read EtherCAT Slave Information (ESI) files: the vendor's XML description of its devices.

Layout: ETG.2000 (EtherCAT Slave Information Specification) and its schema EtherCATInfo.xsd:
``EtherCATInfo/Vendor`` (Id, Name), ``Descriptions/Groups`` and ``Descriptions/Devices/Device``,
one or several. Each device carries its identity (``Type`` with ``ProductCode`` and
``RevisionNo``), names per language (``Name LcId``), FMMUs, SyncManagers (``Sm``), PDOs
(``RxPdo``/``TxPdo``), the mailbox protocols, distributed-clock op modes (``Dc/OpMode``), the
EEPROM (``Eeprom``: ByteSize, ConfigData, BootStrap, Category) and, under ``Profile``, the CoE
object dictionary (``Dictionary``: DataTypes and Objects). A modular device (ETG.2000
``Device/Slots``; ETG.5001 Modular Device Profile) names the modules each slot may hold, by
``ModuleIdent`` or ``ModuleClass``; the modules themselves (``Descriptions/Modules/Module``:
identity, PDOs, objects) are listed once for the whole file.

Numbers are written as in ESI: decimal (``128``) or hexadecimal with the prefix ``#x``
(``#x1000``); booleans as ``1``/``0`` or ``true``/``false``; binary data (ConfigData,
BootStrap, DefaultData) as hex digits, byte by byte in EEPROM order.

The reader is expat with line numbers recorded on every element, so that anything it cannot use
raises :class:`~skinframes.errors.EsiFormatError` naming the element and its line. Elements it
does not model (vendor specials, images) are skipped without a word.
"""

from __future__ import annotations

import dataclasses
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Final
from xml.parsers import expat

from skinframes.errors import EsiFormatError

__all__ = [
    "FMMU_KINDS",
    "SM_KINDS",
    "EsiAlternativeSmMapping",
    "EsiCoe",
    "EsiDataType",
    "EsiDataTypeSubItem",
    "EsiDcOpMode",
    "EsiDevice",
    "EsiDictionary",
    "EsiEeprom",
    "EsiEepromCategory",
    "EsiFile",
    "EsiFmmu",
    "EsiMailbox",
    "EsiModule",
    "EsiObject",
    "EsiObjectSubItem",
    "EsiPdo",
    "EsiPdoEntry",
    "EsiSlot",
    "EsiSlots",
    "EsiSyncManager",
    "EsiVendor",
    "configure_slots",
    "missing_communication_objects",
    "parse_esi",
    "parse_number",
    "read_esi",
]

ENGLISH_LCID: Final = 1033  # the language whose Name is the device's name, when present
SM_KINDS: Final = ("MBoxOut", "MBoxIn", "Outputs", "Inputs")  # ETG.2000 SmType text
SM_COMMUNICATION_TYPES: Final = 0x1C00  # ETG.1000.6 5.6.7.4: one type a SyncManager
PDO_ASSIGNMENT_BASE: Final = 0x1C10  # + n: the PDO assignment of SyncManager n
FMMU_KINDS: Final = ("Outputs", "Inputs", "MBoxState")  # ETG.2000 FmmuType text


class _Element(ET.Element):
    """An ElementTree element that remembers the line it starts on."""

    __slots__ = ("line",)
    line: int


# --- the model ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class EsiVendor:
    """``Vendor``: the ETG-assigned vendor id and the vendor's name."""

    vendor_id: int
    name: str


@dataclass(frozen=True, slots=True)
class EsiSyncManager:
    """``Sm``: one SyncManager as the device expects it configured (ETG.2000, SmType).

    ``kind`` is the element's text (one of :data:`SM_KINDS`, or ``""`` for an unused one);
    ``default_size_bytes`` is None where the ESI gives no DefaultSize.
    """

    start_address: int
    default_size_bytes: int | None
    control_byte: int
    enable: int
    kind: str


@dataclass(frozen=True, slots=True)
class EsiFmmu:
    """``Fmmu``: what one FMMU is for (:data:`FMMU_KINDS`, or ``""``), and its Sm if given."""

    kind: str
    sync_manager: int | None = None


@dataclass(frozen=True, slots=True)
class EsiPdoEntry:
    """``Entry`` of a PDO: the mapped object (index 0: padding), its width and type name.

    ``depend_on_slot``: the ``Index`` attribute ``DependOnSlot`` (a module's entry: the index
    is a base, moved by the slot's SlotIndexIncrement; ETG.2000 ModuleType).
    """

    index: int
    subindex: int
    bit_length: int
    name: str
    data_type: str
    depend_on_slot: bool = False


@dataclass(frozen=True, slots=True)
class EsiPdo:
    """``RxPdo``/``TxPdo`` (ETG.2000, PdoType).

    ``sync_manager`` is the Sm it is assigned to by default (None: not assigned);
    ``excludes`` the PDOs that cannot be assigned beside it (``Exclude``);
    ``depend_on_slot`` the ``Index`` attribute ``DependOnSlot`` (a module's PDO: the index is
    a base, moved by the slot's SlotPdoIncrement), ``excludes_depend_on_slot`` that of each
    ``Exclude``.
    """

    index: int
    name: str
    entries: tuple[EsiPdoEntry, ...]
    sync_manager: int | None = None
    mandatory: bool = False
    fixed: bool = False
    excludes: tuple[int, ...] = ()
    depend_on_slot: bool = False
    excludes_depend_on_slot: tuple[bool, ...] = ()

    @property
    def bit_length(self) -> int:
        """Sum of the entries' bit lengths."""
        return sum(e.bit_length for e in self.entries)


@dataclass(frozen=True, slots=True)
class EsiAlternativeSmMapping:
    """``AlternativeSmMapping``: another assignment of PDOs to SyncManagers.

    ``assignments`` holds (Sm number, PDO indices) per ``Sm`` element.
    """

    name: str
    default: bool
    assignments: tuple[tuple[int, tuple[int, ...]], ...]


@dataclass(frozen=True, slots=True)
class EsiCoe:
    """``Mailbox/CoE``: the CoE services the device offers (attributes, default false)."""

    sdo_info: bool = False
    pdo_assign: bool = False
    pdo_config: bool = False
    pdo_upload: bool = False
    complete_access: bool = False
    segmented_sdo: bool = True


@dataclass(frozen=True, slots=True)
class EsiMailbox:
    """``Mailbox``: the protocols it carries (``coe`` None: no CoE) and the data link layer."""

    coe: EsiCoe | None = None
    foe: bool = False
    eoe: bool = False
    soe: bool = False
    aoe: bool = False
    voe: bool = False
    data_link_layer: bool = False


@dataclass(frozen=True, slots=True)
class EsiDcOpMode:
    """``Dc/OpMode``: one synchronisation mode; times in nanoseconds, as ESI writes them.

    A cycle time's ``Factor`` attribute (a multiple of the bus cycle) is kept beside it.
    """

    name: str
    description: str
    assign_activate: int
    cycle_time_sync0_ns: int = 0
    cycle_time_sync0_factor: int = 0
    shift_time_sync0_ns: int = 0
    cycle_time_sync1_ns: int = 0
    cycle_time_sync1_factor: int = 0
    shift_time_sync1_ns: int = 0


@dataclass(frozen=True, slots=True)
class EsiEepromCategory:
    """``Eeprom/Category``: an SII category the vendor gives ready-made (CatNo, Data)."""

    category_type: int
    data: bytes


@dataclass(frozen=True, slots=True)
class EsiEeprom:
    """``Eeprom``: the EEPROM's size, its configuration area and the bootstrap mailboxes.

    ``config_data`` are the bytes of SII words 0.. as written (up to 14); ``bootstrap`` the
    8 bytes of SII words 0x14-0x17 (receive offset, size, send offset, size), None if absent.
    """

    byte_size: int
    config_data: bytes
    bootstrap: bytes | None = None
    categories: tuple[EsiEepromCategory, ...] = ()


@dataclass(frozen=True, slots=True)
class EsiDataTypeSubItem:
    """``DataType/SubItem``: one member of a record type, with its place and access.

    ``access`` is the ``Flags/Access`` text (``ro``, ``rw``, ``wo``); its ``ReadRestrictions``
    and ``WriteRestrictions`` attributes (``PreOP``, ``PreOP_SafeOP``, ``SafeOP_OP``, ...)
    name the states it applies in; ``pdo_mapping`` is ``Flags/PdoMapping`` (``R``, ``T``).
    """

    subindex: int | None
    name: str
    type_name: str
    bit_size: int
    bit_offset: int
    access: str | None = None
    read_restrictions: str | None = None
    write_restrictions: str | None = None
    pdo_mapping: str | None = None


@dataclass(frozen=True, slots=True)
class EsiDataType:
    """``DataTypes/DataType``: a named type; records list sub items, arrays a base type."""

    name: str
    bit_size: int
    base_type: str | None = None
    array_lower_bound: int | None = None
    array_elements: int | None = None
    sub_items: tuple[EsiDataTypeSubItem, ...] = ()


@dataclass(frozen=True, slots=True)
class EsiObjectSubItem:
    """``Object/Info/SubItem``: the default of one sub item of an object."""

    name: str
    default_value: str | None = None
    default_data: bytes | None = None
    default_string: str | None = None


@dataclass(frozen=True, slots=True)
class EsiObject:
    """``Objects/Object``: one entry of the CoE object dictionary.

    ``default_value`` is the text of ``Info/DefaultValue`` as written (``#x00001389``, a
    string); ``default_data`` the bytes of ``Info/DefaultData``, ``default_string`` the text of
    ``Info/DefaultString`` (a STRING object's value). ``access`` (``ro``, ``rw``,
    ...), ``category`` (``m``, ``o``) and ``pdo_mapping`` (``R``, ``T``, ``RT``) are the
    ``Flags``, with the access's ``ReadRestrictions``/``WriteRestrictions``; the access of a
    record's sub items is in its data type's sub items. ``depend_on_slot``: the ``Index``
    attribute ``DependOnSlot`` (a module's object, moved by the slot's SlotIndexIncrement).
    """

    index: int
    name: str
    type_name: str
    bit_size: int
    access: str | None = None
    category: str | None = None
    pdo_mapping: str | None = None
    default_value: str | None = None
    default_data: bytes | None = None
    sub_items: tuple[EsiObjectSubItem, ...] = ()
    default_string: str | None = None
    read_restrictions: str | None = None
    write_restrictions: str | None = None
    depend_on_slot: bool = False


@dataclass(frozen=True, slots=True)
class EsiDictionary:
    """``Profile/Dictionary``: the data types and objects of the CoE object dictionary."""

    data_types: tuple[EsiDataType, ...]
    objects: tuple[EsiObject, ...]

    def object(self, index: int) -> EsiObject | None:
        """The object at ``index``, or None."""
        return next((o for o in self.objects if o.index == index), None)


@dataclass(frozen=True, slots=True)
class EsiSlot:
    """``Slots/Slot`` (ETG.2000 SlotType): a place for ``min_instances``..``max_instances``
    modules, named by ``ModuleIdent`` (``module_idents``; the one with ``Default`` = 1 is
    ``default_module_ident``) or by ``ModuleClass/Class`` (``module_classes``), and the
    slot's own SlotIndexIncrement/SlotPdoIncrement where it gives them (None: the Slots').
    """

    name: str
    min_instances: int
    max_instances: int
    module_idents: tuple[int, ...] = ()
    default_module_ident: int | None = None
    module_classes: tuple[str, ...] = ()
    slot_index_increment: int | None = None
    slot_pdo_increment: int | None = None
    line: int = 0


@dataclass(frozen=True, slots=True)
class EsiSlots:
    """``Device/Slots`` of a modular device (ETG.2000; ETG.5001 Modular Device Profile).

    ``slot_index_increment``/``slot_pdo_increment`` move a module's objects and PDOs whose
    ``Index`` has ``DependOnSlot`` by that much per slot (0 where the ESI gives none);
    ``download_module_ident_list``: the master writes the configured modules' idents to
    0xF030 (ETG.5001) before SAFE-OP.
    """

    slots: tuple[EsiSlot, ...]
    slot_index_increment: int = 0
    slot_pdo_increment: int = 0
    max_slot_count: int | None = None
    download_module_ident_list: bool = False


@dataclass(frozen=True, slots=True)
class EsiModule:
    """``Modules/Module`` (ETG.2000 ModuleType): a module a slot of a modular device holds.

    ``module_ident`` is the ``Type`` attribute ``ModuleIdent`` (what 0xF030/0xF050 carry,
    ETG.5001), ``type_name`` the ``Type`` text; ``module_class`` and ``module_pdo_group`` its
    attributes ``ModuleClass`` and ``ModulePdoGroup``; its PDOs and its ``Profile/Dictionary``
    are the module's own. ``line`` is where the ``Module`` element starts.
    """

    module_ident: int
    type_name: str
    names: tuple[tuple[int | None, str], ...]
    rx_pdos: tuple[EsiPdo, ...]
    tx_pdos: tuple[EsiPdo, ...]
    dictionary: EsiDictionary | None = None
    module_class: str | None = None
    module_pdo_group: int | None = None
    line: int = 0

    @property
    def name(self) -> str:
        """The English name (LcId 1033), else the first one, else the type name."""
        for lcid, text in self.names:
            if lcid in (None, ENGLISH_LCID):
                return text
        return self.names[0][1] if self.names else self.type_name


@dataclass(frozen=True, slots=True)
class EsiDevice:
    """``Devices/Device``: one device type of the file.

    ``type_name`` is the ``Type`` text (the order number); ``names`` holds (LcId, text) per
    ``Name``; ``physics`` the ``Physics`` attribute (one letter per port, ``Y`` = 100BASE-TX).
    ``line`` is where the ``Device`` element starts in the file; ``slots`` the ``Slots`` of a
    modular device (None: not modular); ``configured_modules`` the idents of the modules
    :func:`configure_slots` put in its slots, in slot order (what 0xF030 holds, ETG.5001).
    """

    type_name: str
    product_code: int
    revision: int
    names: tuple[tuple[int | None, str], ...]
    group_type: str
    physics: str
    fmmus: tuple[EsiFmmu, ...]
    sync_managers: tuple[EsiSyncManager, ...]
    rx_pdos: tuple[EsiPdo, ...]
    tx_pdos: tuple[EsiPdo, ...]
    mailbox: EsiMailbox | None
    dc_op_modes: tuple[EsiDcOpMode, ...]
    eeprom: EsiEeprom | None
    dictionary: EsiDictionary | None
    alternative_sm_mappings: tuple[EsiAlternativeSmMapping, ...] = ()
    ebus_current_ma: int = 0
    line: int = 0
    slots: EsiSlots | None = None
    configured_modules: tuple[int, ...] = ()

    @property
    def name(self) -> str:
        """The English name (LcId 1033), else the first one, else the type name."""
        for lcid, text in self.names:
            if lcid == ENGLISH_LCID:
                return text
        return self.names[0][1] if self.names else self.type_name


@dataclass(frozen=True, slots=True)
class EsiFile:
    """A whole ESI file: the vendor, its groups (Type -> name), its devices and the modules
    (``Descriptions/Modules``) the slots of its modular devices hold."""

    vendor: EsiVendor
    groups: tuple[tuple[str, str], ...]
    devices: tuple[EsiDevice, ...]
    modules: tuple[EsiModule, ...] = ()

    def slot_modules(self, device: EsiDevice) -> tuple[EsiModule, ...]:
        """The modules of the file that a slot of ``device`` may hold (by ModuleIdent or
        ModuleClass), in file order; none for a device without slots."""
        if device.slots is None:
            return ()
        idents = {i for s in device.slots.slots for i in s.module_idents}
        classes = {c for s in device.slots.slots for c in s.module_classes}
        return tuple(
            m for m in self.modules if m.module_ident in idents or m.module_class in classes
        )

    def group_name(self, group_type: str) -> str:
        """The name of the group ``group_type`` names, or ``""``."""
        return next((name for t, name in self.groups if t == group_type), "")

    def device(self, selector: str | None = None) -> EsiDevice:
        """The device whose Type text or product code is ``selector``, optionally followed by
        ``@REVISION`` (its RevisionNo) for files that describe several revisions of a device.

        Without a selector, the file's only device. Product code and revision may be written
        in decimal, ``0x`` or ``#x`` hex. A Type text holding ``@`` is matched whole first.

        Raises:
            EsiFormatError: no device matches, several do, or the file has several devices
                and no selector was given (the message lists them).
        """
        listing = ", ".join(
            f"{d.type_name} (product code {d.product_code:#x}) @{d.revision:#x}"
            for d in self.devices
        )
        if selector is None:
            if len(self.devices) == 1:
                return self.devices[0]
            raise EsiFormatError(
                f"the ESI describes {len(self.devices)} devices, pick one: {listing}"
            )
        found = self._matching(selector)
        if not found and "@" in selector:
            name, _, rev_text = selector.rpartition("@")
            revision = _number_or_none(rev_text)
            if revision is None:
                raise EsiFormatError(f"{selector!r}: {rev_text!r} after @ is not a revision")
            found = [d for d in self._matching(name) if d.revision == revision]
        if len(found) == 1:
            return found[0]
        if not found:
            raise EsiFormatError(f"no device {selector!r} in the ESI; it has: {listing}")
        revs = ", ".join(f"revision {d.revision:#x} (line {d.line})" for d in found)
        raise EsiFormatError(
            f"{len(found)} devices match {selector!r}: {revs}; pick one with @REVISION"
        )

    def _matching(self, selector: str) -> list[EsiDevice]:
        """The devices whose Type text, else whose product code, is ``selector``."""
        found = [d for d in self.devices if d.type_name == selector]
        if not found:
            code = _number_or_none(selector)
            found = [d for d in self.devices if code is not None and d.product_code == code]
        return found


# --- reading -----------------------------------------------------------------------------------
def read_esi(path: str | os.PathLike[str]) -> EsiFile:
    """Read the ESI file at ``path``.

    Raises:
        EsiFormatError: the file is not well-formed XML, lacks a required element, or holds a
            value that cannot be used (the message names the element and its line).
        OSError: the file cannot be read.
    """
    p = Path(os.fspath(path))
    return parse_esi(p.read_bytes(), source=str(p))


def parse_esi(data: bytes, source: str = "ESI") -> EsiFile:
    """Parse the bytes of an ESI file; ``source`` names it in error messages.

    Raises:
        EsiFormatError: see :func:`read_esi`.
    """
    root = _parse_xml(data, source)
    ctx = _Context(source)
    if root.tag != "EtherCATInfo":
        raise ctx.error(root, f"the root element is <{root.tag}>, expected <EtherCATInfo>")
    vendor_el = ctx.required(root, "Vendor")
    vendor = EsiVendor(
        ctx.number(ctx.required(vendor_el, "Id")),
        _names(vendor_el)[0][1] if _names(vendor_el) else "",
    )
    descriptions = ctx.required(root, "Descriptions")
    groups: list[tuple[str, str]] = []
    groups_el = descriptions.find("Groups")
    if groups_el is not None:
        for g in groups_el.iterfind("Group"):
            names = _names(g)
            name = next(
                (t for lcid, t in names if lcid == ENGLISH_LCID), names[0][1] if names else ""
            )
            groups.append((ctx.text(ctx.required(g, "Type")), name))
    devices_el = ctx.required(descriptions, "Devices")
    devices = tuple(ctx.device(d) for d in devices_el.iterfind("Device"))
    if not devices:
        raise ctx.error(devices_el, "no <Device>")
    modules = tuple(ctx.module(m) for m in descriptions.iterfind("Modules/Module"))
    return EsiFile(vendor, tuple(groups), devices, modules)


def missing_communication_objects(device: EsiDevice) -> tuple[int, ...]:
    """The communication objects a CoE slave serves that the ESI's ``Profile/Dictionary`` lacks.

    Every CoE slave with SyncManagers has 0x1C00, their communication types, the PDO
    assignment 0x1C10 + n of each process-data SyncManager n, and the mapping object of each of
    its PDOs (ETG.1000.6 5.6.7.3, 5.6.7.4; masters read them to size the process data, SOEM's
    ``ecx_readPDOmap`` first of all), yet some vendors' ESI files leave them out. These are:
    0x1C00 when the device has an ``Sm``, 0x1C10 + n for each ``Outputs``/``Inputs`` Sm n, and
    the ``Index`` of each RxPdo/TxPdo of the device, in that order. None without CoE.
    """
    if device.mailbox is None or device.mailbox.coe is None or not device.sync_managers:
        return ()
    have = set() if device.dictionary is None else {o.index for o in device.dictionary.objects}
    wanted = [SM_COMMUNICATION_TYPES]
    wanted += [
        PDO_ASSIGNMENT_BASE + n
        for n, sm in enumerate(device.sync_managers)
        if sm.kind in ("Outputs", "Inputs")
    ]
    wanted += [p.index for p in device.rx_pdos + device.tx_pdos]
    return tuple(dict.fromkeys(i for i in wanted if i not in have))


def configure_slots(esi: EsiFile, device: EsiDevice, selectors: Sequence[str]) -> EsiDevice:
    """``device`` with modules in its slots: the modules ``selectors`` name (a ModuleIdent in
    decimal, ``0x`` or ``#x`` hex, or a Type text), the k-th in slot number k (from 0).

    The modules fill the slots in order (ETG.2000 Slots, ETG.5001 Modular Device Profile): each
    slot takes modules it names (ModuleIdent or ModuleClass) up to its MaxInstances, and must
    have its MinInstances (and there may be MaxSlotCount modules at most, unless it is 0).
    Module k's PDOs and objects join the device's, an ``Index`` or ``Exclude`` with
    ``DependOnSlot`` moved by k times the slot's SlotPdoIncrement (a PDO's) or
    SlotIndexIncrement (an entry's or object's; the slot's own where it gives one, else the
    Slots'); one with the index of a device's own takes its place (ETG.2000
    ``OverwrittenByModule``; vendors list the default modules' PDOs in the device too);
    ``configured_modules`` holds their idents.

    Raises:
        EsiFormatError: the device has no slots, a selector names no module its slots may hold,
            the modules do not fit the slots, or two modules have a PDO or object of one index.
    """
    where = f"ESI device {device.type_name} (line {device.line})"
    if device.slots is None:
        raise EsiFormatError(f"{where}: has no <Slots>, so no modules")
    holdable = esi.slot_modules(device)
    modules = [_module_named(holdable, s, where) for s in selectors]
    slots = device.slots.slots
    placed: list[EsiSlot] = []
    at, count = 0, 0
    for k, m in enumerate(modules):
        while at < len(slots) and (count >= slots[at].max_instances or not _takes(slots[at], m)):
            _enough(slots[at], count, where)
            at, count = at + 1, 0
        if at == len(slots):
            raise EsiFormatError(
                f"{where}: module {k + 1} ({m.type_name}): no slot after the ones before takes it"
            )
        placed.append(slots[at])
        count += 1
    for slot in slots[at:]:
        _enough(slot, count if slot is slots[at] else 0, where)
    limit = device.slots.max_slot_count
    if limit and len(modules) > limit:  # 0, as some vendors write it: no limit given
        raise EsiFormatError(f"{where}: {len(modules)} modules, MaxSlotCount is {limit}")
    pdos: dict[int, tuple[bool, EsiPdo, str]] = {p.index: (True, p, "") for p in device.rx_pdos}
    pdos |= {p.index: (False, p, "") for p in device.tx_pdos}
    types = list(device.dictionary.data_types) if device.dictionary else []
    objects = {o.index: (o, "") for o in device.dictionary.objects} if device.dictionary else {}
    for k, (m, slot) in enumerate(zip(modules, placed, strict=True)):
        pdo_step = k * _increment(slot.slot_pdo_increment, device.slots.slot_pdo_increment)
        index_step = k * _increment(slot.slot_index_increment, device.slots.slot_index_increment)
        mine = f"module {k + 1} ({m.type_name}, line {m.line})"
        for rx, theirs in ((True, m.rx_pdos), (False, m.tx_pdos)):
            for p in theirs:
                moved = _moved_pdo(p, pdo_step, index_step)
                other = pdos.get(moved.index, (rx, p, ""))[2]
                if other:
                    raise EsiFormatError(f"{where}: {mine}: PDO {moved.index:#06x} is {other}'s")
                pdos[moved.index] = (rx, moved, mine)
        if m.dictionary is None:
            continue
        named = {t.name for t in types}
        types += [t for t in m.dictionary.data_types if t.name not in named]
        for o in m.dictionary.objects:
            index = o.index + (index_step if o.depend_on_slot else 0)
            other = objects.get(index, (o, ""))[1]
            if other:
                raise EsiFormatError(f"{where}: {mine}: object {index:#06x} is {other}'s")
            objects[index] = (dataclasses.replace(o, index=index, depend_on_slot=False), mine)
    dictionary = (
        EsiDictionary(tuple(types), tuple(o for o, _ in objects.values()))
        if device.dictionary is not None or objects
        else None
    )
    return dataclasses.replace(
        device,
        rx_pdos=tuple(p for rx, p, _ in pdos.values() if rx),
        tx_pdos=tuple(p for rx, p, _ in pdos.values() if not rx),
        dictionary=dictionary,
        configured_modules=tuple(m.module_ident for m in modules),
    )


def _module_named(modules: tuple[EsiModule, ...], selector: str, where: str) -> EsiModule:
    """The module whose Type text, else whose ModuleIdent, is ``selector``."""
    found = [m for m in modules if m.type_name == selector]
    if not found:
        ident = _number_or_none(selector)
        found = [m for m in modules if ident is not None and m.module_ident == ident]
    if not found:
        listing = ", ".join(f"{m.type_name} ({m.module_ident:#x})" for m in modules) or "none"
        raise EsiFormatError(
            f"{where}: no module {selector!r} its slots may hold; they may hold: {listing}"
        )
    return found[0]


def _takes(slot: EsiSlot, module: EsiModule) -> bool:
    return module.module_ident in slot.module_idents or module.module_class in slot.module_classes


def _enough(slot: EsiSlot, count: int, where: str) -> None:
    if count < slot.min_instances:
        raise EsiFormatError(
            f"{where}: slot {slot.name!r} (line {slot.line}) needs {slot.min_instances} "
            f"module(s) at least, the modules given put {count} in it"
        )


def _increment(own: int | None, common: int) -> int:
    return common if own is None else own


def _moved_pdo(p: EsiPdo, pdo_step: int, index_step: int) -> EsiPdo:
    """A module's PDO in its slot: ``DependOnSlot`` indices moved (ETG.2000)."""
    entries = tuple(
        dataclasses.replace(e, index=e.index + index_step, depend_on_slot=False)
        if e.depend_on_slot and e.index
        else e
        for e in p.entries
    )
    index = p.index + pdo_step if p.depend_on_slot else p.index
    excludes = tuple(
        x + pdo_step if moves else x
        for x, moves in zip(p.excludes, p.excludes_depend_on_slot, strict=True)
    )
    return dataclasses.replace(
        p,
        index=index,
        entries=entries,
        excludes=excludes,
        depend_on_slot=False,
        excludes_depend_on_slot=(False,) * len(excludes),
    )


def parse_number(text: str) -> int:
    """An ESI number: decimal, ``#x`` hex (ETG.2000 HexDecValue), or ``0x`` hex.

    Raises:
        ValueError: ``text`` is neither.
    """
    s = text.strip()
    negative = s.startswith("-")
    if negative:
        s = s[1:]
    if s[:2] in ("#x", "#X", "0x", "0X") and s[2:].isalnum():
        value = int(s[2:], 16)  # ValueError for a non-hex digit
    elif s.isdigit() and s.isascii():
        value = int(s)
    else:
        raise ValueError(f"{text!r} is not a number")
    return -value if negative else value


def _number_or_none(text: str) -> int | None:
    try:
        return parse_number(text)
    except ValueError:
        return None


def _parse_xml(data: bytes, source: str) -> _Element:
    builder = ET.TreeBuilder(element_factory=_Element)
    parser = expat.ParserCreate()
    parser.buffer_text = True

    def start(tag: str, attrs: dict[str, str]) -> None:
        element = builder.start(tag, attrs)
        element.line = parser.CurrentLineNumber  # type: ignore[attr-defined]

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise EsiFormatError(
            f"{source}: line {exc.lineno}: not well-formed XML ({expat.ErrorString(exc.code)})"
        ) from exc
    root = builder.close()
    assert isinstance(root, _Element)
    return root


def _names(el: ET.Element) -> list[tuple[int | None, str]]:
    out: list[tuple[int | None, str]] = []
    for n in el.iterfind("Name"):
        lcid = n.get("LcId")
        out.append((_number_or_none(lcid) if lcid is not None else None, (n.text or "").strip()))
    return out


_TRUE: Final = frozenset({"1", "true"})
_FALSE: Final = frozenset({"0", "false"})


class _Context:
    """Turns elements into the model; every failure names the element and its line."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, el: ET.Element, what: str) -> EsiFormatError:
        line = getattr(el, "line", 0)
        return EsiFormatError(f"{self.source}: line {line}: <{el.tag}>: {what}")

    def required(self, el: ET.Element, tag: str) -> ET.Element:
        child = el.find(tag)
        if child is None:
            raise self.error(el, f"missing <{tag}>")
        return child

    def text(self, el: ET.Element) -> str:
        return (el.text or "").strip()

    def number(self, el: ET.Element) -> int:
        text = self.text(el)
        try:
            return parse_number(text)
        except ValueError:
            raise self.error(el, f"{text!r} is not a number (decimal or #x hex)") from None

    def child_number(self, el: ET.Element, tag: str, default: int | None = None) -> int:
        child = el.find(tag)
        if child is None:
            if default is None:
                raise self.error(el, f"missing <{tag}>")
            return default
        return self.number(child)

    def attr_number(self, el: ET.Element, name: str, default: int | None = None) -> int:
        text = el.get(name)
        if text is None:
            if default is None:
                raise self.error(el, f"missing attribute {name}")
            return default
        try:
            return parse_number(text)
        except ValueError:
            raise self.error(el, f"{name}={text!r} is not a number (decimal or #x hex)") from None

    def attr_optional(self, el: ET.Element, name: str) -> int | None:
        return None if el.get(name) is None else self.attr_number(el, name)

    def flag(self, el: ET.Element, name: str, default: bool = False) -> bool:
        text = el.get(name)
        if text is None:
            return default
        low = text.strip().lower()
        if low in _TRUE:
            return True
        if low in _FALSE:
            return False
        raise self.error(el, f"{name}={text!r} is not a boolean (1, 0, true, false)")

    def hex_bytes(self, el: ET.Element) -> bytes:
        text = "".join(self.text(el).split())
        try:
            return bytes.fromhex(text)
        except ValueError:
            raise self.error(el, f"{text[:40]!r} is not hex bytes") from None

    def device(self, d: ET.Element) -> EsiDevice:
        type_el = self.required(d, "Type")
        names = _names(d)
        electrical = d.find("Electrical")
        ebus = 0
        if electrical is not None and electrical.find("EBusCurrent") is not None:
            ebus = self.child_number(electrical, "EBusCurrent")
        return EsiDevice(
            type_name=self.text(type_el),
            product_code=self.attr_number(type_el, "ProductCode", 0),
            revision=self.attr_number(type_el, "RevisionNo", 0),
            names=tuple(names),
            group_type=_flag_text(d, "GroupType") or "",
            physics=d.get("Physics", ""),
            fmmus=tuple(self.fmmu(f) for f in d.iterfind("Fmmu")),
            sync_managers=tuple(self.sync_manager(s) for s in d.iterfind("Sm")),
            rx_pdos=tuple(self.pdo(p) for p in d.iterfind("RxPdo")),
            tx_pdos=tuple(self.pdo(p) for p in d.iterfind("TxPdo")),
            mailbox=self.mailbox(d.find("Mailbox")),
            dc_op_modes=self.dc(d.find("Dc")),
            eeprom=self.eeprom(d.find("Eeprom")),
            dictionary=self.dictionary(d.find("Profile/Dictionary")),
            alternative_sm_mappings=tuple(
                self.alternative(a) for a in d.iterfind("AlternativeSmMapping")
            ),
            ebus_current_ma=ebus,
            line=getattr(d, "line", 0),
            slots=self.slots(d.find("Slots")),
        )

    def slots(self, s: ET.Element | None) -> EsiSlots | None:
        """``Slots`` (ETG.2000); a slot naming no module, or fewer MaxInstances than
        MinInstances, is an error."""
        if s is None:
            return None
        return EsiSlots(
            slots=tuple(self.slot(x) for x in s.iterfind("Slot")),
            slot_index_increment=self.attr_number(s, "SlotIndexIncrement", 0),
            slot_pdo_increment=self.attr_number(s, "SlotPdoIncrement", 0),
            max_slot_count=self.attr_optional(s, "MaxSlotCount"),
            download_module_ident_list=self.flag(s, "DownloadModuleIdentList"),
        )

    def slot(self, s: ET.Element) -> EsiSlot:
        low, high = self.attr_number(s, "MinInstances"), self.attr_number(s, "MaxInstances")
        if not 0 <= low <= high:
            raise self.error(s, f"MinInstances {low}, MaxInstances {high}: not 0 <= min <= max")
        idents = s.findall("ModuleIdent")
        classes = [self.text(self.required(c, "Class")) for c in s.iterfind("ModuleClass")]
        if not idents and not classes:
            raise self.error(s, "names no <ModuleIdent> and no <ModuleClass>")
        defaults = [self.number(i) for i in idents if self.attr_number(i, "Default", 0)]
        if len(defaults) > 1:
            raise self.error(s, f"{len(defaults)} <ModuleIdent> with Default=1, at most 1")
        names = _names(s)
        return EsiSlot(
            name=next((t for lcid, t in names if lcid in (None, ENGLISH_LCID)), ""),
            min_instances=low,
            max_instances=high,
            module_idents=tuple(self.number(i) for i in idents),
            default_module_ident=defaults[0] if defaults else None,
            module_classes=tuple(classes),
            slot_index_increment=self.attr_optional(s, "SlotIndexIncrement"),
            slot_pdo_increment=self.attr_optional(s, "SlotPdoIncrement"),
            line=getattr(s, "line", 0),
        )

    def module(self, m: ET.Element) -> EsiModule:
        """``Modules/Module`` (ETG.2000 ModuleType)."""
        type_el = self.required(m, "Type")
        group = type_el.get("ModulePdoGroup")
        return EsiModule(
            module_ident=self.attr_number(type_el, "ModuleIdent"),
            type_name=self.text(type_el),
            names=tuple(_names(m)),
            rx_pdos=tuple(self.pdo(p) for p in m.iterfind("RxPdo")),
            tx_pdos=tuple(self.pdo(p) for p in m.iterfind("TxPdo")),
            dictionary=self.dictionary(m.find("Profile/Dictionary")),
            module_class=type_el.get("ModuleClass"),
            module_pdo_group=None if group is None else self.attr_number(type_el, "ModulePdoGroup"),
            line=getattr(m, "line", 0),
        )

    def fmmu(self, f: ET.Element) -> EsiFmmu:
        kind = self.text(f)
        if kind and kind not in FMMU_KINDS:
            raise self.error(f, f"{kind!r} is not an FMMU use ({', '.join(FMMU_KINDS)})")
        return EsiFmmu(kind, self.attr_optional(f, "Sm"))

    def sync_manager(self, s: ET.Element) -> EsiSyncManager:
        kind = self.text(s)
        if kind and kind not in SM_KINDS:
            raise self.error(s, f"{kind!r} is not a SyncManager type ({', '.join(SM_KINDS)})")
        return EsiSyncManager(
            start_address=self.attr_number(s, "StartAddress"),
            default_size_bytes=self.attr_optional(s, "DefaultSize"),
            control_byte=self.attr_number(s, "ControlByte"),
            enable=self.attr_number(s, "Enable", 0),
            kind=kind,
        )

    def pdo(self, p: ET.Element) -> EsiPdo:
        entries = []
        for e in p.iterfind("Entry"):
            index = self.child_number(e, "Index")
            index_el = e.find("Index")
            data_type = e.find("DataType")
            entries.append(
                EsiPdoEntry(
                    index=index,
                    subindex=self.child_number(e, "SubIndex", 0),
                    bit_length=self.child_number(e, "BitLen"),
                    name=_flag_text(e, "Name") or "",
                    data_type="" if data_type is None else self.text(data_type),
                    depend_on_slot=index_el is not None and self.flag(index_el, "DependOnSlot"),
                )
            )
        names = _names(p)
        return EsiPdo(
            index=self.child_number(p, "Index"),
            name=next((t for lcid, t in names if lcid in (None, ENGLISH_LCID)), ""),
            entries=tuple(entries),
            sync_manager=self.attr_optional(p, "Sm"),
            mandatory=self.flag(p, "Mandatory"),
            fixed=self.flag(p, "Fixed"),
            excludes=tuple(self.number(x) for x in p.iterfind("Exclude")),
            depend_on_slot=self.flag(self.required(p, "Index"), "DependOnSlot"),
            excludes_depend_on_slot=tuple(
                self.flag(x, "DependOnSlot") for x in p.iterfind("Exclude")
            ),
        )

    def alternative(self, a: ET.Element) -> EsiAlternativeSmMapping:
        names = _names(a)
        return EsiAlternativeSmMapping(
            name=names[0][1] if names else "",
            default=self.flag(a, "Default"),
            assignments=tuple(
                (self.attr_number(sm, "No"), tuple(self.number(x) for x in sm.iterfind("Pdo")))
                for sm in a.iterfind("Sm")
            ),
        )

    def mailbox(self, m: ET.Element | None) -> EsiMailbox | None:
        if m is None:
            return None
        coe_el = m.find("CoE")
        coe = None
        if coe_el is not None:
            coe = EsiCoe(
                sdo_info=self.flag(coe_el, "SdoInfo"),
                pdo_assign=self.flag(coe_el, "PdoAssign"),
                pdo_config=self.flag(coe_el, "PdoConfig"),
                pdo_upload=self.flag(coe_el, "PdoUpload"),
                complete_access=self.flag(coe_el, "CompleteAccess"),
                segmented_sdo=self.flag(coe_el, "SegmentedSdo", True),
            )
        return EsiMailbox(
            coe=coe,
            foe=m.find("FoE") is not None,
            eoe=m.find("EoE") is not None,
            soe=m.find("SoE") is not None,
            aoe=m.find("AoE") is not None,
            voe=m.find("VoE") is not None,
            data_link_layer=self.flag(m, "DataLinkLayer"),
        )

    def dc_time(self, op: ET.Element, tag: str) -> int:
        """A time of a DC op mode in ns, 0 when absent: a cycle time 0..2**32-1 (the SII's
        32-bit field, ETG.2010 Table 14), a shift time an ESI xs:int (it may be negative)."""
        el = op.find(tag)
        if el is None:
            return 0
        value = self.number(el)
        low, high = (-(2**31), 2**31 - 1) if tag.startswith("Shift") else (0, 2**32 - 1)
        if not low <= value <= high:
            raise self.error(el, f"{value} ns is outside {low}..{high}")
        return value

    def dc(self, dc: ET.Element | None) -> tuple[EsiDcOpMode, ...]:
        if dc is None:
            return ()
        modes = []
        for op in dc.iterfind("OpMode"):
            sync0 = op.find("CycleTimeSync0")
            sync1 = op.find("CycleTimeSync1")
            modes.append(
                EsiDcOpMode(
                    name=self.text(self.required(op, "Name")),
                    description=_flag_text(op, "Desc") or "",
                    assign_activate=self.child_number(op, "AssignActivate", 0),
                    cycle_time_sync0_ns=self.dc_time(op, "CycleTimeSync0"),
                    cycle_time_sync0_factor=0
                    if sync0 is None
                    else self.attr_number(sync0, "Factor", 0),
                    shift_time_sync0_ns=self.dc_time(op, "ShiftTimeSync0"),
                    cycle_time_sync1_ns=self.dc_time(op, "CycleTimeSync1"),
                    cycle_time_sync1_factor=0
                    if sync1 is None
                    else self.attr_number(sync1, "Factor", 0),
                    shift_time_sync1_ns=self.dc_time(op, "ShiftTimeSync1"),
                )
            )
        return tuple(modes)

    def eeprom(self, e: ET.Element | None) -> EsiEeprom | None:
        if e is None:
            return None
        config = e.find("ConfigData")
        bootstrap = e.find("BootStrap")
        boot = None if bootstrap is None else self.hex_bytes(bootstrap)
        if boot is not None and len(boot) != 8:
            raise self.error(e, f"<BootStrap> {len(boot)} bytes, expected 8 (4 words)")
        return EsiEeprom(
            byte_size=self.child_number(e, "ByteSize"),
            config_data=b"" if config is None else self.hex_bytes(config),
            bootstrap=boot,
            categories=tuple(
                EsiEepromCategory(
                    self.child_number(c, "CatNo"), self.hex_bytes(self.required(c, "Data"))
                )
                for c in e.iterfind("Category")
            ),
        )

    def dictionary(self, d: ET.Element | None) -> EsiDictionary | None:
        if d is None:
            return None
        types = []
        for t in d.iterfind("DataTypes/DataType"):
            array = t.find("ArrayInfo")
            base = t.find("BaseType")
            types.append(
                EsiDataType(
                    name=self.text(self.required(t, "Name")),
                    bit_size=self.child_number(t, "BitSize"),
                    base_type=None if base is None else self.text(base),
                    array_lower_bound=None
                    if array is None
                    else self.child_number(array, "LBound", 0),
                    array_elements=None if array is None else self.child_number(array, "Elements"),
                    sub_items=tuple(
                        EsiDataTypeSubItem(
                            subindex=None
                            if s.find("SubIdx") is None
                            else self.child_number(s, "SubIdx"),
                            name=self.text(self.required(s, "Name")),
                            type_name=self.text(self.required(s, "Type")),
                            bit_size=self.child_number(s, "BitSize"),
                            bit_offset=self.child_number(s, "BitOffs"),
                            access=_flag_text(s, "Flags/Access"),
                            read_restrictions=_attribute(s, "Flags/Access", "ReadRestrictions"),
                            write_restrictions=_attribute(s, "Flags/Access", "WriteRestrictions"),
                            pdo_mapping=_flag_text(s, "Flags/PdoMapping"),
                        )
                        for s in t.iterfind("SubItem")
                    ),
                )
            )
        objects = []
        for o in d.iterfind("Objects/Object"):
            info = o.find("Info")
            default_data = None if info is None else info.find("DefaultData")
            objects.append(
                EsiObject(
                    index=self.child_number(o, "Index"),
                    name=_names(o)[0][1] if _names(o) else "",
                    type_name=self.text(self.required(o, "Type")),
                    bit_size=self.child_number(o, "BitSize"),
                    access=_flag_text(o, "Flags/Access"),
                    category=_flag_text(o, "Flags/Category"),
                    pdo_mapping=_flag_text(o, "Flags/PdoMapping"),
                    default_value=None if info is None else _flag_text(info, "DefaultValue"),
                    default_data=None if default_data is None else self.hex_bytes(default_data),
                    sub_items=()
                    if info is None
                    else tuple(self.object_sub(s) for s in info.iterfind("SubItem")),
                    default_string=None if info is None else _flag_text(info, "DefaultString"),
                    read_restrictions=_attribute(o, "Flags/Access", "ReadRestrictions"),
                    write_restrictions=_attribute(o, "Flags/Access", "WriteRestrictions"),
                    depend_on_slot=self.flag(self.required(o, "Index"), "DependOnSlot"),
                )
            )
        return EsiDictionary(tuple(types), tuple(objects))

    def object_sub(self, s: ET.Element) -> EsiObjectSubItem:
        info = s.find("Info")
        data = None if info is None else info.find("DefaultData")
        return EsiObjectSubItem(
            name=_names(s)[0][1] if _names(s) else "",
            default_value=None if info is None else _flag_text(info, "DefaultValue"),
            default_data=None if data is None else self.hex_bytes(data),
            default_string=None if info is None else _flag_text(info, "DefaultString"),
        )


def _flag_text(el: ET.Element, path: str) -> str | None:
    found = el.find(path)
    return None if found is None else (found.text or "").strip()


def _attribute(el: ET.Element, path: str, name: str) -> str | None:
    found = el.find(path)
    return None if found is None else found.get(name)
