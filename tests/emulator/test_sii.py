"""The SII image: ETG.2010 layout read back by an independent parser, CRC-8 of words 0-6."""

from __future__ import annotations

import random
import struct

import pytest
from mini_master import categories, find_category

from emulator.errors import TopologyError
from emulator.slave.sii import (
    DataType,
    FmmuUsage,
    SlaveInfo,
    SyncManagerType,
    build_sii,
    crc8,
    eeprom_kibit,
)


def crc8_augmented(data: bytes) -> int:
    """The same CRC as IgH's ``calcSiiCrc`` computes it: message bits shifted through an
    augmented register starting at 0x48 (0xFF moved back by 8 zero bits), then 8 zero bits."""
    crc = 0x48
    for byte in data:
        for i in range(8):
            top = crc & 0x80
            crc = ((crc << 1) | ((byte >> (7 - i)) & 1)) & 0xFF
            if top:
                crc ^= 0x07
    for _ in range(8):
        top = crc & 0x80
        crc = (crc << 1) & 0xFF
        if top:
            crc ^= 0x07
    return crc


# Words 0-7 of real SII EEPROMs (Beckhoff EK1100, EL2828, Kollmorgen AKD), as dumped in the
# ethercrab repository (dumps/eeprom/*.hex): the low byte of word 7 is the vendor's checksum.
REAL_CONFIG_AREAS = [
    "000d0000000000000000000000004600",
    "040100000000ff00000000000000e200",
    "09000008000000000000000000001000",
]


@pytest.mark.parametrize("area", REAL_CONFIG_AREAS)
def test_crc8_matches_real_eeproms(area: str) -> None:
    raw = bytes.fromhex(area)
    assert crc8(raw[:14]) == raw[14]
    assert raw[15] == 0  # the high byte of the checksum word is 0


def test_crc8_equals_an_independent_formulation() -> None:
    rng = random.Random(7)
    for _ in range(200):
        data = bytes(rng.randrange(256) for _ in range(14))
        assert crc8(data) == crc8_augmented(data)


def test_skin_patch_image_layout() -> None:
    info = SlaveInfo.skin_patch(192, serial=7, alias=0x1234)
    image = build_sii(info)
    words = struct.unpack_from("<64H", image)
    assert words[0] == 0x0005  # PDI control: SPI slave; ESC configuration 0
    assert words[4] == 0x1234  # configured station alias
    assert words[5] == words[6] == 0  # reserved, 0
    assert words[7] == crc8_augmented(image[:14])  # checksum, high byte 0
    assert struct.unpack_from("<IIII", image, 16) == (0x534B494E, 0x000100C0, 0x00010000, 7)
    assert words[0x18:0x1D] == (0, 0, 0, 0, 0)  # no mailbox, no mailbox protocols
    # 1.7 KiB of SII fit a 16 Kibit EEPROM: word 0x3E holds size - 1, word 0x3F version 1
    assert (words[0x3E], words[0x3F]) == (15, 1)
    assert len(image) == 2048
    kinds = [k for k, _ in categories(image)]
    assert kinds == [10, 30, 40, 41, 50, 0xFFFF]  # STRINGS GENERAL FMMU SYNCM TXPDO end
    strings = find_category(image, 10)
    assert strings is not None and strings[0] == 4
    assert strings[1 : 1 + 1 + 12] == b"\x0cSkinPatch192"
    general = find_category(image, 30)
    assert general is not None and len(general) == 32
    assert general[3] == 1  # NameIdx -> string 1
    assert general[5:9] == bytes(4)  # no CoE, FoE, EoE, SoE
    assert struct.unpack_from("<H", general, 16)[0] == 0x0011  # ports 0 and 1: MII
    assert find_category(image, 40) == bytes([0x02, 0x00])  # FMMU0 inputs (+ pad byte)
    assert find_category(image, 41) == struct.pack("<HHBBBB", 0x1000, 192, 0x20, 0, 1, 4)
    txpdo = find_category(image, 50)
    assert txpdo is not None
    assert struct.unpack_from("<HBBBBH", txpdo, 0) == (0x1A00, 192, 0, 0, 4, 0)
    entries = [struct.unpack_from("<HBBBBH", txpdo, 8 + 8 * i) for i in range(192)]
    assert entries[0] == (0x6000, 1, 0, 0x05, 8, 0)  # 0x6000:01 UNSIGNED8, 8 bits
    assert entries[12] == (0x6001, 1, 0, 0x05, 8, 0)  # triangle 1, taxel 0
    assert entries[-1] == (0x600F, 12, 0, 0x05, 8, 0)
    assert len(txpdo) == 8 + 192 * 8
    assert set(image[1776:]) == {0xFF}  # erased EEPROM after the end marker


def test_partial_patch_and_large_payloads() -> None:
    image = build_sii(SlaveInfo.skin_patch(16))
    txpdo = find_category(image, 50)
    assert txpdo is not None and txpdo[2] == 16
    assert struct.unpack_from("<HB", txpdo, 8 + 8 * 12) == (0x6001, 1)
    # 128 + strings 42 + general 36 + FMMU 6 + SYNCM 12 + TXPDO 4 + 8 + 16 x 8 + end 2 = 366
    # bytes: more than a 2 Kibit EEPROM holds, so 4 Kibit (word 0x3E = 4 - 1)
    assert struct.unpack_from("<H", image, 2 * 0x3E)[0] == 3
    assert len(image) == 512
    big = SlaveInfo.skin_patch(400)  # 34 triangles, 96-bit OCTET_STRING entries, 3 PDOs
    assert big.input_bytes == 400
    assert [len(p.entries) for p in big.tx_pdos] == [16, 16, 2]
    assert big.tx_pdos[2].entries[-1].bit_length == 32  # 400 - 33 * 12 = 4 bytes
    assert big.tx_pdos[0].entries[0].data_type == DataType.OCTET_STRING


def test_outputs_add_an_rxpdo_and_a_second_syncmanager() -> None:
    info = SlaveInfo.skin_patch(16, output_bytes=4)
    image = build_sii(info)
    assert find_category(image, 40) == bytes([FmmuUsage.OUTPUTS, FmmuUsage.INPUTS])
    syncm = find_category(image, 41)
    assert syncm is not None
    # SM1 after SM0's three 16-byte buffers: 0x1000 + 3 x 16 = 0x1030; ctrl 0x64 = write, watchdog
    assert struct.unpack_from("<HHBBBB", syncm, 8) == (0x1030, 4, 0x64, 0, 1, 3)
    rxpdo = find_category(image, 51)
    assert rxpdo is not None and struct.unpack_from("<HBB", rxpdo) == (0x1600, 4, 1)
    assert info.sm_of_type(SyncManagerType.OUTPUTS) == 1
    assert (info.input_bytes, info.output_bytes) == (16, 4)


def test_eeprom_sizes() -> None:
    assert eeprom_kibit(1) == 2
    assert eeprom_kibit(256) == 2
    assert eeprom_kibit(257) == 4
    assert eeprom_kibit(2048) == 16


@pytest.mark.parametrize("size", [0, 1487])
def test_impossible_patches_raise(size: int) -> None:
    with pytest.raises(TopologyError):
        SlaveInfo.skin_patch(size)


def test_identity_must_fit_its_words() -> None:
    info = SlaveInfo.skin_patch(16)
    with pytest.raises(TopologyError):
        SlaveInfo(1 << 32, 0, 0, 0, "x", info.sync_managers, info.fmmus)
