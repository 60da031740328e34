"""Slaves described by third-party ESI files (../shared/esi), emulated behind the ESC.

Expected values are the XML's (read here with ElementTree) and ETG.1000.6's: the dictionary's
objects and defaults, the default PDO assignment (PDOs with an ``Sm``), the access the ESI
grants (``Fixed``, ``PdoAssign``/``PdoConfig``, ``WriteRestrictions="PreOP"``, ``Mandatory``),
abort codes (Table 41) and AL status codes (Table 11). The SyncManagers are programmed and the
states requested through frames, as a master does.
"""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from emulator.errors import TopologyError
from emulator.esc.chain import EcatChain
from emulator.live import TaxelFeed, mixed_chain
from emulator.slave.coe import CoeServer
from emulator.slave.esi_objects import EsiDictionary
from emulator.slave.esi_slave import EsiApplication, check_esi_slave, esi_device, load_esi_slave
from skinframes import ecat_mailbox as mb
from skinframes import ethercat
from skinframes.ecat_mailbox import SdoAbort, SdoInfoOpcode
from skinframes.esi import missing_communication_objects, read_esi
from skinframes.ethercat import Command as C  # noqa: N817
from skinframes.ethercat import Datagram, EcatFrame
from skinframes_cli import main

LAN9252, DYNPDO = "soes_linux_lan9252demo", "soes_rtl_xmc4_dynpdo"
PREOP, SAFEOP, OP = 0x02, 0x04, 0x08
STATION = 0x1001


def n(text: str | None) -> int:
    s = (text or "").strip()
    return int(s[2:], 16) if s.startswith("#x") else int(s)


def xml_device(path: Path) -> ET.Element:
    device = ET.parse(path).getroot().find("Descriptions/Devices/Device")
    assert device is not None
    return device


def dictionary(shared_esi: Path, name: str) -> tuple[EsiApplication, EsiDictionary]:
    dev = esi_device(load_esi_slave(str(shared_esi / f"{name}.xml")))
    app = dev.app
    assert isinstance(app, EsiApplication) and isinstance(app.objects, EsiDictionary)
    return app, app.objects


@pytest.mark.parametrize("name", [LAN9252, DYNPDO, "soes_rtl_lwip_eoe", "soes_tiesc_k2gice"])
def test_the_dictionary_is_the_xmls(shared_esi: Path, name: str) -> None:
    path = shared_esi / f"{name}.xml"
    root = ET.parse(path).getroot()
    device = xml_device(path)
    _, od = dictionary(shared_esi, name)
    objects = list(device.iterfind("Profile/Dictionary/Objects/Object"))
    assert od.indices() == sorted(n(o.findtext("Index")) for o in objects)
    for o in objects:
        index = n(o.findtext("Index"))
        default = o.findtext("Info/DefaultValue")
        string = o.findtext("Info/DefaultString")
        if default is not None:  # a VAR with a number: little-endian in its bits
            size = n(o.findtext("BitSize")) // 8
            assert od.read(index, 0, PREOP) == n(default).to_bytes(size, "little"), hex(index)
        if string is not None:  # a STRING(n) of BitSize 8 n: NUL-padded to it; STRING(0): as is
            size = n(o.findtext("BitSize")) // 8
            assert od.read(index, 0, PREOP) == string.encode().ljust(size, b"\0"), hex(index)
    type_el = device.find("Type")
    assert type_el is not None
    identity = [od.read(0x1018, k, PREOP) for k in range(1, 5)]
    assert [int.from_bytes(v, "little") for v in identity] == [  # type: ignore[arg-type]
        n(root.findtext("Vendor/Id")),
        n(type_el.get("ProductCode")),
        n(type_el.get("RevisionNo")),
        0,  # the SII's serial number, as skinframes sii writes it
    ]
    for tag, assign in (("RxPdo", 0x1C12), ("TxPdo", 0x1C13)):
        pdos = [p for p in device.iterfind(tag) if p.get("Sm") is not None]
        ca = od.read_complete(assign, 0, PREOP)
        assert ca == bytes([len(pdos), 0]) + b"".join(
            struct.pack("<H", n(p.findtext("Index"))) for p in pdos
        )
        for p in pdos:  # the mapping: index << 16 | subindex << 8 | bits of each Entry
            words = [
                n(e.findtext("Index")) << 16
                | n(e.findtext("SubIndex")) << 8
                | n(e.findtext("BitLen"))
                for e in p.iterfind("Entry")
            ]
            mapping = od.read_complete(n(p.findtext("Index")), 0, PREOP)
            assert mapping == bytes([len(words), 0]) + b"".join(struct.pack("<I", w) for w in words)


