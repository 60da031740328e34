"""Read ESI files (ETG.2000) into the model of :mod:`skinframes.esi.model`.

:func:`read_esi` reads a file, :func:`parse_esi` its bytes. Numbers are written as in ESI
(:func:`~skinframes.esi.model.parse_number`); booleans as ``1``/``0`` or ``true``/``false``;
binary data (ConfigData, BootStrap, DefaultData) as hex digits, byte by byte in EEPROM order.

The reader is expat with line numbers recorded on every element, so that anything it cannot use
raises :class:`~skinframes.errors.EsiFormatError` naming the element and its line. Elements it
does not model (vendor specials, images) are skipped without a word.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Final, NamedTuple
from xml.parsers import expat

from skinframes.errors import EsiFormatError
from skinframes.esi.model import (
    ENGLISH_LCID,
    FMMU_KINDS,
    SM_KINDS,
    EsiAlternativeSmMapping,
    EsiCoe,
    EsiDataType,
    EsiDataTypeSubItem,
    EsiDcOpMode,
    EsiDevice,
    EsiDictionary,
    EsiEeprom,
    EsiEepromCategory,
    EsiFile,
    EsiFmmu,
    EsiMailbox,
    EsiModule,
    EsiObject,
    EsiObjectSubItem,
    EsiPdo,
    EsiPdoEntry,
    EsiSlot,
    EsiSlots,
    EsiSyncManager,
    EsiVendor,
    _number_or_none,
    parse_number,
)


class _Element(ET.Element):
    """An ElementTree element that remembers the line it starts on."""

    __slots__ = ("line",)
    line: int


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


class _Range(NamedTuple):
    """The values a number may take: ``low..high``, a multiple of ``step``; ``unit`` for the
    message."""

    low: int
    high: int
    step: int = 1
    unit: str = ""


_U8: Final = _Range(0, 0xFF)
_U16: Final = _Range(0, 0xFFFF)
_U32: Final = _Range(0, 0xFFFF_FFFF)
_I16: Final = _Range(-(1 << 15), (1 << 15) - 1)

# The ranges of the numbers read, by (element, attribute; "" for its text): the SII field each
# goes into (ETG.2010 Tables 2-14) or the CoE field (ETG.1000.6: index 16 bits, subindex and
# mapped length 8). A number outside is an error naming the element and its line.
_RANGES: Final[dict[tuple[str, str], _Range]] = {
    ("Id", ""): _U32,  # Vendor/Id: words 8-9
    ("Type", "ProductCode"): _U32,  # words 0xA-0xB
    ("Type", "RevisionNo"): _U32,  # words 0xC-0xD
    ("Type", "ModuleIdent"): _U32,  # ETG.5001 0xF030 (a module's ident)
    ("ModuleIdent", ""): _U32,
    ("ByteSize", ""): _Range(128, 0x10000 * 128, 128),  # word 0x3E: ByteSize / 128 - 1
    ("EBusCurrent", ""): _I16,  # GENERAL: mA, signed
    ("CatNo", ""): _U16,  # a category's type
    ("Sm", "StartAddress"): _U16,  # SYNCM (Table 9)
    ("Sm", "DefaultSize"): _U16,
    ("Sm", "ControlByte"): _U8,
    ("Sm", "Enable"): _U8,
    ("Sm", "No"): _U8,  # AlternativeSmMapping
    ("Fmmu", "Sm"): _U8,
    ("RxPdo", "Sm"): _U8,  # TXPDO/RXPDO (Table 11)
    ("TxPdo", "Sm"): _U8,
    ("Index", ""): _U16,  # a PDO's, an entry's or an object's
    ("Exclude", ""): _U16,
    ("Pdo", ""): _U16,
    ("SubIndex", ""): _U8,  # an entry's (Table 12)
    ("SubIdx", ""): _U8,
    ("BitLen", ""): _U8,
    ("AssignActivate", ""): _U16,  # DC (Table 14)
    ("CycleTimeSync0", ""): _Range(0, 0xFFFF_FFFF, unit="ns"),
    ("CycleTimeSync1", ""): _Range(0, 0xFFFF_FFFF, unit="ns"),
    # a shift time is an xs:int: a negative one goes in as its two's complement
    ("ShiftTimeSync0", ""): _Range(-(1 << 31), (1 << 31) - 1, unit="ns"),
    ("ShiftTimeSync1", ""): _Range(-(1 << 31), (1 << 31) - 1, unit="ns"),
    ("CycleTimeSync0", "Factor"): _I16,
    ("CycleTimeSync1", "Factor"): _I16,
}


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
            value = parse_number(text)
        except ValueError:
            raise self.error(el, f"{text!r} is not a number (decimal or #x hex)") from None
        return self.in_range(el, "", text, value)

    def in_range(self, el: ET.Element, name: str, text: str, value: int) -> int:
        """``value`` (of attribute ``name``, "" for the text) if it is in its :data:`_RANGES`."""
        limits = _RANGES.get((el.tag, name))
        if limits is None or (limits.low <= value <= limits.high and value % limits.step == 0):
            return value
        what = f"{name}={text.strip()}" if name else text.strip()
        if limits.unit:
            what += f" {limits.unit}"
        if value % limits.step:
            raise self.error(el, f"{what} is not a multiple of {limits.step}")
        raise self.error(el, f"{what} is outside {limits.low}..{limits.high}")

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
            value = parse_number(text)
        except ValueError:
            raise self.error(el, f"{name}={text!r} is not a number (decimal or #x hex)") from None
        return self.in_range(el, name, text, value)

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
        """A time of a DC op mode in ns, 0 when absent (its range in :data:`_RANGES`)."""
        el = op.find(tag)
        return 0 if el is None else self.number(el)

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
