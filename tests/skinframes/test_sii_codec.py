"""The SII codec against the images shipped with third-party ESI files, round trips, bad images.

What the shipped images hold is read with this file's own ElementTree look-ups of the XML and
with tests/mini_master.py's category walk, not with the code under test.
"""

from __future__ import annotations

import contextlib
import struct
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from mini_master import find_category

from emulator.slave.sii import SlaveInfo, build_sii
from skinframes.errors import FieldRangeError, LengthMismatchError, TruncatedError
from skinframes.esi import read_esi
from skinframes.sii import (
    SiiDc,
    SiiGeneral,
    SiiImage,
    SiiPdo,
    SiiPdoEntry,
    SiiSyncManager,
    SyncManagerType,
    config_area,
    crc8,
    decode_sii,
    encode_sii,
    sii_from_esi,
    stated_eeprom_kibit,
)

SHIPPED = [
    "soes_linux_lan9252demo",
    "soes_rtl_lwip_eoe",
    "soes_rtl_xmc4_dynpdo",
    "soes_tiesc_k2gice",
    "soes_xmc4300_slavedemo",
]
SM_TYPE = {"MBoxOut": 1, "MBoxIn": 2, "Outputs": 3, "Inputs": 4}
FMMU_USE = {"Outputs": 1, "Inputs": 2, "MBoxState": 3}


def _num(text: str | None) -> int:
    s = (text or "").strip()
    return int(s[2:], 16) if s.startswith("#x") else int(s)


def xml_facts(path: Path) -> dict[str, object]:
    """What the XML says, read with plain ElementTree (independent of skinframes.esi)."""
    root = ET.parse(path).getroot()
    dev = root.find("Descriptions/Devices/Device")
    assert dev is not None
    typ = dev.find("Type")
    assert typ is not None
    sms = [
        (
            _num(s.get("StartAddress")),
            _num(s.get("DefaultSize", "0")),
            _num(s.get("ControlByte")),
            _num(s.get("Enable")),
            SM_TYPE[(s.text or "").strip()],
        )
        for s in dev.iterfind("Sm")
    ]
    return {
        "identity": (
            _num(root.findtext("Vendor/Id")),
            _num(typ.get("ProductCode")),
            _num(typ.get("RevisionNo")),
        ),
        "config": bytes.fromhex(dev.findtext("Eeprom/ConfigData") or "").ljust(14, b"\x00"),
        "bootstrap": bytes.fromhex(dev.findtext("Eeprom/BootStrap") or "00" * 8),
        "byte_size": _num(dev.findtext("Eeprom/ByteSize")),
        "sms": sms,
        "fmmus": [FMMU_USE[(f.text or "").strip()] for f in dev.iterfind("Fmmu")],
        "protocols": sum(
            bit
            for tag, bit in (("AoE", 1), ("EoE", 2), ("CoE", 4), ("FoE", 8), ("SoE", 16))
            if dev.find(f"Mailbox/{tag}") is not None
        ),
    }


@pytest.fixture(params=SHIPPED)
def pair(request: pytest.FixtureRequest, shared_esi: Path) -> tuple[Path, bytes]:
    name = str(request.param)
    return shared_esi / f"{name}.xml", (shared_esi / f"{name}.bin").read_bytes()


def test_every_shipped_image_is_listed(shared_esi: Path) -> None:
    assert sorted(p.stem for p in shared_esi.glob("*.bin")) == SHIPPED