def test_what_the_esi_forbids_is_refused(shared_esi: Path) -> None:
    _, lan = dictionary(shared_esi, LAN9252)
    # lan9252: 0x1C13 and the fixed 0x1A00 are "ro", and the ESI offers no PdoAssign/PdoConfig
    assert lan.write(0x1C13, 0, b"\x00", PREOP) == SdoAbort.READ_ONLY
    assert lan.write(0x1A00, 0, b"\x00", PREOP) == SdoAbort.READ_ONLY
    _, dyn = dictionary(shared_esi, DYNPDO)
    assert dyn.write(0x1600, 0, b"\x00", PREOP) == SdoAbort.READ_ONLY  # RxPdo Fixed="true"
    assert dyn.write(0x1602, 1, bytes(4), SAFEOP) == SdoAbort.DEVICE_STATE  # WriteRestrictions
    # entries change only while subindex 0 is 0 (ETG.1000.6 5.6.2)
    assert dyn.write(0x1C12, 1, struct.pack("<H", 0x1602), PREOP) == SdoAbort.SUBINDEX0_NOT_ZERO
    assert dyn.write(0x1C12, 0, b"\x00", PREOP) is None
    # 0x1601 is Mandatory: an assignment without it is refused; with it, accepted
    for k, pdo in enumerate((0x1600, 0x1602), start=1):
        assert dyn.write(0x1C12, k, struct.pack("<H", pdo), PREOP) is None
    assert dyn.write(0x1C12, 0, b"\x02", PREOP) == SdoAbort.VALUE_RANGE
    assert dyn.write(0x1C12, 2, struct.pack("<H", 0x1A00), PREOP) is None  # a TxPDO
    assert dyn.write(0x1C12, 0, b"\x02", PREOP) == SdoAbort.VALUE_RANGE
    assert dyn.write(0x1C12, 2, struct.pack("<H", 0x1601), PREOP) is None
    assert dyn.write(0x1C12, 0, b"\x02", PREOP) is None
    assert dyn.assigned(2) == [0x1600, 0x1601]
    # a mapping of an object no PDO maps (0x8001 variableRW) is refused
    assert dyn.write(0x1A01, 1, struct.pack("<I", 0x8001_00_20), PREOP) is None
    assert dyn.write(0x1A01, 0, b"\x01", PREOP) == SdoAbort.NOT_MAPPABLE
    # 0x6000:1 is 8 bits: mapped with 16 it is refused too, with 8 accepted
    assert dyn.write(0x1A01, 1, struct.pack("<I", 0x6000_01_10), PREOP) is None
    assert dyn.write(0x1A01, 0, b"\x01", PREOP) == SdoAbort.NOT_MAPPABLE
    assert dyn.write(0x1A01, 1, struct.pack("<I", 0x6000_01_08), PREOP) is None
    assert dyn.write(0x1A01, 0, b"\x01", PREOP) is None
    assert dyn.mapped(0x1A01) == [(0x6000, 1, 8)]


def test_a_gap_in_a_record_does_not_exist_but_is_described(shared_esi: Path) -> None:
    _, dyn = dictionary(shared_esi, DYNPDO)
    # DT1C32 has SubIdx 0..18 and 32
    assert dyn.read(0x1C32, 19, PREOP) == SdoAbort.NO_SUBINDEX
    assert dyn.read(0x1C32, 32, PREOP) == bytes(1)  # SyncError, BOOL, default 0
    server = CoeServer(dyn, 512)
    request = mb.sdo_info_header(SdoInfoOpcode.ENTRY_DESCRIPTION_REQUEST) + struct.pack(
        "<HBB", 0x1C32, 19, 0x07
    )
    (answer,) = server.handle(mb.coe_header(mb.CoeService.SDO_INFORMATION)[:2] + request[2:], PREOP)
    at = mb.COE_HEADER_BYTES + mb.SDO_INFO_HEADER_BYTES
    assert answer[mb.COE_HEADER_BYTES] & 0x7F == SdoInfoOpcode.ENTRY_DESCRIPTION_RESPONSE
    # index, subindex, value info, data type 0, bit length 0, access 0, no name
    assert answer[at:] == struct.pack("<HBBHHH", 0x1C32, 19, 0x07, 0, 0, 0)


