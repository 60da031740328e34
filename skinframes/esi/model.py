"""What an ESI file says (ETG.2000): its constants and the frozen dataclasses the reader fills in.

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
(``#x1000``). :func:`parse_number` reads them; it is here, not in the reader, because a device
selector (:meth:`EsiFile.device`) takes them too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from skinframes.errors import EsiFormatError

ENGLISH_LCID: Final = 1033  # the language whose Name is the device's name, when present
SM_KINDS: Final = ("MBoxOut", "MBoxIn", "Outputs", "Inputs")  # ETG.2000 SmType text
SM_COMMUNICATION_TYPES: Final = 0x1C00  # ETG.1000.6 5.6.7.4: one type a SyncManager
PDO_ASSIGNMENT_BASE: Final = 0x1C10  # + n: the PDO assignment of SyncManager n
FMMU_KINDS: Final = ("Outputs", "Inputs", "MBoxState")  # ETG.2000 FmmuType text


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


# --- what a CoE slave serves -------------------------------------------------------------------
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


# --- numbers as ESI writes them ----------------------------------------------------------------
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
