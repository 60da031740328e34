"""The ESI reader against third-party ESI files (../shared/esi), typed-in values and bad XML.

Expected values are read off the XML files by eye (the line numbers are the files') and typed in
here, never taken from the reader's own output.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from memory_util import traced_peak

from skinframes.errors import DecodeError, EsiFormatError
from skinframes.esi import (
    EsiCoe,
    EsiDcOpMode,
    EsiFmmu,
    EsiPdoEntry,
    EsiSyncManager,
    configure_slots,
    parse_esi,
    parse_number,
    read_esi,
)


def test_numbers_as_esi_writes_them() -> None:
    assert parse_number("#x1000") == 0x1000
    assert parse_number("#X1a00") == 0x1A00
    assert parse_number("128") == 128
    assert parse_number(" 42 ") == 42
    assert parse_number("-5") == -5
    for bad in ("", "#x", "#xZZ", "1.5", "x10", "١٢"):
        with pytest.raises(ValueError):
            parse_number(bad)


def test_lan9252_demo(shared_esi: Path) -> None:
    esi = read_esi(shared_esi / "soes_linux_lan9252demo.xml")
    assert (esi.vendor.vendor_id, esi.vendor.name) == (0x1337, "rt-labs AB")
    assert esi.groups == (("lan9252_spi", "lan9252"),)
    d = esi.device()
    assert (d.type_name, d.product_code, d.revision, d.name) == ("evb9252_dig", 1234, 0, "lan9252")
    assert d.physics == "YY" and d.group_type == "lan9252_spi"
    assert d.fmmus == (EsiFmmu("Outputs"), EsiFmmu("Inputs"))
    assert d.sync_managers == (
        EsiSyncManager(0x1000, 128, 0x26, 1, "MBoxOut"),
        EsiSyncManager(0x1080, 128, 0x22, 1, "MBoxIn"),
        EsiSyncManager(0x1100, None, 0x24, 1, "Outputs"),
        EsiSyncManager(0x1180, None, 0x20, 1, "Inputs"),
    )
    (rx,) = d.rx_pdos
    assert (rx.index, rx.sync_manager, rx.mandatory, rx.fixed) == (0x1600, 2, True, True)
    assert [(e.index, e.subindex, e.bit_length) for e in rx.entries] == [
        (0x7000, 1, 8),
        (0x7000, 2, 8),
    ]
    (tx,) = d.tx_pdos
    assert (tx.index, tx.sync_manager, tx.bit_length) == (0x1A00, 3, 8)
    assert d.mailbox is not None and d.mailbox.data_link_layer
    assert d.mailbox.coe == EsiCoe(sdo_info=True)
    assert d.mailbox.foe and not (d.mailbox.eoe or d.mailbox.soe or d.mailbox.aoe)
    assert d.eeprom is not None and d.eeprom.byte_size == 256
    assert d.eeprom.config_data == bytes.fromhex("8002000000000000")
    assert d.eeprom.bootstrap == bytes.fromhex("0010800080108000")
    assert d.dictionary is not None and len(d.dictionary.objects) == 13
    dt1018 = next(t for t in d.dictionary.data_types if t.name == "DT1018")
    assert dt1018.bit_size == 144
    assert [(s.subindex, s.name, s.type_name, s.bit_offset, s.access) for s in dt1018.sub_items][
        1
    ] == (1, "Vendor ID", "UDINT", 16, "ro")
    arr = next(t for t in d.dictionary.data_types if t.name == "DT1C00ARR")
    assert (arr.base_type, arr.array_lower_bound, arr.array_elements) == ("USINT", 1, 4)


def test_dynpdo_dictionary_and_coe(shared_esi: Path) -> None:
    d = read_esi(shared_esi / "soes_rtl_xmc4_dynpdo.xml").device("xmc48relax")
    assert d.mailbox is not None
    assert d.mailbox.coe == EsiCoe(
        sdo_info=True, pdo_assign=True, pdo_config=True, complete_access=True
    )
    assert [(p.index, len(p.entries), p.fixed) for p in d.rx_pdos] == [
        (0x1600, 1, True),
        (0x1601, 1, True),
        (0x1602, 0, False),
    ]
    assert d.tx_pdos[0].entries == (EsiPdoEntry(0x6000, 1, 8, "Button1", "USINT"),)
    assert d.dictionary is not None
    device_type = d.dictionary.object(0x1000)
    assert device_type is not None
    assert (device_type.name, device_type.type_name, device_type.bit_size) == (
        "Device Type",
        "UDINT",
        32,
    )
    assert (device_type.default_value, device_type.access, device_type.category) == (
        "#x00001389",
        "ro",
        "m",
    )


def test_bogus_io_names_and_undeclared_sizes(shared_esi: Path) -> None:
    esi = read_esi(shared_esi / "hw_device_mgr_BogusIO.xml")
    assert esi.vendor.vendor_id == 0xB090C0
    d = esi.device("#xB0901030")  # by product code
    assert (d.type_name, d.revision) == ("B090.IO.3.0", 42)
    assert d.names[1] == (2052, "B090.IO.001 3路数字量输入/3路数字量输出")
    assert d.name == "B090.IO.001 3-ch Digital In/3-ch Digital Out"
    assert [s.default_size_bytes for s in d.sync_managers] == [None, None]
    assert d.tx_pdos[0].sync_manager == 2  # as written, though the device has SMs 0 and 1 only
    assert d.mailbox is None and d.dictionary is None
    assert d.eeprom is not None
    assert d.eeprom.config_data == bytes.fromhex("B0900000DEADBEEF")
    assert d.eeprom.bootstrap is None


def test_dc_op_mode(shared_esi: Path) -> None:
    d = read_esi(shared_esi / "soes_xmc4300_slavedemo.xml").device()
    assert d.dc_op_modes == (EsiDcOpMode("DcOff", "DC unused", 0),)
    assert d.eeprom is not None and d.eeprom.byte_size == 3968


MULTI = b"""<?xml version="1.0"?>
<EtherCATInfo>
  <Vendor><Id>2</Id><Name>Two</Name></Vendor>
  <Descriptions>
    <Groups><Group><Type>G</Type><Name>Group G</Name></Group></Groups>
    <Devices>
      <Device Physics="YK">
        <Type ProductCode="#x10" RevisionNo="#x1">A-1</Type><Name>first</Name>
        <Sm StartAddress="#x1000" ControlByte="#x20" Enable="1">Inputs</Sm>
        <Fmmu Sm="0">Inputs</Fmmu>
        <TxPdo Sm="0"><Index>#x1a00</Index><Name>In</Name><Exclude>#x1a01</Exclude>
          <Entry><Index>#x6000</Index><SubIndex>1</SubIndex><BitLen>1</BitLen><Name>b</Name><DataType>BOOL</DataType></Entry>
          <Entry><Index>0</Index><BitLen>7</BitLen></Entry>
        </TxPdo>
        <AlternativeSmMapping Default="1"><Name>Alt</Name><Sm No="0"><Pdo>#x1a00</Pdo></Sm></AlternativeSmMapping>
        <Dc><OpMode><Name>DC</Name><Desc>sync</Desc><AssignActivate>#x300</AssignActivate>
          <CycleTimeSync0 Factor="1">0</CycleTimeSync0><ShiftTimeSync0>100</ShiftTimeSync0>
          <CycleTimeSync1 Factor="-2">0</CycleTimeSync1></OpMode></Dc>
        <Eeprom><ByteSize>512</ByteSize><ConfigData>0500</ConfigData>
          <Category><CatNo>1</CatNo><Data>ABCD</Data></Category></Eeprom>
      </Device>
      <Device><Type ProductCode="#x20" RevisionNo="2">B-2</Type><Name>second</Name></Device>
    </Devices>
  </Descriptions>