class Master:
    """Just enough of a master: datagrams through the chain."""

    def __init__(self, chain: EcatChain) -> None:
        self.chain = chain

    def one(self, d: Datagram) -> Datagram:
        back = self.chain.process_frame(ethercat.frame(EcatFrame((d,))).to_bytes())
        assert back is not None
        ecat, _, _ = ethercat.decode(back[14:], strict=False)
        return ecat.datagrams[0]

    def wr(self, ado: int, data: bytes) -> int:
        return self.one(Datagram(C.FPWR, STATION, ado, data)).wkc

    def rd(self, ado: int, size: int) -> bytes:
        return self.one(Datagram(C.FPRD, STATION, ado, bytes(size))).data

    def state(self, value: int) -> tuple[int, int]:
        self.one(Datagram(C.BWR, 0, 0x0120, struct.pack("<H", value)))
        return int.from_bytes(self.rd(0x0130, 2), "little"), int.from_bytes(
            self.rd(0x0134, 2), "little"
        )


def sm(start: int, length: int, control: int, enable: int) -> bytes:
    """SyncManager registers 0x0800 + 8 n (datasheet II 2.14)."""
    return struct.pack("<HHBBBB", start, length, control, 0, enable, 0)


def test_a_reconfigured_pdo_sets_the_input_length(shared_esi: Path) -> None:
    dev = esi_device(load_esi_slave(str(shared_esi / f"{DYNPDO}.xml")))
    chain = EcatChain([dev])
    m = Master(chain)
    m.one(Datagram(C.APWR, 0, 0x0010, struct.pack("<H", STATION)))
    # the XML's Sms: MBoxOut 0x1000/512 #x26, MBoxIn 0x1200/512 #x22, Outputs 0x1400 #x64,
    # Inputs 0x1A00 #x20
    assert m.wr(0x0800, sm(0x1000, 512, 0x26, 1) + sm(0x1200, 512, 0x22, 1)) == 1
    assert m.state(PREOP) == (PREOP, 0)
    app = dev.app
    assert isinstance(app, EsiApplication) and isinstance(app.objects, EsiDictionary)
    od = app.objects
    # TXPDO 2 (0x1A01, no entries in the ESI, not Fixed) maps 0x6000:1; both TxPDOs assigned
    assert od.write(0x1A01, 1, struct.pack("<I", 0x6000_01_08), PREOP) is None
    assert od.write(0x1A01, 0, b"\x01", PREOP) is None
    assert (
        od.write_complete(0x1C13, 0, bytes([2, 0]) + struct.pack("<HH", 0x1A00, 0x1A01), PREOP)
        is None
    )
    outputs = sm(0x1400, 2, 0x64, 1)  # RXPDO 1 + 2: 2 bytes, as the ESI assigns them
    # inputs programmed with the one byte of the default assignment: refused, 0x001E
    assert m.wr(0x0810, outputs + sm(0x1A00, 1, 0x20, 1)) == 1
    assert m.state(SAFEOP) == (PREOP | 0x10, 0x001E)
    # an enabled SyncManager keeps its settings (datasheet II 2.14): off, then as it should be
    assert m.wr(0x0818, sm(0x1A00, 1, 0x20, 0)) == 1
    assert m.wr(0x0818, sm(0x1A00, 2, 0x20, 1)) == 1
    assert m.state(SAFEOP | 0x10) == (SAFEOP, 0)
    app.count(dev)
    app.count(dev)
    # both entries are 0x6000:1 (8 bits): the counter, twice (ETG.1000.6 5.6.7 packing)
    assert app.image(3) == bytes([2, 2])
    assert od.read(0x6000, 1, SAFEOP) == bytes([2])