def test_our_image_equals_the_shipped_one_where_both_follow_the_xml(
    pair: tuple[Path, bytes],
) -> None:
    xml, shipped = pair
    esi = read_esi(xml)
    ours = encode_sii(sii_from_esi(esi, esi.device()).image)
    assert ours[0:16] == shipped[0:16]  # ConfigData (words 0-6) and the checksum (word 7)
    assert ours[16:32] == shipped[16:32]  # vendor, product, revision, serial
    assert ours[0x28:0x3A] == shipped[0x28:0x3A]  # bootstrap, standard mailboxes, protocols
    assert ours[0x7C:0x80] == shipped[0x7C:0x80]  # size word, version
    assert ours[:0x80] == shipped[:0x80]  # the whole header, reserved words too
    assert find_category(ours, 41) == find_category(shipped, 41)  # SYNCM
    assert find_category(ours, 40) == find_category(shipped, 40)  # FMMU
    # and both say what the XML says
    facts = xml_facts(xml)
    assert shipped[0:14] == facts["config"] and shipped[14] == crc8(shipped[0:14])
    assert struct.unpack_from("<III", shipped, 16) == facts["identity"]
    assert shipped[0x28:0x30] == facts["bootstrap"]
    assert struct.unpack_from("<H", shipped, 0x38)[0] == facts["protocols"]
    assert struct.unpack_from("<HH", shipped, 0x7C) == (facts["byte_size"] // 128 - 1, 1)  # type: ignore[operator]
    syncm = find_category(shipped, 41)
    assert syncm is not None
    assert [(s, n, c, e, t) for s, n, c, _, e, t in struct.iter_unpack("<HHBBBB", syncm)] == facts[
        "sms"
    ]


def test_decoding_a_shipped_image_gives_what_the_xml_says(pair: tuple[Path, bytes]) -> None:
    xml, shipped = pair
    facts = xml_facts(xml)
    decoded = decode_sii(shipped)
    # SOES's xmc4300 image is its used 292 bytes of the 3968 its ByteSize (and size word) say
    short = len(shipped) < facts["byte_size"]  # type: ignore[operator]
    assert [f.code for f in decoded.findings] == (["sii.short"] if short else [])
    img = decoded.image
    assert (img.vendor_id, img.product_code, img.revision) == facts["identity"]
    assert img.config_data == facts["config"] and img.serial == 0
    assert img.eeprom_bytes == facts["byte_size"]
    assert img.mailbox_protocols == facts["protocols"]
    assert [(s.start, s.length, s.control, s.enable, s.type) for s in img.sync_managers] == facts[
        "sms"
    ]
    assert list(img.fmmus) == facts["fmmus"]
    boot = facts["bootstrap"]
    assert isinstance(boot, bytes)
    assert img.bootstrap_rx_mailbox + img.bootstrap_tx_mailbox == struct.unpack("<4H", boot)
    mbx = [(s[0], s[1]) for s in facts["sms"] if s[4] in (1, 2)]  # type: ignore[attr-defined, index]
    assert [img.standard_rx_mailbox, img.standard_tx_mailbox] == mbx


# Where the shipped images part from their ESI. SOURCES.md: their strings, GENERAL and DC
# categories come from SOES's own tools, and they carry no PDO categories.
def test_where_the_shipped_images_disagree_with_their_esi(shared_esi: Path) -> None:
    # xmc4300: the ESI has one DC op mode (DcOff, AssignActivate 0); the image has two entries,
    # the second with AssignActivate 0x0100, and is 292 bytes where ByteSize says 3968
    xml = shared_esi / "soes_xmc4300_slavedemo.xml"
    shipped = decode_sii((shared_esi / "soes_xmc4300_slavedemo.bin").read_bytes())
    assert [d.assign_activate for d in shipped.image.dc] == [0, 0x0100]
    esi = read_esi(xml)
    ours = sii_from_esi(esi, esi.device()).image
    assert [d.assign_activate for d in ours.dc] == [0]
    assert len((shared_esi / "soes_xmc4300_slavedemo.bin").read_bytes()) == 292
    assert len(encode_sii(ours)) == 3968
    # lan9252: the image's CoE details (GENERAL byte 5) 0x13 set "upload at start-up" (bit 4),
    # the ESI says PdoUpload="false": 0x03 (SDO, SDO information)
    lan = decode_sii((shared_esi / "soes_linux_lan9252demo.bin").read_bytes()).image
    assert lan.general is not None and lan.general.coe_details == 0x13
    esi = read_esi(shared_esi / "soes_linux_lan9252demo.xml")
    general = sii_from_esi(esi, esi.device()).image.general
    assert general is not None and general.coe_details == 0x03
    # no shipped image carries TXPDO/RXPDO; ours do where ByteSize leaves room (k2gice, 2 KiB),
    # and leave them out where it does not (256-byte EEPROMs of CoE devices: CoE has them)
    for name in SHIPPED:
        assert find_category((shared_esi / f"{name}.bin").read_bytes(), 50) is None
    esi = read_esi(shared_esi / "soes_tiesc_k2gice.xml")
    built = sii_from_esi(esi, esi.device())
    assert built.omitted == () and [p.index for p in built.image.tx_pdos] == [0x1A00]
    esi = read_esi(shared_esi / "soes_linux_lan9252demo.xml")
    built = sii_from_esi(esi, esi.device())
    assert built.image.tx_pdos == () and "TXPDO" in built.omitted[-1]


def test_a_device_without_coe_keeps_its_pdos(shared_esi: Path) -> None:
    esi = read_esi(shared_esi / "hw_device_mgr_BogusIO.xml")
    built = sii_from_esi(esi, esi.device())
    img = built.image
    assert built.omitted == ()
    assert img.rx_pdos == (
        SiiPdo(
            0x1600,
            0,
            (SiiPdoEntry(0x7000, 1, 8, 0x05, img.rx_pdos[0].entries[0].name_index),),
            0,
            img.rx_pdos[0].name_index,
            0x12,  # Fixed="1": fixed content 0x10; Sm="0": default 0x02; not Mandatory
        ),
    )
    assert img.string(img.rx_pdos[0].name_index) == "DOut(0-2)"
    assert img.string(img.rx_pdos[0].entries[0].name_index) == "Outputs"
    assert img.tx_pdos[0].sync_manager == 2  # as the ESI writes it
    raw = encode_sii(img)
    assert raw[:8] == bytes.fromhex("B0900000DEADBEEF") and len(raw) == 2048
    assert decode_sii(raw).image == img


def test_emulator_images_round_trip_byte_for_byte() -> None:
    for info in (
        SlaveInfo.skin_patch(192, serial=7, alias=0x1234),
        SlaveInfo.skin_patch(16, output_bytes=4),
        SlaveInfo.skin_patch(400, mailbox=True, output_bytes=8),
    ):
        raw = build_sii(info)
        decoded = decode_sii(raw)
        assert decoded.findings == ()
        assert encode_sii(decoded.image) == raw
        assert decoded.image.alias == info.alias
        assert decoded.image.string(decoded.image.general.name_index) == info.name  # type: ignore[union-attr]


u8, u16, u32 = (st.integers(0, (1 << b) - 1) for b in (8, 16, 32))
entries = st.builds(SiiPdoEntry, u16, u8, u8, u8, u8, u16)
pdos = st.builds(SiiPdo, u16, u8, st.lists(entries, max_size=4).map(tuple), u8, u8, u16)
images = st.builds(
    SiiImage,
    config_data=st.binary(min_size=14, max_size=14),
    vendor_id=u32,
    product_code=u32,
    revision=u32,
    serial=u32,
    eeprom_bytes=st.just(8192),
    bootstrap_rx_mailbox=st.tuples(u16, u16),
    standard_tx_mailbox=st.tuples(u16, u16),
    mailbox_protocols=u16,
    version=u16,
    strings=st.lists(st.text(max_size=20), max_size=5).map(tuple),
    general=st.none() | st.builds(SiiGeneral, u8, u8, u8, u8, u8, u8, u8, u8),
    fmmus=st.lists(st.integers(1, 255), max_size=5).map(tuple),
    sync_managers=st.lists(
        st.builds(SiiSyncManager, u16, u16, u8, u8, st.sampled_from(SyncManagerType), u8),
        max_size=4,
    ).map(tuple),
    tx_pdos=st.lists(pdos, max_size=3).map(tuple),
    rx_pdos=st.lists(pdos, max_size=3).map(tuple),
    dc=st.lists(
        st.builds(
            SiiDc,
            u32,
            u32,
            u32,
            st.integers(-32768, 32767),
            u16,
            st.integers(-32768, 32767),
            u8,
            u8,
        ),
        max_size=2,
    ).map(tuple),
)


@given(images)
def test_decode_inverts_encode(image: SiiImage) -> None:
    raw = encode_sii(image)
    assert len(raw) == image.eeprom_bytes and raw[14] == crc8(image.config_data)
    assert decode_sii(raw).image == image


@given(st.binary(min_size=0, max_size=300))
def test_random_bytes_raise_only_decode_errors(data: bytes) -> None:
    from skinframes.errors import DecodeError

    with contextlib.suppress(DecodeError):
        decode_sii(bytes(128) + data)


def _image() -> bytes:
    return build_sii(SlaveInfo.skin_patch(16))


def test_a_wrong_checksum_is_a_finding_not_a_refusal() -> None:
    raw = bytearray(_image())
    raw[14] ^= 0x01
    decoded = decode_sii(bytes(raw))
    assert [f.code for f in decoded.findings] == ["sii.checksum"]
    assert decoded.image == decode_sii(_image()).image
    assert decoded.checksum == raw[14]


def test_an_image_cut_short_of_its_size_word_is_a_finding(shared_esi: Path) -> None:
    # the user's report: the first 250 bytes of a 256-byte image (size word 1: (1 + 1) * 128),
    # its end category at bytes 0xF4-0xF5 still inside them
    shipped = (shared_esi / "soes_linux_lan9252demo.bin").read_bytes()
    assert len(shipped) == 256 and struct.unpack_from("<H", shipped, 0x7C)[0] == 1
    decoded = decode_sii(shipped[:250])
    assert [(f.code, f.message) for f in decoded.findings] == [
        ("sii.short", "SII: 250 bytes, the size word says 256")
    ]
    assert decode_sii(shipped).findings == ()


def test_the_bypass_word_is_an_info_finding_not_a_checksum_error() -> None:
    # datasheet I Table 42: word 7 = 0x88A4 disables the checksum check; an ESC loads the area
    raw = bytearray(_image())
    raw[14:16] = bytes([0xA4, 0x88])
    decoded = decode_sii(bytes(raw))
    assert [(f.code, str(f.severity)) for f in decoded.findings] == [
        ("sii.checksum_bypassed", "info")
    ]
    assert decoded.checksum == 0x88A4
    assert decoded.image == decode_sii(_image()).image


def test_bad_images_raise_typed_errors() -> None:
    raw = _image()
    with pytest.raises(TruncatedError, match="header"):
        decode_sii(raw[:100])
    # the FMMU category (at 0x80 + strings + general) claims more words than the image has
    past = bytearray(raw[: 0x80 + 4])
    past[0x82:0x84] = (0x7FFF).to_bytes(2, "little")
    with pytest.raises(TruncatedError, match="category 10 at byte 128 holds 65534 bytes"):
        decode_sii(bytes(past))
    with pytest.raises(TruncatedError, match="no end category"):
        decode_sii(raw[:0x80] + struct.pack("<HH", 40, 1) + b"\x02\x00")
    with pytest.raises(LengthMismatchError, match="SYNCM"):
        decode_sii(raw[:0x80] + struct.pack("<HH", 41, 3) + bytes(6) + b"\xff\xff")
    with pytest.raises(TruncatedError, match="PDO 0x1a00 has 5 entries"):
        decode_sii(
            raw[:0x80]
            + struct.pack("<HHHBBBBH", 50, 8, 0x1A00, 5, 0, 0, 0, 0)
            + bytes(8)
            + b"\xff\xff"
        )


def test_values_that_do_not_fit_raise_field_range_errors() -> None:
    image = decode_sii(_image()).image
    from dataclasses import replace

    with pytest.raises(FieldRangeError, match="identity"):
        encode_sii(replace(image, vendor_id=1 << 32))
    with pytest.raises(FieldRangeError, match="EEPROM holds 256"):
        encode_sii(replace(image, eeprom_bytes=256, strings=("x" * 200,)))
    with pytest.raises(FieldRangeError, match="config_data"):
        encode_sii(replace(image, config_data=bytes(8)))


def test_the_stated_size_is_word_0x3e_plus_one_kibit() -> None:
    # ETG.2010 Table 2, word 0x3E: the EEPROM's size in Kibit minus 1 (bytes 0x7C-0x7D)
    image = bytearray(128)
    image[0x7C:0x7E] = b"\x0f\x00"
    assert stated_eeprom_kibit(image) == 16
    image[0x7C:0x7E] = b"\xff\x00"
    assert stated_eeprom_kibit(bytes(image)) == 256


def test_the_config_area_loads_with_its_crc_or_the_bypass_word_and_not_otherwise() -> None:
    # datasheet I Table 42: word 7's low byte is the CRC-8 of words 0-6; 0x88A4 bypasses it
    words = (0x0C08, 0x0000, 0x0000, 0x0000, 0x1234, 0x0000, 0x0000)
    head = struct.pack("<7H", *words)
    good = head + struct.pack("<H", crc8(head))
    assert config_area(good + bytes(112)) == (*words, crc8(head))
    bypass = head + b"\xa4\x88"
    assert config_area(bypass) == (*words, 0x88A4)
    assert config_area(head + struct.pack("<H", crc8(head) ^ 0x01)) is None
    assert config_area(bytearray(head + struct.pack("<H", crc8(head) | 0x5500))) is not None