</EtherCATInfo>
"""


def test_several_devices_are_picked_by_type_or_product_code() -> None:
    esi = parse_esi(MULTI)
    assert [d.type_name for d in esi.devices] == ["A-1", "B-2"]
    assert esi.device("B-2").product_code == 0x20
    assert esi.device("0x10").type_name == "A-1"
    assert esi.device("32").type_name == "B-2"
    with pytest.raises(EsiFormatError, match=r"2 devices.*A-1 \(product code 0x10\).*B-2"):
        esi.device()
    with pytest.raises(EsiFormatError, match="no device 'C'"):
        esi.device("C")
    assert esi.device("A-1@#x1") is esi.devices[0]  # @REVISION: the Type's RevisionNo="1"
    with pytest.raises(EsiFormatError, match="no device 'A-1@2'"):
        esi.device("A-1@2")
    with pytest.raises(EsiFormatError, match="'x' after @ is not a revision"):
        esi.device("A-1@x")
    a = esi.devices[0]
    assert a.line == 7 and a.physics == "YK"
    assert a.fmmus == (EsiFmmu("Inputs", 0),)
    assert a.tx_pdos[0].excludes == (0x1A01,)
    assert a.tx_pdos[0].entries[1] == EsiPdoEntry(0, 0, 7, "", "")
    assert a.alternative_sm_mappings[0].assignments == ((0, (0x1A00,)),)
    (mode,) = a.dc_op_modes
    assert (mode.assign_activate, mode.shift_time_sync0_ns, mode.cycle_time_sync1_factor) == (
        0x300,
        100,
        -2,
    )
    assert a.eeprom is not None and a.eeprom.categories[0].data == b"\xab\xcd"
    assert esi.devices[1].eeprom is None and esi.group_name("G") == "Group G"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (MULTI[:400], r"line \d+: not well-formed XML"),
        (b"<Other/>", r"line 1: <Other>: the root element"),
        (MULTI.replace(b"<Id>2</Id>", b""), r"line 3: <Vendor>: missing <Id>"),
        (MULTI.replace(b"<Id>2</Id>", b"<Id>#xG</Id>"), r"line 3: <Id>: '#xG' is not a number"),
        (
            MULTI.replace(b">Inputs</Sm>", b">Input</Sm>"),
            r"line 9: <Sm>: 'Input' is not a SyncManager type",
        ),
        (MULTI.replace(b'StartAddress="#x1000" ', b""), r"line 9: <Sm>: missing attribute"),
        (MULTI.replace(b"<BitLen>1</BitLen>", b""), r"line 12: <Entry>: missing <BitLen>"),
        (MULTI.replace(b"<Data>ABCD", b"<Data>ABC"), r"line 2\d: <Data>: 'ABC' is not hex"),
        (MULTI.replace(b">Inputs</Fmmu>", b">Out</Fmmu>"), r"line 10: <Fmmu>"),
        (MULTI.replace(b'Default="1"', b'Default="yes"'), r"<AlternativeSmMapping>: Default="),
        (
            MULTI.replace(b'<Type ProductCode="#x20" RevisionNo="2">B-2</Type>', b""),
            r"line 22: <Device>: missing <Type>",
        ),
    ],
)
def test_bad_input_names_the_element_and_line(text: bytes, message: str) -> None:
    with pytest.raises(EsiFormatError, match=message) as info:
        parse_esi(text, source="x.xml")
    assert isinstance(info.value, DecodeError) and str(info.value).startswith("x.xml: line ")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        # the SII's fields (ETG.2010): identity UDINTs, SYNCM words and bytes, the size word
        (b"<Id>2<", b"<Id>#x100000000<", "3: <Id>: #x100000000 is outside 0..4294967295"),
        (b'No="#x1"', b'No="-1"', "8: <Type>: RevisionNo=-1 is outside 0..4294967295"),
        (b'Enable="1"', b'Enable="256"', "9: <Sm>: Enable=256 is outside 0..255"),
        (b'"#x1000"', b'"65536"', "9: <Sm>: StartAddress=65536 is outside 0..65535"),
        (b'<Fmmu Sm="0">', b'<Fmmu Sm="#x100">', "10: <Fmmu>: Sm=#x100 is outside 0..255"),
        (b'<TxPdo Sm="0">', b'<TxPdo Sm="256">', "11: <TxPdo>: Sm=256 is outside 0..255"),
        # CoE: index 16 bits, subindex and mapped length 8
        (b"<Index>#x1a00<", b"<Index>#x11a00<", "11: <Index>: #x11a00 is outside 0..65535"),
        (b"<Exclude>#x1a01", b"<Exclude>-1", "11: <Exclude>: -1 is outside 0..65535"),
        (b"<SubIndex>1<", b"<SubIndex>256<", "12: <SubIndex>: 256 is outside 0..255"),
        (b"<BitLen>7<", b"<BitLen>300<", "13: <BitLen>: 300 is outside 0..255"),
        (b"<Pdo>#x1a00", b"<Pdo>#x10000", "15: <Pdo>: #x10000 is outside 0..65535"),
        (b'<Sm No="0">', b'<Sm No="-1">', "15: <Sm>: No=-1 is outside 0..255"),
        # DC (Table 14): AssignActivate a word, the cycle factors INTs
        (b"#x300<", b"#x10300<", "16: <AssignActivate>: #x10300 is outside 0..65535"),
        (b'"-2"', b'"-32769"', "18: <CycleTimeSync1>: Factor=-32769 is outside -32768..32767"),
        # the size word 0x3E: ByteSize / 128 - 1 in 16 bits
        (b"<ByteSize>512", b"<ByteSize>500", "19: <ByteSize>: 500 is not a multiple of 128"),
        (b"<ByteSize>512", b"<ByteSize>8388736", "19: <ByteSize>: 8388736 is outside 128..8388608"),
        (b"<CatNo>1<", b"<CatNo>65536<", "20: <CatNo>: 65536 is outside 0..65535"),
    ],
)
def test_a_number_outside_its_field_names_the_element_and_line(
    old: bytes, new: bytes, message: str
) -> None:
    assert MULTI.count(old) == 1
    with pytest.raises(EsiFormatError) as info:
        parse_esi(MULTI.replace(old, new), source="x.xml")
    assert str(info.value) == f"x.xml: line {message}"


def test_the_ends_of_the_ranges_are_taken() -> None:
    text = MULTI
    for old, new in (
        (b'ProductCode="#x10"', b'ProductCode="#xFFFFFFFF"'),
        (b'Enable="1"', b'Enable="255"'),
        (b"<Index>#x1a00</Index>", b"<Index>#xFFFF</Index>"),
        (b'Factor="-2"', b'Factor="-32768"'),
        (b"<ShiftTimeSync0>100<", b"<ShiftTimeSync0>-2147483648<"),
        (b"<ByteSize>512", b"<ByteSize>8388608"),
    ):
        text = text.replace(old, new)
    device = parse_esi(text).devices[0]
    assert (device.product_code, device.sync_managers[0].enable, device.tx_pdos[0].index) == (
        0xFFFF_FFFF,
        255,
        0xFFFF,
    )
    (mode,) = device.dc_op_modes
    assert (mode.cycle_time_sync1_factor, mode.shift_time_sync0_ns) == (-32768, -(2**31))
    assert device.eeprom is not None and device.eeprom.byte_size == 0x10000 * 128


def test_a_type_text_with_an_at_sign_is_matched_whole_first() -> None:
    def device(type_text: str, revision: int) -> bytes:
        return (
            f'<Device><Type ProductCode="1" RevisionNo="{revision}">{type_text}</Type></Device>'
        ).encode()

    esi = parse_esi(
        b"<EtherCATInfo><Vendor><Id>1</Id></Vendor><Descriptions><Devices>"
        + device("T@2", 7)
        + device("T", 2)
        + b"</Devices></Descriptions></EtherCATInfo>"
    )
    assert esi.device("T@2").revision == 7  # the Type text, not T at revision 2
    assert esi.device("T@2@7") is esi.devices[0]  # the last @ starts the revision


def test_empty_and_binary_input() -> None:
    for data in (b"", b"\x00\xff" * 10, "<a>é</a>".encode("latin-1")):
        with pytest.raises(EsiFormatError):
            parse_esi(data)


def _big_esi(shared_esi: Path, target_bytes: int) -> bytes:
    src = (shared_esi / "soes_rtl_xmc4_dynpdo.xml").read_bytes()
    i = src.index(b"<Objects>") + len(b"<Objects>")
    j = src.index(b"</Objects>")
    copies = target_bytes // (j - i) + 1
    return src[:i] + src[i:j] * copies + src[j:]


def test_a_10_mb_esi_reads_in_seconds_with_little_memory(shared_esi: Path) -> None:
    data = _big_esi(shared_esi, 10_000_000)
    start = time.perf_counter()
    esi = parse_esi(data)
    elapsed = time.perf_counter() - start
    dictionary = esi.device().dictionary
    assert dictionary is not None and len(dictionary.objects) > 5000
    assert elapsed < 8, f"{elapsed:.1f} s for {len(data)} bytes"
    small = _big_esi(shared_esi, 2_000_000)
    peak = traced_peak(lambda: parse_esi(small))
    assert peak < 10 * len(small), f"peak {peak} bytes for a {len(small)}-byte file"


def test_strings_and_access_restrictions(shared_esi: Path) -> None:
    d = read_esi(shared_esi / "soes_rtl_xmc4_dynpdo.xml").device()
    assert d.dictionary is not None
    name = d.dictionary.object(0x1008)
    assert name is not None and name.default_string == "xmc48relax"  # <DefaultString>
    by_name = {t.name: t for t in d.dictionary.data_types}
    count, elements = by_name["DT1C12"].sub_items  # <Access WriteRestrictions="PreOP">rw
    assert (count.access, count.write_restrictions, count.read_restrictions) == (
        "rw",
        "PreOP",
        None,
    )
    assert (elements.type_name, elements.write_restrictions) == ("DT1C12ARR", "PreOP")
    assert by_name["DT1018"].sub_items[1].write_restrictions is None  # <Access>ro</Access>


MODULAR = Path(__file__).resolve().parent.parent / "data" / "esi" / "modular_coupler.xml"


def test_a_modular_device_s_slots_and_the_file_s_modules() -> None:
    """tests/data/esi/modular_coupler.xml (ETG.2000 Slots and Modules), read by eye."""
    esi = read_esi(MODULAR)
    d = esi.device()
    assert d.slots is not None
    assert (
        d.slots.slot_index_increment,
        d.slots.slot_pdo_increment,
        d.slots.max_slot_count,
        d.slots.download_module_ident_list,
    ) == (0x10, 1, 4, True)
    head, io = d.slots.slots
    assert (head.name, head.min_instances, head.max_instances, head.line) == ("Head", 1, 1, 87)
    assert head.module_idents == (0x10002, 0x10001, 0x19999)
    assert (head.default_module_ident, head.module_classes) == (0x10001, ())
    assert (head.slot_index_increment, head.slot_pdo_increment) == (None, None)
    assert (io.name, io.min_instances, io.max_instances) == ("IO", 0, 3)
    assert (io.module_idents, io.module_classes, io.default_module_ident) == (
        (),
        ("DI", "DO"),
        None,
    )
    assert (io.slot_index_increment, io.slot_pdo_increment) == (0x20, 2)
    assert [
        (m.module_ident, m.type_name, m.module_class, m.module_pdo_group) for m in esi.modules
    ] == [
        (0x10001, "HEAD-A", "HEAD", None),
        (0x10002, "HEAD-B", "HEAD", None),
        (0x20001, "DI-8", "DI", 1),
        (0x20002, "DO-4", "DO", 0),
        (0x30001, "AI-2", "AI", None),
    ]
    di = esi.modules[2]
    assert (di.name, di.line) == ("DI-8 inputs", 115)
    (tx,) = di.tx_pdos
    assert (tx.index, tx.sync_manager, tx.fixed, tx.depend_on_slot) == (0x1A01, 3, True, True)
    assert [(e.index, e.subindex, e.bit_length, e.depend_on_slot) for e in tx.entries] == [
        (0x6010, 1, 1, True),
        (0x6010, 2, 1, True),
        (0, 0, 6, False),
    ]
    assert di.dictionary is not None and [o.index for o in di.dictionary.objects] == [0x8010]
    assert esi.modules[0].dictionary is None and esi.modules[3].rx_pdos[0].index == 0x1601
    assert [m.type_name for m in esi.slot_modules(d)] == ["HEAD-A", "HEAD-B", "DI-8", "DO-4"]
    # the coupler's own PDO is the device's; no module PDO is
    assert [p.index for p in d.tx_pdos] == [0x1AFF] and not d.tx_pdos[0].depend_on_slot


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            b'<Slot MinInstances="0" MaxInstances="3"',
            b'<Slot MinInstances="4" MaxInstances="3"',
            r"line 93: <Slot>: MinInstances 4, MaxInstances 3",
        ),
        (
            b'<Slot MinInstances="1" MaxInstances="1">',
            b'<Slot MaxInstances="1">',
            r"line 87: <Slot>: missing attribute MinInstances",
        ),
        (
            b"<ModuleIdent>#x00010002</ModuleIdent>",
            b'<ModuleIdent Default="1">#x00010002</ModuleIdent>',
            r"line 87: <Slot>: 2 <ModuleIdent> with Default=1",
        ),
        (
            b"<ModuleIdent>#x00019999</ModuleIdent>",
            b"<ModuleIdent>#x0001999Z</ModuleIdent>",
            r"line 91: <ModuleIdent>: '#x0001999Z' is not a number",
        ),
        (
            b"<ModuleClass><Class>DO</Class>",
            b"<ModuleClass><Klass>DO</Klass>",
            r"line 96: <ModuleClass>: missing <Class>",
        ),
        (
            b'<Type ModuleIdent="#x00010002" ModuleClass="HEAD">',
            b'<Type ModuleClass="HEAD">',
            r"line 112: <Type>: missing attribute ModuleIdent",
        ),
        (
            b'<Index DependOnSlot="true">#x1A01',
            b'<Index DependOnSlot="yes">#x1A01',
            r"line 120: <Index>: DependOnSlot='yes' is not a boolean",
        ),
    ],
)
def test_bad_slots_and_modules_name_the_element_and_line(
    old: bytes, new: bytes, message: str
) -> None:
    text = MODULAR.read_bytes()
    assert text.count(old) == 1
    with pytest.raises(EsiFormatError, match=message):
        parse_esi(text.replace(old, new), source="x.xml")


def test_a_slot_naming_no_module_is_an_error() -> None:
    text = MODULAR.read_bytes()
    start = text.index(b"<ModuleClass><Class>DI")
    end = text.index(b"</Slot>", start)
    bare = text[:start] + text[end:]
    with pytest.raises(EsiFormatError, match=r"line 93: <Slot>: names no <ModuleIdent>"):
        parse_esi(bare, source="x.xml")


def test_modules_in_the_slots_join_the_device_moved_by_their_slot() -> None:
    """ETG.2000/ETG.5001, by hand from modular_coupler.xml: module k is slot number k; a
    DependOnSlot index moves by k times the slot's increment (the IO slot's own: PDOs 2,
    objects 0x20; the Head slot has none, so the Slots': 1 and 0x10)."""
    esi = read_esi(MODULAR)
    d = configure_slots(esi, esi.device(), ["HEAD-B", "#x20002", "DI-8"])
    assert d.configured_modules == (0x10002, 0x20002, 0x20001)
    assert [p.index for p in d.rx_pdos] == [0x1601 + 1 * 2]
    assert [(e.index, e.subindex, e.bit_length) for e in d.rx_pdos[0].entries] == [
        (0x7010 + 1 * 0x20, 1, 4),
        (0, 0, 4),  # padding: index 0 is not moved
    ]
    assert [p.index for p in d.tx_pdos] == [0x1AFF, 0x1A01 + 2 * 2]
    assert [e.index for e in d.tx_pdos[1].entries] == [0x6010 + 2 * 0x20] * 2 + [0]
    assert d.tx_pdos[1].excludes == (0x1A02 + 2 * 2,)  # Exclude DependOnSlot="true"
    assert d.dictionary is not None
    assert [o.index for o in d.dictionary.objects][-1] == 0x8010 + 2 * 0x20
    assert not any(p.depend_on_slot for p in d.tx_pdos + d.rx_pdos)
    # the device itself is unchanged (its SII is built from it)
    assert esi.device().configured_modules == () and len(esi.device().tx_pdos) == 1