def test_a_mixed_line_publishes_taxels_and_counts(shared_esi: Path) -> None:
    slave = load_esi_slave(str(shared_esi / f"{LAN9252}.xml"))
    chain = mixed_chain(2, 16, [lambda: esi_device(slave)])
    assert [d.info.serial for d in chain.devices] == [1, 2, 0]
    feed = TaxelFeed(2, 16, samples=4, seed=1)
    assert feed.publish(chain, 0.0) and feed.publish(chain, 1.0)
    patches = [d.app.inputs for d in chain.devices[:2]]  # type: ignore[attr-defined]
    assert patches == [feed.payloads[1][p].tobytes() for p in range(2)]
    app = chain.devices[2].app
    assert isinstance(app, EsiApplication) and app.counter == 2


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--nodes", "0", "--esi", "{esi}/none.xml"], "--esi {esi}/none.xml: No such file"),
        (
            ["--nodes", "0", "--esi", "{esi}/soes_linux_lan9252demo.xml#x"],
            "--esi {esi}/soes_linux_lan9252demo.xml#x: no device 'x' in the ESI",
        ),
        (  # its TxPdo names Sm 2; the device has SMs 0 and 1 (SOURCES.md)
            ["--nodes", "0", "--esi", "{esi}/hw_device_mgr_BogusIO.xml"],
            "--esi {esi}/hw_device_mgr_BogusIO.xml: ESI device B090.IO.3.0 (line 24): "
            "TxPdo 0x1a00 is assigned to Sm 2, the device has 2 SyncManagers",
        ),
        (
            ["--nodes", "2", "--esi", "{esi}/soes_linux_lan9252demo.xml"],
            "serve ecat: --bytes is required with --nodes > 0",
        ),
    ],
)
def test_bad_esi_is_one_error_line(
    capsys: pytest.CaptureFixture[str], shared_esi: Path, args: list[str], message: str
) -> None:
    argv = [a.format(esi=shared_esi) for a in args]
    assert main(["serve", "ecat", "--iface", "lo", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"skinframes: error: {message.format(esi=shared_esi)}")
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    "name", [LAN9252, DYNPDO, "soes_rtl_lwip_eoe", "soes_tiesc_k2gice", "soes_xmc4300_slavedemo"]
)
def test_distributed_clocks_only_where_the_esi_has_them(shared_esi: Path, name: str) -> None:
    has_dc = xml_device(shared_esi / f"{name}.xml").find("Dc/OpMode") is not None
    m = Master(EcatChain([esi_device(load_esi_slave(str(shared_esi / f"{name}.xml")))]))
    # ESC features 0x0008: bit 2 distributed clocks, bit 3 64-bit (datasheet II 2.1), what
    # SOEM's config_init reads to decide whether a slave has DC
    features = m.one(Datagram(C.APRD, 0, 0x0008, bytes(2))).data
    assert int.from_bytes(features, "little") & 0x0C == (0x0C if has_dc else 0)


# A record whose SubItem 1 is a whole byte array (SubIdx given: one entry, as an Ingenia drive's
# 0x58B2 "Monitoring data" with ARRAY [0..511] OF BYTE), and an array of 300 elements, which no
# CoE subindex (one byte) can address.
BYTE_BLOCK_TYPES = """
<DataType><Name>ARRAY [0..7] OF BYTE</Name><BaseType>BYTE</BaseType><BitSize>64</BitSize>
  <ArrayInfo><LBound>0</LBound><Elements>8</Elements></ArrayInfo></DataType>
<DataType><Name>DT2100</Name><BitSize>80</BitSize>
  <SubItem><SubIdx>0</SubIdx><Name>SubIndex 000</Name><Type>USINT</Type><BitSize>8</BitSize>
    <BitOffs>0</BitOffs><Flags><Access>ro</Access></Flags></SubItem>
  <SubItem><SubIdx>1</SubIdx><Name>Block</Name><Type>ARRAY [0..7] OF BYTE</Type>
    <BitSize>64</BitSize><BitOffs>16</BitOffs><Flags><Access>ro</Access></Flags></SubItem>
</DataType>
<DataType><Name>DT2101ARR</Name><BaseType>USINT</BaseType><BitSize>2400</BitSize>
  <ArrayInfo><LBound>1</LBound><Elements>300</Elements></ArrayInfo></DataType>
<DataType><Name>DT2101</Name><BitSize>2416</BitSize>
  <SubItem><SubIdx>0</SubIdx><Name>SubIndex 000</Name><Type>USINT</Type><BitSize>8</BitSize>
    <BitOffs>0</BitOffs><Flags><Access>ro</Access></Flags></SubItem>
  <SubItem><Name>Elements</Name><Type>DT2101ARR</Type><BitSize>2400</BitSize>
    <BitOffs>16</BitOffs><Flags><Access>ro</Access></Flags></SubItem>
</DataType>
"""
BYTE_BLOCK = """
<Object><Index>#x2100</Index><Name>Byte block</Name><Type>DT2100</Type><BitSize>80</BitSize>
  <Info><SubItem><Name>SubIndex 000</Name><Info><DefaultData>01</DefaultData></Info></SubItem>
  <SubItem><Name>Block</Name><Info><DefaultData>0102030405060708</DefaultData></Info></SubItem>
  </Info></Object>
"""
LONG_ARRAY = """
<Object><Index>#x2101</Index><Name>Long array</Name><Type>DT2101</Type><BitSize>2416</BitSize>
</Object>
"""


def with_objects(shared_esi: Path, tmp_path: Path, objects: str) -> Path:
    xml = (shared_esi / f"{LAN9252}.xml").read_text(encoding="utf-8")
    xml = xml.replace("<DataTypes>", "<DataTypes>" + BYTE_BLOCK_TYPES, 1)
    xml = xml.replace("</Objects>", objects + "</Objects>", 1)
    path = tmp_path / "blocks.xml"
    path.write_text(xml, encoding="utf-8")
    return path


def test_an_array_typed_subitem_with_a_subindex_is_one_entry(
    shared_esi: Path, tmp_path: Path
) -> None:
    dev = esi_device(load_esi_slave(str(with_objects(shared_esi, tmp_path, BYTE_BLOCK))))
    od = dev.app.objects
    assert isinstance(od, EsiDictionary)
    assert od.read(0x2100, 0, PREOP) == b"\x01"
    assert od.read(0x2100, 1, PREOP) == bytes(range(1, 9))  # the 64 bits, one entry
    assert od.read(0x2100, 2, PREOP) == SdoAbort.NO_SUBINDEX
    block = od.entry(0x2100, 1)
    assert not isinstance(block, int) and block.bit_length == 64


def test_an_array_beyond_subindex_255_is_refused(shared_esi: Path, tmp_path: Path) -> None:
    path = with_objects(shared_esi, tmp_path, LONG_ARRAY)
    with pytest.raises(TopologyError) as info:
        check_esi_slave(str(path))  # what serve ecat --esi runs before serving
    assert str(info.value).endswith(
        "object 0x2101: subindex 300 (type DT2101); CoE subindices are 0..255"
    )


NO_1C00 = Path(__file__).resolve().parent.parent / "data" / "esi" / "coe_without_1c00.xml"
SM_TYPES = {"MBoxOut": 1, "MBoxIn": 2, "Outputs": 3, "Inputs": 4}  # ETG.1000.6 0x1C00 values


def test_a_dictionary_without_0x1c00_gets_it_and_the_assignments_from_the_esi() -> None:
    """tests/data/esi/coe_without_1c00.xml lacks 0x1C00, 0x1C12 and 0x1C13 (ETG.1000.6 5.6.7.4
    has them in every CoE slave with SyncManagers): they are made from its Sm elements and
    default assignment, 0x1C12/0x1C13 with room for each PDO of their direction that may go
    there, and changed in PRE-OP as ``PdoAssign`` allows and ``Exclude`` forbids."""
    device = xml_device(NO_1C00)
    esi_objects = [
        n(o.findtext("Index")) for o in device.iterfind("Profile/Dictionary/Objects/Object")
    ]
    assert not {0x1C00, 0x1C12, 0x1C13} & set(esi_objects)
    od = esi_device(load_esi_slave(str(NO_1C00))).app.objects
    assert isinstance(od, EsiDictionary)
    assert od.indices() == sorted([*esi_objects, 0x1C00, 0x1C12, 0x1C13])
    types = [SM_TYPES[(s.text or "").strip()] for s in device.iterfind("Sm")]
    assert od.read(0x1C00, 0, PREOP) == bytes([len(types)]) == b"\x04"
    assert [od.read(0x1C00, k, OP) for k in range(1, 5)] == [bytes([t]) for t in types]
    assert od.write(0x1C00, 3, b"\x04", PREOP) == SdoAbort.READ_ONLY
    # default assignment: the PDOs with an Sm (0x1600 on 2, 0x1A00 on 3); 0x1A01 has none
    assert (od.assigned(2), od.assigned(3)) == ([0x1600], [0x1A00])
    assert od.read(0x1C13, 0, PREOP) == b"\x01"
    assert od.read(0x1C13, 1, PREOP) == struct.pack("<H", 0x1A00)
    assert od.read(0x1C13, 3, PREOP) == SdoAbort.NO_SUBINDEX  # room for 0x1A00 and 0x1A01
    assert od.read(0x1C12, 2, PREOP) == SdoAbort.NO_SUBINDEX  # room for 0x1600 alone
    # PdoAssign="1": 0x1C13 changes in PRE-OP, not in SAFE-OP; 0x1A00 and 0x1A01 exclude each other
    assert od.write(0x1C13, 0, b"\x00", SAFEOP) == SdoAbort.DEVICE_STATE
    assert od.write(0x1C13, 0, b"\x00", PREOP) is None
    assert od.write(0x1C13, 2, struct.pack("<H", 0x1A01), PREOP) is None
    assert od.write(0x1C13, 0, b"\x02", PREOP) == SdoAbort.INCOMPATIBLE_PARAMETER
    assert od.write(0x1C13, 1, struct.pack("<H", 0x1A01), PREOP) is None
    assert od.write(0x1C13, 0, b"\x01", PREOP) is None
    assert od.assigned(3) == [0x1A01]