@pytest.mark.parametrize(
    ("modules", "message"),
    [
        ([], r"slot 'Head' \(line 87\) needs 1 module\(s\) at least, the modules given put 0"),
        (["DI-8"], r"slot 'Head' \(line 87\) needs 1"),
        (["HEAD-A", "HEAD-B"], r"module 2 \(HEAD-B\): no slot after the ones before takes it"),
        (["HEAD-A", *["DI-8"] * 4], r"module 5 \(DI-8\): no slot"),
        (["HEAD-A", "AI-2"], r"no module 'AI-2' its slots may hold; they may hold: HEAD-A"),
        (["HEAD-A", "0x19999"], r"no module '0x19999'"),
    ],
)
def test_modules_that_do_not_fit_the_slots_are_refused(modules: list[str], message: str) -> None:
    esi = read_esi(MODULAR)
    with pytest.raises(EsiFormatError, match=message):
        configure_slots(esi, esi.device(), modules)


def test_a_device_without_slots_takes_no_modules(shared_esi: Path) -> None:
    esi = read_esi(shared_esi / "soes_linux_lan9252demo.xml")
    with pytest.raises(EsiFormatError, match=r"has no <Slots>, so no modules"):
        configure_slots(esi, esi.device(), [])


def test_a_module_s_pdo_or_object_takes_the_place_of_the_device_s_of_its_index() -> None:
    """ETG.2000 OverwrittenByModule; vendors (Beckhoff's EP6228 and EL1904 ESIs) list the
    default modules' PDOs in the device as well. Two modules of one index are an error."""
    text = MODULAR.read_bytes()
    head_a = b'<Index DependOnSlot="1">#x1A00</Index>'
    filter_time = b'<Index DependOnSlot="true">#x8010</Index>'
    assert text.count(head_a) == 1 and text.count(filter_time) == 1
    esi = parse_esi(
        text.replace(head_a, b"<Index>#x1AFF</Index>").replace(
            filter_time, b"<Index>#x1000</Index>"
        )
    )
    d = configure_slots(esi, esi.device(), ["HEAD-A", "DI-8"])
    assert [(p.index, p.name) for p in d.tx_pdos] == [(0x1AFF, "Head A inputs"), (0x1A03, "DI-8")]
    assert d.dictionary is not None
    assert [(o.index, o.name) for o in d.dictionary.objects if o.index == 0x1000] == [
        (0x1000, "DI-8 filter time")
    ]
    do_4 = b'<Index DependOnSlot="1">#x1601</Index>'
    esi = parse_esi(text.replace(do_4, b"<Index>#x1601</Index>"), source="x.xml")
    with pytest.raises(
        EsiFormatError,
        match=r"module 3 \(DO-4, line \d+\): PDO 0x1601 is module 2 \(DO-4, line \d+\)'s",
    ):
        configure_slots(esi, esi.device(), ["HEAD-A", "DO-4", "DO-4"])