def test_a_pdo_without_its_mapping_object_gets_one(shared_esi: Path) -> None:
    """tests/data/esi/modular_coupler.xml: its own TxPdo 0x1AFF (0xF100:0, 16 bits, Fixed) has
    no mapping object in the Dictionary, nor are 0x1C00/0x1C12/0x1C13 there: all are made
    (ETG.1000.6 5.6.7.3), 0x1C12 with no room (no RxPdo of the coupler's own)."""
    path = NO_1C00.parent / "modular_coupler.xml"
    od = esi_device(load_esi_slave(str(path))).app.objects
    assert isinstance(od, EsiDictionary)
    esi_objects = [
        n(o.findtext("Index"))
        for o in xml_device(path).iterfind("Profile/Dictionary/Objects/Object")
    ]
    assert od.indices() == sorted([*esi_objects, 0x1AFF, 0x1C00, 0x1C12, 0x1C13])
    assert od.read(0x1AFF, 0, PREOP) == b"\x01"
    assert od.read(0x1AFF, 1, PREOP) == struct.pack("<I", 0xF100_00_10)
    assert od.write(0x1AFF, 0, b"\x00", PREOP) == SdoAbort.READ_ONLY  # PdoConfig="0", Fixed
    assert od.assigned(3) == [0x1AFF] and od.read(0x1C12, 0, PREOP) == b"\x00"
    assert od.write(0x1C13, 0, b"\x00", PREOP) is None  # PdoAssign="1"


def test_only_what_the_dictionary_lacks_is_made(shared_esi: Path, tmp_path: Path) -> None:
    """An ESI with 0x1C12/0x1C13 and no 0x1C00 (as some drives' ESIs are) gets 0x1C00 alone;
    a CoE ESI with no dictionary and no PDOs gets 0x1C00 alone; no CoE, nothing."""
    xml = (shared_esi / f"{LAN9252}.xml").read_text(encoding="utf-8")
    start = xml.index("<Object>", xml.index("<Index>#x1C00</Index>") - 40)
    end = xml.index("</Object>", start) + len("</Object>")
    assert "#x1C00" in xml[start:end] and "#x1C12" not in xml[start:end]
    path = tmp_path / "lan9252_without_1c00.xml"
    path.write_text(xml[:start] + xml[end:], encoding="utf-8")
    _, lan = dictionary(shared_esi, LAN9252)
    od = esi_device(load_esi_slave(str(path))).app.objects
    assert isinstance(od, EsiDictionary)
    assert od.indices() == lan.indices()  # 0x1C00 made again
    for k in range(5):  # as the ESI's own 0x1C00 (SubIndex 0 = 4, then 1 2 3 4)
        assert od.read(0x1C00, k, PREOP) == lan.read(0x1C00, k, PREOP)
    xmc_path = shared_esi / "soes_xmc4300_slavedemo.xml"
    sms = [(s.text or "").strip() for s in xml_device(xmc_path).iterfind("Sm")]
    assert sms == ["MBoxOut", "MBoxIn", "Outputs", "Inputs"]  # and no PDO, no Dictionary
    xmc = esi_device(load_esi_slave(str(xmc_path))).app.objects
    assert isinstance(xmc, EsiDictionary) and xmc.indices() == [0x1C00, 0x1C12, 0x1C13]
    assert [xmc.read(0x1C00, k, PREOP) for k in range(5)] == [bytes([t]) for t in (4, 1, 2, 3, 4)]
    assert xmc.read(0x1C13, 0, PREOP) == b"\x00"  # nothing to assign: subindex 0 alone
    assert xmc.read(0x1C13, 1, PREOP) == SdoAbort.NO_SUBINDEX
    assert xmc.write(0x1C13, 0, b"\x01", PREOP) == SdoAbort.READ_ONLY  # no PdoAssign
    bogus = read_esi(shared_esi / "hw_device_mgr_BogusIO.xml")  # no Mailbox at all
    assert missing_communication_objects(bogus.device()) == ()
