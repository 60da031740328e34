"""The emulated ESC on crafted frames: every command, working counters, registers, SyncManagers,
FMMUs, the SII EEPROM interface and the AL state machine.

Expected values come from the ESC datasheet (section I "technology", section II "registers"),
ETG.1000.4/.6 and hand computation, as each comment says; frames are built with the skinframes
EtherCAT codec (tested on its own against tshark).
"""

from __future__ import annotations

import dataclasses
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from emulator.errors import TopologyError
from emulator.esc.chain import EcatChain, configure_frames
from emulator.esc.device import EscDevice
from emulator.hostile import hostile_frames, master_reset_frames
from emulator.slave.sii import SlaveInfo, SyncManagerType, build_sii, crc8
from emulator.slave.state_machine import AlStatusCode, SkinPatchApplication
from skinframes import ethercat, taxel
from skinframes.errors import DecodeError
from skinframes.ethercat import Command as C  # noqa: N817 (short, the spec's table style)
from skinframes.ethercat import Datagram, EcatFrame
from skinframes.ethernet import EthernetFrame


def u16(v: int) -> bytes:
    return struct.pack("<H", v)


def send(chain: EcatChain, *dgs: Datagram) -> list[Datagram]:
    raw = ethercat.frame(EcatFrame(dgs)).to_bytes()
    back = chain.process_frame(raw)
    assert back is not None
    assert len(back) == len(raw)
    ecat, _, _ = ethercat.decode(back[14:], strict=False)
    return list(ecat.datagrams)


def one(chain: EcatChain, d: Datagram) -> Datagram:
    return send(chain, d)[0]


def word(d: Datagram) -> int:
    return int(struct.unpack_from("<H", d.data)[0])


class NullApp:
    """A PDI application that does nothing: SyncManagers stay under master control only."""

    def power_on(self, device: EscDevice) -> None:
        pass

    def al_control(self, device: EscDevice, value: int) -> None:
        pass


def bare_chain(n: int = 1, input_bytes: int = 16) -> EcatChain:
    return EcatChain(
        [
            EscDevice(SlaveInfo.skin_patch(input_bytes, serial=i + 1), app=NullApp())
            for i in range(n)
        ]
    )


# --- power-on register image ----------------------------------------------------------------
def test_identity_registers_and_reset_values() -> None:
    chain = EcatChain.skin(3, 192)
    d = one(chain, Datagram(C.BRD, 0, 0x0000, bytes(10)))
    # type 0x11 (ET1100), revision 0, build 0, 8 FMMUs, 8 SMs, 60 KiB RAM, ports 0/1 MII
    # (0x0F = 11 11 00 00), features 0x000C: bit-oriented FMMU, DC (bit 2), 64-bit DC (bit 3)
    assert d.data == bytes([0x11, 0, 0, 0, 8, 8, 60, 0x0F, 0x0C, 0])
    assert (d.wkc, d.adp) == (3, 3)  # every slave reads and increments the position
    al = one(chain, Datagram(C.APRD, 0, 0x0130, bytes(6)))
    assert al.data == bytes([0x01, 0, 0, 0, 0, 0])  # INIT, no error, code 0
    wd = one(chain, Datagram(C.APRD, 0, 0x0400, bytes(2)))
    assert word(wd) == 0x09C2  # watchdog divider reset value: 100 us (datasheet II 2.10)


def test_dl_status_middle_and_last_slave() -> None:
    chain = EcatChain.skin(3, 16)
    # bit 0 PDI operational, 1 PDI watchdog reloaded, 4/5 link port 0/1, 9/11 communication
    # on port 0/1, 10 loop port 1 closed, 12/14 ports 2/3 (not implemented) closed
    middle = 0x0001 | 0x0002 | 0x0010 | 0x0020 | 0x0200 | 0x0800 | 0x1000 | 0x4000
    last = 0x0001 | 0x0002 | 0x0010 | 0x0200 | 0x0400 | 0x1000 | 0x4000
    assert (middle, last) == (0x5A33, 0x5613)  # 0x5A/0x56 as in datasheet II Table 2
    assert word(one(chain, Datagram(C.APRD, 0, 0x0110, bytes(2)))) == middle
    assert word(one(chain, Datagram(C.APRD, (-2) & 0xFFFF, 0x0110, bytes(2)))) == last


# --- device addressing ----------------------------------------------------------------------
def test_auto_increment_commands() -> None:
    chain = EcatChain.skin(4, 16)
    for p in range(4):
        d = one(chain, Datagram(C.APWR, (-p) & 0xFFFF, 0x0010, u16(0x100 + p)))
        assert (d.wkc, d.adp) == (1, (-p + 4) & 0xFFFF)
    assert [dev.station for dev in chain.devices] == [0x100, 0x101, 0x102, 0x103]
    d = one(chain, Datagram(C.APRD, 0xFFFE, 0x0010, bytes(2)))  # position 2
    assert (word(d), d.wkc, d.adp) == (0x102, 1, 2)
    d = one(chain, Datagram(C.APRD, 0xFFF0, 0x0010, bytes(2)))  # position 16: nobody
    assert (d.data, d.wkc, d.adp) == (bytes(2), 0, 0xFFF4)
    # APRW: returns the old value, writes the new one, WKC 1 + 2 (datasheet I Table 5)
    d = one(chain, Datagram(C.APRW, 0xFFFF, 0x0010, u16(0x0BEE)))
    assert (word(d), d.wkc) == (0x101, 3)
    assert chain.devices[1].station == 0x0BEE


def test_configured_address_and_alias() -> None:
    infos = [SlaveInfo.skin_patch(16, serial=1), SlaveInfo.skin_patch(16, serial=2, alias=0x0ABC)]
    chain = EcatChain([EscDevice(i) for i in infos])
    send(chain, Datagram(C.APWR, 0, 0x0010, u16(0x1001)))
    send(chain, Datagram(C.APWR, 0xFFFF, 0x0010, u16(0x1002)))
    assert one(chain, Datagram(C.FPRD, 0x1002, 0x0012, bytes(2))).data == u16(0x0ABC)
    assert one(chain, Datagram(C.FPRD, 0x0ABC, 0x0010, bytes(2))).wkc == 0  # alias not enabled
    send(chain, Datagram(C.BWR, 0, 0x0103, b"\x01"))  # DL control bit 24: use the alias
    d = one(chain, Datagram(C.FPRD, 0x0ABC, 0x0010, bytes(2)))
    assert (word(d), d.wkc, d.adp) == (0x1002, 1, 0x0ABC)  # FPxx never change ADP
    assert one(chain, Datagram(C.FPWR, 0x1001, 0x0400, u16(0x1234))).wkc == 1
    d = one(chain, Datagram(C.FPRW, 0x1001, 0x0400, u16(0x0101)))
    assert (word(d), d.wkc) == (0x1234, 3)
    assert word(one(chain, Datagram(C.FPRD, 0x1001, 0x0400, bytes(2)))) == 0x0101


def test_broadcast_read_ors_and_read_write_writes_data_in() -> None:
    chain = EcatChain.skin(3, 16)
    for p, value in enumerate((0x0001, 0x0002, 0x0004)):
        send(chain, Datagram(C.APWR, (-p) & 0xFFFF, 0x0010, u16(value)))
    d = one(chain, Datagram(C.BRD, 0, 0x0010, u16(0x0100)))
    assert (word(d), d.wkc, d.adp) == (0x0107, 3, 3)  # data in OR 1 OR 2 OR 4
    assert one(chain, Datagram(C.BWR, 0x0020, 0x0400, u16(0x0777))).adp == 0x0023
    # BRW (datasheet I Table 7): out = in OR read, memory := in, per slave in chain order:
    # slave 0: in 0x0100 -> writes 0x0100, out 0x0101; slave 1: in 0x0101 -> writes 0x0101,
    # out 0x0103; slave 2: in 0x0103 -> writes 0x0103, out 0x0107. WKC 3 x 3.
    d = one(chain, Datagram(C.BRW, 0, 0x0010, u16(0x0100)))
    assert (word(d), d.wkc) == (0x0107, 9)
    assert [dev.station for dev in chain.devices] == [0x0100, 0x0101, 0x0103]


def test_read_multiple_write() -> None:
    chain = EcatChain.skin(4, 16)
    for p in range(4):
        send(chain, Datagram(C.APWR, (-p) & 0xFFFF, 0x0010, u16(0x1001 + p)))
    send(chain, Datagram(C.FPWR, 0x1003, 0x0400, u16(0x4321)))
    # FRMW: slave 0x1003 reads, all others write what it read (WKC +1 each, datasheet I Table 7)
    d = one(chain, Datagram(C.FRMW, 0x1003, 0x0400, bytes(2)))
    assert (word(d), d.wkc, d.adp) == (0x4321, 4, 0x1003)
    values = [word(one(chain, Datagram(C.FPRD, 0x1001 + p, 0x0400, bytes(2)))) for p in range(4)]
    # slaves 0 and 1 wrote the datagram before slave 2 read (0x0000); slave 3 wrote 0x4321
    assert values == [0x0000, 0x0000, 0x4321, 0x4321]
    # ARMW at a position nobody has: every slave writes (+1 each), ADP counts up
    d = one(chain, Datagram(C.ARMW, 0x0100, 0x0400, u16(0x0055)))
    assert (d.wkc, d.adp, d.data) == (4, 0x0104, u16(0x0055))
    assert {word(one(chain, Datagram(C.FPRD, 0x1001 + p, 0x0400, bytes(2)))) for p in range(4)} == {
        0x0055
    }


def test_nop_and_reserved_commands_leave_the_datagram_alone() -> None:
    chain = EcatChain.skin(2, 16)
    d = one(chain, Datagram(C.NOP, 0x1234, 0x0010, b"\xaa\xbb"))
    assert (d.adp, d.data, d.wkc) == (0x1234, b"\xaa\xbb", 0)
    d = one(chain, Datagram(0x0F, 0x0000, 0x0010, b"\xaa\xbb"))  # reserved value 15
    assert (d.adp, d.data, d.wkc) == (0, b"\xaa\xbb", 0)


def test_writes_to_read_only_registers_count_but_change_nothing() -> None:
    chain = EcatChain.skin(1, 16)
    d = one(chain, Datagram(C.APWR, 0, 0x0000, b"\x99"))
    assert d.wkc == 1  # the access reached the ESC (datasheet I 2.4)
    assert chain.devices[0].registers(0x0000, 1) == b"\x11"
    assert one(chain, Datagram(C.APWR, 0, 0x0130, u16(0x0008))).wkc == 1
    assert chain.devices[0].al_status == 0x0001


def test_shadow_registers_take_effect_after_the_frame_user_ram_at_once() -> None:
    chain = EcatChain.skin(2, 16)
    # datasheet I 3.4: writes to 0x0000-0x0F7F take effect after the frame's FCS
    out = send(chain, Datagram(C.BWR, 0, 0x0400, u16(0x1111)), Datagram(C.BRD, 0, 0x0400, bytes(2)))
    assert word(out[1]) == 0x09C2
    assert word(one(chain, Datagram(C.BRD, 0, 0x0400, bytes(2)))) == 0x1111
    out = send(
        chain, Datagram(C.APWR, 0, 0x0010, u16(0x0777)), Datagram(C.FPRD, 0x0777, 0, bytes(1))
    )
    assert out[1].wkc == 0  # the new station address is not valid yet inside the frame
    # user RAM 0x0F80-0x0FFF has no shadow buffer
    out = send(chain, Datagram(C.APWR, 0, 0x0F80, b"\x5a"), Datagram(C.APRD, 0, 0x0F80, b"\x00"))
    assert out[1].data == b"\x5a"


# --- DL control, loop, events, frame-level behaviour ----------------------------------------
def test_closing_port_1_shortens_the_line_and_forcing_it_open_loses_frames() -> None:
    chain = EcatChain.skin(3, 16)
    send(chain, Datagram(C.APWR, 0xFFFF, 0x0101, b"\x0c"))  # slave 1: loop port 1 closed
    d = one(chain, Datagram(C.BRD, 0, 0x0000, bytes(1)))
    assert (d.wkc, d.adp) == (2, 2)  # slave 2 is behind a closed port
    status = word(one(chain, Datagram(C.APRD, 0xFFFF, 0x0110, bytes(2))))
    assert status & 0x0C00 == 0x0C00  # loop closed, communication established (link present)
    send(chain, Datagram(C.APWR, 0xFFFF, 0x0101, b"\x00"))  # auto again
    assert one(chain, Datagram(C.BRD, 0, 0x0000, bytes(1))).wkc == 3
    send(chain, Datagram(C.APWR, 0xFFFE, 0x0101, b"\x08"))  # last slave: port 1 open, no link
    raw = ethercat.frame(EcatFrame((Datagram(C.BRD, 0, 0, bytes(1)),))).to_bytes()
    assert chain.process_frame(raw) is None


def test_irq_field_carries_masked_event_requests() -> None:
    chain = EcatChain.skin(2, 16)
    assert one(chain, Datagram(C.BRD, 0, 0x0000, bytes(1))).irq == 0  # mask 0 after reset
    send(chain, Datagram(C.BWR, 0, 0x0200, u16(0x0004)))  # DL status event
    # the link-up event is pending since power-on; reading 0x0110 clears it (datasheet II 2.4.3)
    assert one(chain, Datagram(C.BRD, 0, 0x0000, bytes(1))).irq == 0x0004
    send(chain, Datagram(C.BRD, 0, 0x0110, bytes(2)))
    assert one(chain, Datagram(C.BRD, 0, 0x0000, bytes(1))).irq == 0


@pytest.mark.parametrize("how", ["APRD", "BRD", "LRD"])
@pytest.mark.parametrize(
    ("ado", "n", "cleared"),
    [
        (0x010F, 1, 0),  # just below DL status
        (0x010F, 2, 0x04),  # its first byte
        (0x0111, 1, 0x04),  # its second byte alone
        (0x0112, 30, 0),  # just above, up to just below AL status
        (0x012F, 2, 0x08),  # AL status, first byte
        (0x0131, 1, 0x08),  # its second byte alone
        (0x0132, 4, 0),  # just above
        (0x0100, 0x40, 0x0C),  # both
    ],
)
def test_reading_dl_or_al_status_clears_its_event(how: str, ado: int, n: int, cleared: int) -> None:
    """Datasheet I Table 3: the DL status event (0x0210 bit 2) clears on a read of DL status
    0x0110:0x0111, the AL status event (bit 3) on a read of AL status 0x0130:0x0131, whatever
    reads them: one ESC, a broadcast, or an FMMU mapping the registers."""
    chain = EcatChain.skin(10, 16)
    send(chain, Datagram(C.BWR, 0, 0x0200, u16(0x000C)))  # both events in the IRQ field
    table = struct.pack("<IHBBHBBB3x", 0x100, n, 0, 7, ado, 0, 0x01, 0x01)  # byte-wise, read
    send(chain, Datagram(C.BWR, 0, 0x0600, table))
    for dev in chain.devices:
        dev.pdi_write(0x0210, bytes((dev.registers(0x0210, 1)[0] | 0x0C,)))
        dev.update_irq()
    if how == "APRD":
        send(chain, Datagram(C.APRD, 0, ado, bytes(n)))
        reading = [0]
    elif how == "BRD":
        send(chain, Datagram(C.BRD, 0, ado, bytes(n)))
        reading = list(range(10))
    else:
        assert one(chain, Datagram.logical(C.LRD, 0x100, bytes(n))).wkc == 10
        reading = list(range(10))
    pending = 0
    for p, dev in enumerate(chain.devices):
        left = 0x0C & ~cleared if p in reading else 0x0C
        assert dev.registers(0x0210, 1)[0] & 0x0C == left, (p, hex(ado), n)
        pending |= left
    assert one(chain, Datagram(C.BRD, 0, 0x0000, bytes(1))).irq == pending  # ORed over ESCs


def test_frame_length_padding_and_source_mac() -> None:
    chain = EcatChain.skin(2, 16)
    ecat = EcatFrame((Datagram(C.BRD, 0, 0x0130, bytes(2)),))
    padded = ethercat.frame(ecat).to_bytes()
    bare = EthernetFrame(ethercat.BROADCAST_MAC, ethercat.MASTER_MAC, ecat, padding=b"").to_bytes()
    assert (len(padded), len(bare)) == (60, 30)
    back = chain.process_frame(padded)
    assert back is not None and len(back) == 60 and back[30:] == padded[30:]  # padding kept
    assert back[6] == ethercat.MASTER_MAC[0] | 0x02 and back[7:12] == padded[7:12]
    back = chain.process_frame(bare)
    assert back is not None and len(back) == 30
    # DL control bit 0 = 0 on every slave: the source MAC is not changed (datasheet II 2.4.1)
    send(chain, Datagram(C.BWR, 0, 0x0100, b"\x00"))
    back = chain.process_frame(padded)
    assert back is not None and back[6:12] == padded[6:12]


def test_non_ethercat_frames_and_broken_frames() -> None:
    chain = EcatChain.skin(2, 16)
    ip = bytes(12) + b"\x08\x00" + bytes(46)
    assert chain.process_frame(ip) is None  # forwarding rule 1 (reset): destroyed
    send(chain, Datagram(C.BWR, 0, 0x0100, b"\x00"))
    assert chain.process_frame(ip) == ip  # forwarded untouched
    raw = bytearray(ethercat.frame(EcatFrame((Datagram(C.BRD, 0, 0, bytes(4)),))).to_bytes())
    raw[22] = 0x40  # datagram length 64 runs past the frame
    assert chain.process_frame(bytes(raw)) is None
    assert one(chain, Datagram(C.APRD, 0, 0x030C, bytes(1))).data == b"\x01"
    # the first ESC's processing unit found it; the next one counts a forwarded error at port 0
    # (0x0308) and in its processing unit (datasheet II 0x0308, 0x030C)
    assert one(chain, Datagram(C.APRD, 0, 0x0308, bytes(1))).data == b"\x00"
    assert one(chain, Datagram(C.APRD, 0xFFFF, 0x0308, bytes(5))).data == b"\x01\x00\x00\x00\x01"
    vlan = bytearray(ethercat.frame(EcatFrame((Datagram(C.BRD, 0, 0, bytes(1)),))).to_bytes())
    vlan[12:12] = b"\x81\x00\x00\x05"  # 802.1Q tag: processed, tag untouched
    back = chain.process_frame(bytes(vlan))
    # tag 12-15, EtherType 16, header 18, datagram 20: ADP at 22, data at 30, WKC at 31
    assert back is not None and back[12:16] == b"\x81\x00\x00\x05"
    assert (back[22], back[31]) == (2, 2)


def test_esc_reset_sequence() -> None:
    chain = EcatChain.skin(1, 16)
    send(chain, Datagram(C.APWR, 0, 0x0010, u16(0x4444)))
    for i, ch in enumerate(b"RES"):
        if i < 2:
            assert chain.devices[0].station == 0x4444
        send(chain, Datagram(C.APWR, 0, 0x0040, bytes([ch])))
    assert chain.devices[0].station == 0  # reset value after 'R','E','S' in 3 frames
    send(chain, Datagram(C.APWR, 0, 0x0010, u16(0x4444)))
    send(chain, Datagram(C.APWR, 0, 0x0040, b"R"))
    send(chain, Datagram(C.APRD, 0, 0x0000, bytes(1)))  # a frame that does not continue
    send(chain, Datagram(C.APWR, 0, 0x0040, b"E"))
    send(chain, Datagram(C.APWR, 0, 0x0040, b"S"))
    assert chain.devices[0].station == 0x4444


def test_an_lrd_of_the_image_breaks_off_an_esc_reset() -> None:
    # 'R','E','S' in three consecutive frames reset the ESC (datasheet II 0x0040): an LRD of
    # the process image between 'R' and 'E' is a frame that does not continue the sequence
    chain = EcatChain.configured(2, 8)
    for ch in b"RES":
        if ch == ord("E"):
            assert one(chain, Datagram.logical(C.LRD, 0, bytes(16))).wkc == 2
        send(chain, Datagram(C.BWR, 0, 0x0040, bytes([ch])))
    assert [dev.station for dev in chain.devices] == [0x1001, 0x1002]  # not reset
    for ch in b"RES":
        send(chain, Datagram(C.BWR, 0, 0x0040, bytes([ch])))
    assert [dev.station for dev in chain.devices] == [0, 0]  # reset values


# --- SII EEPROM interface -------------------------------------------------------------------
def eeprom_read(chain: EcatChain, station: int, word_address: int) -> tuple[int, bytes]:
    assert (
        one(chain, Datagram(C.FPWR, station, 0x0502, struct.pack("<HI", 0x0100, word_address))).wkc
        == 1
    )
    status = word(one(chain, Datagram(C.FPRD, station, 0x0502, bytes(2))))
    return status, one(chain, Datagram(C.FPRD, station, 0x0508, bytes(8))).data


def stations(chain: EcatChain) -> None:
    for p in range(len(chain)):
        send(chain, Datagram(C.APWR, (-p) & 0xFFFF, 0x0010, u16(0x1001 + p)))


def test_eeprom_read_status_and_errors() -> None:
    chain = EcatChain.skin(2, 192)
    stations(chain)
    status = word(one(chain, Datagram(C.FPRD, 0x1001, 0x0502, bytes(2))))
    # idle, 8-byte reads (bit 6), 16 Kibit EEPROM needs 1 address byte (bit 7 = 0), loaded
    assert status == 0x0040
    status, data = eeprom_read(chain, 0x1002, 0x08)
    assert status == 0x0040
    # vendor "SKIN" 0x534B494E and product 0x000100C0, little-endian
    assert data == bytes.fromhex("4e494b53c0000100")
    status, _ = eeprom_read(chain, 0x1001, 0x400)  # beyond the 1024-word EEPROM
    assert status & 0x2000  # missing acknowledge (datasheet I Table 45)
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, u16(0x0000)))  # "000" clears the errors
    assert word(one(chain, Datagram(C.FPRD, 0x1001, 0x0502, bytes(2)))) == 0x0040
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, u16(0x0300)))  # invalid command 011
    assert word(one(chain, Datagram(C.FPRD, 0x1001, 0x0502, bytes(2)))) == 0x2040


def test_eeprom_broadcast_read_ors_the_serial_numbers() -> None:
    chain = EcatChain.skin(3, 16)
    d = one(chain, Datagram(C.BWR, 0, 0x0502, struct.pack("<HI", 0x0100, 0x0E)))
    assert d.wkc == 3
    d = one(chain, Datagram(C.BRD, 0, 0x0508, bytes(4)))
    assert (struct.unpack("<I", d.data)[0], d.wkc) == (1 | 2 | 3, 3)


def test_eeprom_write_needs_write_enable_in_the_same_frame() -> None:
    chain = EcatChain.skin(1, 16)
    stations(chain)
    send(chain, Datagram(C.FPWR, 0x1001, 0x0508, u16(0xBEEF)))
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, struct.pack("<HI", 0x0200, 0x20)))
    status = word(one(chain, Datagram(C.FPRD, 0x1001, 0x0502, bytes(2))))
    assert status & 0x4000  # write without write enable
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, u16(0)))
    send(chain, Datagram(C.FPWR, 0x1001, 0x0508, u16(0xBEEF)))
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, struct.pack("<HI", 0x0201, 0x20)))
    assert word(one(chain, Datagram(C.FPRD, 0x1001, 0x0502, bytes(2)))) & 0x6001 == 0
    _, data = eeprom_read(chain, 0x1001, 0x20)
    assert data[:2] == u16(0xBEEF)


def test_eeprom_owned_by_pdi_ignores_ecat_commands() -> None:
    chain = EcatChain.skin(1, 16)
    stations(chain)
    send(chain, Datagram(C.FPWR, 0x1001, 0x0500, b"\x01"))  # offer the EEPROM to the PDI
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, struct.pack("<HI", 0x0100, 0x08)))
    assert one(chain, Datagram(C.FPRD, 0x1001, 0x0508, bytes(4))).data == bytes(4)
    send(chain, Datagram(C.FPWR, 0x1001, 0x0500, b"\x02"))  # force, then take it back
    send(chain, Datagram(C.FPWR, 0x1001, 0x0500, b"\x00"))
    _, data = eeprom_read(chain, 0x1001, 0x08)
    assert data[:4] == bytes.fromhex("4e494b53")


def test_eeprom_reload_keeps_the_alias_and_checks_the_crc() -> None:
    chain = EcatChain.skin(1, 16)
    stations(chain)

    def write_word(address: int, value: int) -> None:
        send(chain, Datagram(C.FPWR, 0x1001, 0x0508, u16(value)))
        send(chain, Datagram(C.FPWR, 0x1001, 0x0502, struct.pack("<HI", 0x0201, address)))

    # new config area: PDI 0x08 (16-bit async uC), alias 0x0077, checksum by hand-run CRC
    area = struct.pack("<7H", 0x0008, 0, 0, 0, 0x0077, 0, 0)
    for i, value in enumerate(struct.unpack("<7H", area)):
        write_word(i, value)
    write_word(7, crc8(area))
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, u16(0x0400)))  # reload
    regs = one(chain, Datagram(C.FPRD, 0x1001, 0x0140, bytes(1))).data
    alias = one(chain, Datagram(C.FPRD, 0x1001, 0x0012, bytes(2))).data
    assert (regs, alias) == (b"\x08", u16(0))  # alias only at the first load (datasheet I 11.1)
    write_word(0, 0x0005)  # now the checksum no longer fits
    send(chain, Datagram(C.FPWR, 0x1001, 0x0502, u16(0x0400)))
    status = word(one(chain, Datagram(C.FPRD, 0x1001, 0x0502, bytes(2))))
    assert status & 0x1800 == 0x1800  # checksum error, device information not loaded
    assert one(chain, Datagram(C.FPRD, 0x1001, 0x0140, bytes(1))).data == b"\x08"  # kept


def test_bad_checksum_at_power_on_keeps_the_pdi_down() -> None:
    info = SlaveInfo.skin_patch(16)
    image = bytearray(build_sii(info))
    image[14] ^= 0xFF
    chain = EcatChain([EscDevice(info, sii=bytes(image))])
    status = word(one(chain, Datagram(C.APRD, 0, 0x0502, bytes(2))))
    assert status & 0x1800 == 0x1800
    assert word(one(chain, Datagram(C.APRD, 0, 0x0110, bytes(2)))) & 0x0001 == 0
    assert one(chain, Datagram(C.APRD, 0, 0x1000, bytes(4))).wkc == 0  # no process RAM
    send(chain, Datagram(C.BWR, 0, 0x0120, u16(0x0002)))
    assert chain.devices[0].al_status == 0x0001  # no application answers
    image[14:16] = u16(0x88A4)  # the debugging bypass value of datasheet I Table 42
    bypass = EcatChain([EscDevice(info, sii=bytes(image))])
    assert bypass.devices[0].pdi_operational


def test_eeprom_survives_an_esc_reset() -> None:
    chain = EcatChain.skin(1, 16)
    send(chain, Datagram(C.APWR, 0, 0x0508, u16(0x1234)))
    send(chain, Datagram(C.APWR, 0, 0x0502, struct.pack("<HI", 0x0201, 0x30)))
    for ch in b"RES":
        send(chain, Datagram(C.APWR, 0, 0x0040, bytes([ch])))
    send(chain, Datagram(C.APWR, 0, 0x0502, struct.pack("<HI", 0x0100, 0x30)))
    assert one(chain, Datagram(C.APRD, 0, 0x0508, bytes(2))).data == u16(0x1234)


# --- AL state machine -----------------------------------------------------------------------
def al(chain: EcatChain) -> tuple[int, int]:
    d = one(chain, Datagram(C.APRD, 0, 0x0130, bytes(6)))
    status, _, code = struct.unpack("<HHH", d.data)
    return status, code


def request(chain: EcatChain, value: int) -> None:
    send(chain, Datagram(C.BWR, 0, 0x0120, u16(value)))


def configure_sm0(chain: EcatChain, length: int = 16, control: int = 0x20) -> None:
    regs = struct.pack("<HHBBBB", 0x1000, length, control, 0, 1, 0)
    send(chain, Datagram(C.APWR, 0, 0x0800, regs))


def test_state_machine_transitions_and_error_codes() -> None:
    chain = EcatChain.skin(1, 16)
    request(chain, 0x08)  # INIT -> OP
    assert al(chain) == (0x11, 0x0011)  # stays INIT with error: invalid requested state change
    request(chain, 0x02)  # without acknowledge: ignored
    assert al(chain) == (0x11, 0x0011)
    request(chain, 0x12)  # PREOP + acknowledge
    assert al(chain) == (0x02, 0x0000)
    request(chain, 0x05)
    assert al(chain) == (0x12, 0x0012)  # unknown requested state
    request(chain, 0x01)  # INIT without ack is accepted and resets the error (ETG.1000.6 6.4.1.4)
    assert al(chain) == (0x01, 0x0000)
    request(chain, 0x13)  # BOOT from INIT: not supported
    assert al(chain) == (0x11, 0x0013)
    request(chain, 0x12)
    request(chain, 0x14)  # SAFEOP without a programmed SyncManager
    assert al(chain) == (0x12, 0x001E)  # invalid input configuration
    configure_sm0(chain, length=15)
    request(chain, 0x14)
    assert al(chain) == (0x12, 0x001E)
    send(chain, Datagram(C.APWR, 0, 0x0806, b"\x00"))  # disable to reprogram (II 2.14.1)
    configure_sm0(chain, control=0x24)  # direction "ECAT writes": wrong for inputs
    request(chain, 0x14)
    assert al(chain) == (0x12, 0x001E)
    send(chain, Datagram(C.APWR, 0, 0x0806, b"\x00"))
    configure_sm0(chain)
    request(chain, 0x14)
    assert al(chain) == (0x04, 0x0000)
    request(chain, 0x08)
    assert al(chain) == (0x08, 0x0000)
    request(chain, 0x03)  # OP -> BOOT: refused, and an error in OP drops to SAFEOP
    assert al(chain) == (0x14, 0x0011)
    request(chain, 0x08)  # OP without acknowledge: ignored
    assert al(chain) == (0x14, 0x0011)
    request(chain, 0x18)  # acknowledged: back to OP
    assert al(chain) == (0x08, 0x0000)
    request(chain, 0x05)  # unknown state in OP: SAFEOP + error (KickCAT does the same)
    assert al(chain) == (0x14, 0x0012)
    request(chain, 0x11)  # SAFEOP -> INIT with acknowledge
    assert al(chain) == (0x01, 0x0000)


def test_local_error_in_op_drops_to_safeop_with_the_indication() -> None:
    chain = EcatChain.configured(1, 16)
    dev = chain.devices[0]
    request(chain, 0x08)
    assert al(chain) == (0x08, 0x0000)
    app = dev.app
    assert isinstance(app, SkinPatchApplication)
    app.local_error(dev, AlStatusCode.SM_WATCHDOG)
    assert al(chain) == (0x14, 0x001B)  # SAFEOP, error indication, SyncManager watchdog
    request(chain, 0x01)  # INIT without acknowledge: accepted, the error reset
    assert al(chain) == (0x01, 0x0000)


def test_state_codes_match_soem_names() -> None:
    pysoem = pytest.importorskip("pysoem")  # SOEM's own table: an independent source
    names = {
        AlStatusCode.INVALID_STATE_CHANGE: "Invalid requested state change",
        AlStatusCode.UNKNOWN_STATE: "Unknown requested state",
        AlStatusCode.BOOTSTRAP_NOT_SUPPORTED: "Bootstrap not supported",
        AlStatusCode.INVALID_INPUT_CONFIGURATION: "Invalid input configuration",
        AlStatusCode.INVALID_OUTPUT_CONFIGURATION: "Invalid output configuration",
    }
    for code, name in names.items():
        assert pysoem.al_status_code_to_string(code).lower() == name.lower()


def test_device_emulation_copies_al_control() -> None:
    base = SlaveInfo.skin_patch(16)
    info = SlaveInfo(
        base.vendor_id,
        base.product_code,
        base.revision,
        0,
        "Emulated",
        base.sync_managers,
        base.fmmus,
        base.tx_pdos,
        esc_configuration=0x01,  # 0x0141 bit 0 via SII word 0 (datasheet I 10.1.2)
    )
    chain = EcatChain([EscDevice(info)])
    request(chain, 0x08)
    assert al(chain)[0] == 0x08  # no checks: copied
    request(chain, 0x12)
    assert al(chain)[0] == 0x12  # the acknowledge bit shows up as error indication


# --- SyncManagers and FMMUs -----------------------------------------------------------------
def test_process_data_only_in_safeop_and_op() -> None:
    chain = EcatChain.configured(3, 16)
    payloads = taxel.sample_payloads(3, 2, 16, seed=4)
    chain.publish(payloads[0])
    d = one(chain, Datagram.logical(C.LRD, 0, bytes(48)))
    assert (d.data, d.wkc) == (payloads[0].tobytes(), 3)
    request(chain, 0x02)  # back to PREOP: the application locks the SyncManager (I 8.7)
    d = one(chain, Datagram.logical(C.LRD, 0, bytes(48)))
    assert (d.data, d.wkc) == (bytes(48), 0)


def test_logical_commands_on_input_only_slaves() -> None:
    chain = EcatChain.configured(4, 16, logical_base=0x00010000)
    rows = taxel.sample_payloads(4, 1, 16, seed=5)[0]
    chain.publish(rows)
    d = one(chain, Datagram.logical(C.LRW, 0x00010000, b"\xff" * 64))
    assert (d.data, d.wkc) == (rows.tobytes(), 4)  # read part only: +1 per slave
    d = one(chain, Datagram.logical(C.LWR, 0x00010000, b"\xff" * 64))
    assert (d.data, d.wkc) == (b"\xff" * 64, 0)  # no output FMMU: nobody writes
    d = one(chain, Datagram.logical(C.LRD, 0x00010010, bytes(32)))  # slaves 1 and 2
    assert (d.data, d.wkc) == (rows[1:3].tobytes(), 2)
    d = one(chain, Datagram.logical(C.LRD, 0x00020000, b"\x77" * 8))  # nothing mapped
    assert (d.data, d.wkc) == (b"\x77" * 8, 0)
    # the image spans two datagrams of one frame: each slave reads where it is mapped
    out = send(
        chain,
        Datagram.logical(C.LRD, 0x00010000, bytes(32)),
        Datagram.logical(C.LRD, 0x00010020, bytes(32)),
    )
    assert [o.wkc for o in out] == [2, 2]
    assert out[0].data + out[1].data == rows.tobytes()


def test_syncmanager_buffer_must_be_entered_at_its_start() -> None:
    chain = EcatChain.configured(2, 16)
    rows = taxel.sample_payloads(2, 2, 16, seed=6)
    chain.publish(rows[0])
    send(chain, Datagram(C.APWR, 0, 0x0010, u16(0x1001)))
    d = one(chain, Datagram(C.FPRD, 0x1001, 0x1004, bytes(4)))
    assert d.wkc == 0  # "a buffer has to be accessed beginning with the start address"
    d = one(chain, Datagram(C.FPRD, 0x1001, 0x1000, bytes(8)))  # opens the buffer
    assert (d.data, d.wkc) == (rows[0, 0, :8].tobytes(), 1)
    chain.publish(rows[1])  # a new sample arrives while the master reads in two strokes
    d = one(chain, Datagram(C.FPRD, 0x1001, 0x1008, bytes(8)))  # end address: closes
    assert (d.data, d.wkc) == (rows[0, 0, 8:].tobytes(), 1)  # still the consistent old buffer
    d = one(chain, Datagram(C.FPRD, 0x1001, 0x1000, bytes(16)))
    assert d.data == rows[1, 0].tobytes()  # the next access gets the latest buffer
    assert one(chain, Datagram(C.FPWR, 0x1001, 0x1000, bytes(16))).wkc == 0  # ECAT-read SM


def test_syncmanager_configuration_is_locked_while_enabled() -> None:
    chain = bare_chain()
    regs = struct.pack("<HHBBBB", 0x1000, 16, 0x20, 0, 1, 0)
    send(chain, Datagram(C.APWR, 0, 0x0800, regs))
    send(chain, Datagram(C.APWR, 0, 0x0800, struct.pack("<HH", 0x1800, 4)))
    assert chain.devices[0].sm_registers(0) == (0x1000, 16, 0x20, 1)
    send(chain, Datagram(C.APWR, 0, 0x0806, b"\x00"))
    send(chain, Datagram(C.APWR, 0, 0x0800, struct.pack("<HH", 0x1800, 4)))
    assert chain.devices[0].sm_registers(0) == (0x1800, 4, 0x20, 0)
    # disabled SyncManager: "access to memory without SyncManager control"
    assert one(chain, Datagram(C.APWR, 0, 0x1802, b"\x42")).wkc == 1
    assert one(chain, Datagram(C.APRD, 0, 0x1802, b"\x00")).data == b"\x42"


def test_mailbox_mode_alternates_write_and_read() -> None:
    chain = bare_chain()
    dev = chain.devices[0]
    # SM0: mailbox (mode 10), ECAT writes (direction 01): control 0x06; SM1: mailbox, ECAT reads
    send(chain, Datagram(C.APWR, 0, 0x0800, struct.pack("<HHBBBB", 0x1800, 8, 0x06, 0, 1, 0)))
    send(chain, Datagram(C.APWR, 0, 0x0808, struct.pack("<HHBBBB", 0x1900, 8, 0x02, 0, 1, 0)))
    assert one(chain, Datagram(C.APWR, 0, 0x1800, b"request!")).wkc == 1
    assert dev.registers(0x0805, 1)[0] & 0x08  # mailbox full
    assert one(chain, Datagram(C.APWR, 0, 0x1800, b"again...")).wkc == 0  # full: refused
    assert dev.pdi_read(0x1800, 8) == b"request!"
    assert one(chain, Datagram(C.APWR, 0, 0x1800, b"again...")).wkc == 1
    assert one(chain, Datagram(C.APRD, 0, 0x1900, bytes(8))).wkc == 0  # empty
    dev.pdi_write(0x1900, b"response")
    d = one(chain, Datagram(C.APRD, 0, 0x1900, bytes(8)))
    assert (d.data, d.wkc) == (b"response", 1)
    assert one(chain, Datagram(C.APRD, 0, 0x1900, bytes(8))).wkc == 0  # read out: empty again


def test_outputs_through_a_write_fmmu() -> None:
    info = SlaveInfo.skin_patch(16, output_bytes=4)
    chain = EcatChain([EscDevice(info)])
    dev = chain.devices[0]
    send(chain, Datagram(C.APWR, 0, 0x0800, struct.pack("<HHBBBB", 0x1000, 16, 0x20, 0, 1, 0)))
    send(chain, Datagram(C.APWR, 0, 0x0808, struct.pack("<HHBBBB", 0x1030, 4, 0x64, 0, 1, 0)))
    # FMMU0 outputs at logical 0 (type 2 = write), FMMU1 inputs at logical 4 (type 1 = read)
    send(
        chain, Datagram(C.APWR, 0, 0x0600, struct.pack("<IHBBHBBB3x", 0, 4, 0, 7, 0x1030, 0, 2, 1))
    )
    send(
        chain, Datagram(C.APWR, 0, 0x0610, struct.pack("<IHBBHBBB3x", 4, 16, 0, 7, 0x1000, 0, 1, 1))
    )
    for state in (0x02, 0x04, 0x08):
        request(chain, state)
    assert al(chain) == (0x08, 0)
    d = one(chain, Datagram.logical(C.LRW, 0, b"\x01\x02\x03\x04" + bytes(16)))
    assert d.wkc == 3  # read +1, write +2
    assert dev.pdi_read(0x1030, 4) == b"\x01\x02\x03\x04"
    assert one(chain, Datagram.logical(C.LWR, 0, b"\x05\x06\x07\x08")).wkc == 1
    assert dev.pdi_read(0x1030, 4) == b"\x05\x06\x07\x08"
    assert one(chain, Datagram.logical(C.LRD, 0, bytes(20))).wkc == 1  # inputs only


def test_bitwise_fmmu_mapping_of_the_datasheet_example() -> None:
    # datasheet I Table 24: 14 bits from logical 0x00010011.3 .. 0x00010013.0 to physical
    # bit 1 onwards; here the physical start is user RAM 0x0F81 (the example uses 0x0F01).
    chain = bare_chain()
    fmmu = struct.pack("<IHBBHBBB3x", 0x00010011, 3, 3, 0, 0x0F81, 1, 1, 1)
    send(chain, Datagram(C.APWR, 0, 0x0600, fmmu))
    send(chain, Datagram(C.APWR, 0, 0x0F81, b"\xaa\x55"))
    d = one(chain, Datagram.logical(C.LRD, 0x00010010, b"\xff" * 5))
    # physical bits 0x0F81.1-7 = 1,0,1,0,1,0,1 and 0x0F82.0-6 = 1,0,1,0,1,0,1 land on logical
    # 0x11.3-7 (1,0,1,0,1 -> 0xA8 | untouched 0x07 = 0xAF), 0x12.0-7 (0,1,1,0,1,0,1,0 = 0x56),
    # 0x13.0 (1: 0xFF stays 0xFF); bytes 0x10 and 0x14 are not mapped
    assert (d.data, d.wkc) == (bytes([0xFF, 0xAF, 0x56, 0xFF, 0xFF]), 1)
    d = one(chain, Datagram.logical(C.LRD, 0x00010010, bytes(5)))
    assert d.data == bytes([0x00, 0xA8, 0x56, 0x01, 0x00])
    # the same geometry for writing: all mapped bits 1, the unmapped ones keep their value
    send(chain, Datagram(C.APWR, 0, 0x0F81, b"\x00\x00"))
    send(chain, Datagram(C.APWR, 0, 0x0600, fmmu[:11] + b"\x02" + fmmu[12:]))
    assert one(chain, Datagram.logical(C.LWR, 0x00010010, b"\x00\xff\xff\xff\x00")).wkc == 1
    assert one(chain, Datagram(C.APRD, 0, 0x0F81, bytes(2))).data == b"\xfe\x7f"


def map_bytes(
    chain: EcatChain, index: int, logical: int, length: int, physical: int, kind: int
) -> None:
    """FMMU ``index`` of the first ESC maps ``length`` bytes byte-wise (datasheet II 2.13:
    start bit 0, stop bit 7; type 1 read, 2 write), active."""
    entry = struct.pack("<IHBBHBBB3x", logical, length, 0, 7, physical, 0, kind, 1)
    send(chain, Datagram(C.APWR, 0, 0x0600 + 16 * index, entry))


def test_lrw_writes_the_data_as_it_arrived_not_what_the_esc_read() -> None:
    # datasheet I Table 7: LRW reads into the frame and writes "Data In", the data before the
    # read. FMMU0 reads user RAM 0x0F80 and FMMU1 writes 0x0F90, both at logical byte 0.
    chain = bare_chain()
    send(chain, Datagram(C.APWR, 0, 0x0F80, b"\x55"))
    map_bytes(chain, 0, 0, 1, 0x0F80, 1)
    map_bytes(chain, 1, 0, 1, 0x0F90, 2)
    d = one(chain, Datagram.logical(C.LRW, 0, b"\xaa"))
    assert (d.data, d.wkc) == (b"\x55", 3)  # read +1, write +2
    assert one(chain, Datagram(C.APRD, 0, 0x0F90, bytes(1))).data == b"\xaa"


def test_lower_numbered_fmmu_wins_a_logical_byte() -> None:
    chain = bare_chain()
    send(chain, Datagram(C.APWR, 0, 0x0F80, b"\x11\x22\x33\x44"))
    map_bytes(chain, 0, 0, 2, 0x0F80, 1)
    map_bytes(chain, 1, 0, 2, 0x0F82, 1)
    assert one(chain, Datagram.logical(C.LRD, 0, bytes(2))).data == b"\x11\x22"


@pytest.mark.parametrize("bitwise", [False, True])
def test_lower_numbered_fmmu_wins_inside_a_higher_ones_range(bitwise: bool) -> None:
    # FMMU0 maps logical bytes 2-3, FMMU1 bytes 0-5 around them, FMMU2 the same as FMMU1: FMMU1
    # keeps bytes 0-1 and 4-5 on both sides of FMMU0's, FMMU2 nothing. Bit-wise, FMMU1 and
    # FMMU2 start at logical bit 0.1 and physical bit 0x0F80.1 (bit 0 of byte 0 not mapped).
    chain = bare_chain()
    send(chain, Datagram(C.APWR, 0, 0x0F80, bytes(range(0x10, 0x16))))
    send(chain, Datagram(C.APWR, 0, 0x0FA0, b"\xa2\xa3"))
    map_bytes(chain, 0, 2, 2, 0x0FA0, 3)
    start_bit, phys_bit = (1, 1) if bitwise else (0, 0)
    for index in (1, 2):
        entry = struct.pack("<IHBBHBBB3x", 0, 6, start_bit, 7, 0x0F80, phys_bit, 3, 1)
        send(chain, Datagram(C.APWR, 0, 0x0600 + 16 * index, entry))
    d = one(chain, Datagram.logical(C.LRD, 0, bytes(6)))
    assert (d.data, d.wkc) == (b"\x10\x11\xa2\xa3\x14\x15", 1)
    d = one(chain, Datagram.logical(C.LWR, 0, b"\xe1\xe2\xe3\xe4\xe5\xe6"))
    assert d.wkc == 1
    ram = chain.devices[0].registers(0x0F80, 6) + chain.devices[0].registers(0x0FA0, 2)
    # FMMU1 wrote bytes 0-1 and 4-5 (bit 0 of byte 0 only byte-wise), FMMU0 bytes 2-3
    first = 0xE0 if bitwise else 0xE1
    assert ram == bytes([first, 0xE2, 0x12, 0x13, 0xE5, 0xE6, 0xE3, 0xE4])


# --- every configuration a frame can set is legal input (issue 11) ------------------------------
def test_bitwise_fmmu_at_the_end_of_the_address_space_maps_only_existing_bits() -> None:
    # the crash of issue 11: a bit-wise write FMMU with physical start 0xFFFF.3, then an LWR.
    # Physical bits 0xFFFF.3 .. 0xFFFF.7 exist (5 bits, datasheet I 1.1: 64 KiB), so logical
    # bits 0x0.0 .. 0x0.4 are mapped and the rest of the 2-byte mapping is not.
    chain = bare_chain()
    fmmu = struct.pack("<IHBBHBBB3x", 0, 2, 0, 7, 0xFFFF, 3, 2, 1)
    send(chain, Datagram(C.APWR, 0, 0x0600, fmmu))
    d = one(chain, Datagram.logical(C.LWR, 0, b"\xff\xff"))
    assert d.wkc == 1
    assert chain.devices[0].registers(0xFFFE, 2) == b"\x00\xf8"  # bits 3-7 of 0xFFFF
    # read the same bits back: physical 0xFFFF = 0b1010_1xxx -> logical bits 0-4 = 1,0,1,0,1
    send(chain, Datagram(C.APWR, 0, 0x0600, fmmu[:11] + b"\x01" + fmmu[12:]))
    send(chain, Datagram(C.APWR, 0, 0xFFFF, b"\xa8"))
    d = one(chain, Datagram.logical(C.LRD, 0, b"\xff\xff"))
    assert (d.data, d.wkc) == (b"\xf5\xff", 1)  # 0b111_10101: bits 5-7 and byte 1 untouched


def test_bytewise_fmmu_and_syncmanager_beyond_64_kib_are_clipped() -> None:
    chain = bare_chain()
    # byte-wise FMMU: 0x10 logical bytes from physical 0xFFFC: only 4 exist
    fmmu = struct.pack("<IHBBHBBB3x", 0x100, 0x10, 0, 7, 0xFFFC, 0, 3, 1)
    send(chain, Datagram(C.APWR, 0, 0x0600, fmmu))
    d = one(chain, Datagram.logical(C.LWR, 0x100, bytes(range(1, 0x11))))
    assert d.wkc == 1
    assert chain.devices[0].registers(0xFFFC, 4) == b"\x01\x02\x03\x04"
    d = one(chain, Datagram.logical(C.LRD, 0x100, b"\xee" * 0x10))
    assert d.data == b"\x01\x02\x03\x04" + b"\xee" * 12
    # a write SyncManager (buffered, ECAT writes) from 0xFFFE with length 0xFFFF: 2 bytes exist;
    # writing both is writing its end address: the buffer is exchanged after the frame
    sm = struct.pack("<HHBBBB", 0xFFFE, 0xFFFF, 0x04, 0, 1, 0)
    send(chain, Datagram(C.APWR, 0, 0x0800, sm))
    assert one(chain, Datagram(C.APWR, 0, 0xFFFE, b"\x5a\xa5")).wkc == 1
    assert chain.devices[0].registers(0xFFFE, 2) == b"\x5a\xa5"


def test_broadcast_register_writes_keep_masks_and_locked_syncmanagers() -> None:
    # one BWR of 0xFF over 0x0300-0x089F: read-only bits keep their values, the enabled SM's
    # configuration bytes 0-4 keep theirs (datasheet II 2.14.1), the disabled one takes it
    chain = bare_chain()
    send(chain, Datagram(C.APWR, 0, 0x0800, struct.pack("<HHBBBB", 0x1000, 4, 0x20, 0, 1, 0)))
    before = chain.devices[0].registers(0, 0x0F80)
    assert one(chain, Datagram(C.BWR, 0, 0x0300, b"\xff" * 0x05A0)).wkc == 1
    after = chain.devices[0].registers(0, 0x0F80)
    assert after[0x0300:0x0314] == bytes(0x14)  # error counters cleared by the write
    assert after[0x0400:0x0402] == b"\xff\xff"  # watchdog divider
    assert after[0x0440] == before[0x0440]  # watchdog status: read-only
    fmmu_mask = bytes((0xFF,) * 6 + (0x07, 0x07, 0xFF, 0xFF, 0x07, 0x03, 0x01, 0, 0, 0))
    assert after[0x0600:0x0610] == fmmu_mask  # datasheet II 2.13: reserved bits stay 0
    assert after[0x0800:0x0805] == before[0x0800:0x0805]  # SM0 enabled: locked
    assert after[0x0806] & 0xC3 == 0xC3
    assert after[0x0808:0x080D] == b"\xff\xff\xff\xff\x7f"  # SM1 was disabled: masked write


AREAS = [(0x0600, 0x0700), (0x0800, 0x0880), (0x0120, 0x0122), (0x0500, 0x0510)]


@st.composite
def aimed_datagram(draw: st.DrawFn) -> Datagram:
    lo, hi = draw(st.sampled_from(AREAS))
    ado = draw(st.integers(lo, hi - 1))
    data = bytearray(draw(st.binary(min_size=1, max_size=hi - ado + 4)))
    if ado <= 0x0502 < ado + len(data):
        data[0x0502 - ado] &= 0xFE  # no EEPROM write enable: the SII itself survives
    cmd = draw(st.sampled_from([C.APWR, C.FPWR, C.BWR, C.APRW, C.BRW, C.ARMW, C.FRMW]))
    return Datagram(cmd, draw(st.sampled_from([0, 0xFFFF, 0x1001])), ado, bytes(data))


@st.composite
def any_datagram(draw: st.DrawFn) -> Datagram:
    return Datagram(
        draw(st.integers(0, 255)),
        draw(st.integers(0, 0xFFFF)),
        draw(st.integers(0, 0xFFFF)),
        draw(st.binary(max_size=64)),
    )


def configured_read_works(chain: EcatChain, size: int) -> None:
    """A master resets and configures the line again; an LRD returns every patch's inputs."""
    nodes = len(chain)
    for frame in master_reset_frames(nodes) + configure_frames(chain.devices[0].info, nodes):
        chain.process_frame(frame)
    rows = taxel.sample_payloads(nodes, 1, size, seed=9)[0]
    chain.publish(rows)
    d = one(chain, Datagram.logical(C.LRD, 0, bytes(nodes * size)))
    assert (d.wkc, d.data) == (nodes, rows.tobytes())


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(frames=st.lists(st.lists(aimed_datagram() | any_datagram(), min_size=1, max_size=4)))
def test_hostile_register_writes_never_raise_and_a_master_recovers(
    frames: list[list[Datagram]],
) -> None:
    chain = EcatChain.configured(3, 8)
    for dgs in frames:
        chain.process_frame(ethercat.frame(EcatFrame(tuple(dgs))).to_bytes())
    configured_read_works(chain, 8)


@pytest.mark.parametrize("seed", [1, 2])
def test_seeded_hostile_frames_never_raise_and_a_master_recovers(seed: int) -> None:
    nodes, size = 8, 16
    chain = EcatChain.configured(nodes, size)
    for frame in hostile_frames(1500, nodes=nodes, input_bytes=size, seed=seed):
        chain.process_frame(frame)
    configured_read_works(chain, size)


# --- broadcasts in seeded hostile traffic, against the documents' access rules -------------
# Every ESC a broadcast reaches shares its bytes (emulator/esc/device.py decodes FMMU and
# SyncManager tables once per distinct bytes and cuts writes once per address and length); these
# tests check the outcome slave by slave with expectations written here from the documents:
#
# * which ESCs a frame reaches (datasheet I 3.1, II 2.4.1 DL control 0x0101 bits 2-3: 11 closed,
#   10 open whatever the link (lost without one), 00/01 auto: open with a link), with loop changes
#   taking effect at the end of the frame;
# * a BWR adds 1 to the working counter at every ESC it reaches where it writes a register
#   (ETG.1000.4 Table 14; datasheet I Table 7: an access counts even where the mask keeps bits);
# * an FMMU register byte (of the FMMUs 0x0004 says exist) after a write keeps its read-only
#   and reserved bits and takes the written ones (datasheet II 2.13: bytes 0-5, 8-9 all bits,
#   6/7/10 bits 0-2, 11 bits 0-1, 12 bit 0, 13-15 reserved).

FMMU_FIRST, FMMU_END = 0x0600, 0x0700  # 16 FMMUs of 16 bytes (datasheet II 2.13)
FMMU_WRITABLE = bytes((0xFF,) * 6 + (0x07, 0x07, 0xFF, 0xFF, 0x07, 0x03, 0x01, 0, 0, 0))
REG_FMMUS_SUPPORTED = 0x0004  # number of FMMUs; the others' registers are reserved (II 2.1)
RESET_REGISTER = 0x0040  # 'R','E','S' resets the ESC (datasheet II 2.3): not a plain write
REGISTER_END = 0x0F80  # 0x0000-0x0F7F registers, then memory (datasheet I 1.1)


def reached_positions(chain: EcatChain) -> tuple[int, bool]:
    """How many ESCs a frame reaches, and whether it is lost, from DL control 0x0101."""
    n = len(chain)
    for p, dev in enumerate(chain.devices):
        loop = (dev.registers(0x0101, 1)[0] >> 2) & 0x03
        link = p < n - 1
        if loop == 0x03:
            return p + 1, False
        if loop == 0x02 and not link:
            return p + 1, True
        if loop in (0x00, 0x01) and not link:
            return p + 1, False
    raise AssertionError("the last ESC has no link: auto closes, open loses")  # pragma: no cover


def plain_broadcast_writes(frame: bytes) -> tuple[Datagram, ...] | None:
    """The datagrams of ``frame`` if all are BWRs of registers other than the reset register."""
    try:
        ecat, _, _ = ethercat.decode(frame[14:], strict=False)
    except DecodeError:
        return None
    if ecat.frame_type != ethercat.FrameType.ECAT or frame[12:14] != b"\x88\xa4":
        return None
    for d in ecat.datagrams:
        end = d.ado + len(d.data)
        if d.cmd != C.BWR or not d.data or end > REGISTER_END:
            return None
        if d.ado <= RESET_REGISTER < end:
            return None
    return ecat.datagrams


def expected_fmmus(before: bytes, writes: tuple[Datagram, ...], fmmus: int) -> bytes:
    table = bytearray(before)
    writable = FMMU_WRITABLE * fmmus + bytes(len(table) - len(FMMU_WRITABLE) * fmmus)
    for d in writes:
        for i, value in enumerate(d.data):
            at = d.ado + i - FMMU_FIRST
            if 0 <= at < len(table):
                mask = writable[at]
                table[at] = (table[at] & ~mask & 0xFF) | (value & mask)
    return bytes(table)


@pytest.mark.parametrize("seed", [3, 4])
def test_broadcast_writes_in_hostile_traffic_follow_the_access_rules(seed: int) -> None:
    nodes, size = 6, 8
    chain = EcatChain.configured(nodes, size)
    reset = master_reset_frames(nodes)
    checked = 0
    for i, frame in enumerate(hostile_frames(4000, nodes=nodes, input_bytes=size, seed=seed)):
        if i % 400 == 399:  # reopen loops a hostile frame closed, as a master would
            for r in reset:
                chain.process_frame(r)
        writes = plain_broadcast_writes(frame)
        if writes is None:
            chain.process_frame(frame)
            continue
        reached, lost = reached_positions(chain)
        before = [dev.registers(FMMU_FIRST, FMMU_END - FMMU_FIRST) for dev in chain.devices]
        back = chain.process_frame(frame)
        for p, dev in enumerate(chain.devices):
            fmmus = dev.registers(REG_FMMUS_SUPPORTED, 1)[0]
            want = expected_fmmus(before[p], writes, fmmus) if p < reached else before[p]
            assert dev.registers(FMMU_FIRST, FMMU_END - FMMU_FIRST) == want, (i, p)
        assert (back is None) == lost, i
        if back is not None:
            returned, _, _ = ethercat.decode(back[14:], strict=False)
            for sent, got in zip(writes, returned.datagrams, strict=True):
                assert got.wkc == (sent.wkc + reached) & 0xFFFF, (i, reached)
                assert got.data == sent.data  # a write leaves the data as it was
        checked += 1
    assert checked >= 20  # the seeded sequence holds enough of them to mean something
    configured_read_works(chain, size)


def fmmu_entry(logical: int, length: int, physical: int) -> bytes:
    """A byte-wise read FMMU (datasheet II 2.13): start bit 0, stop bit 7, type 1, active."""
    return struct.pack("<IHBBHBBB3x", logical, length, 0, 7, physical, 0, 0x01, 0x01)


def test_one_slave_reconfigured_after_a_broadcast_keeps_the_others_mapping() -> None:
    # All three ESCs get the same FMMU0 by one BWR (one decoded table serves them); then ESC 1
    # alone maps another logical window by FPWR. An LRD of the first window then reads the
    # station address registers 0x0010 of ESCs 0 and 2 only (ETG.1000.4 5.3: each ESC whose
    # FMMU maps it, +1 each), one of the second window reads ESC 1's.
    chain = EcatChain.skin(3, 8)
    stations = (0x1001, 0x1002, 0x1003)
    for p, station in enumerate(stations):
        d = Datagram(C.APWR, -p & 0xFFFF, 0x0010, struct.pack("<H", station))
        assert chain.process_frame(ethercat.frame(EcatFrame((d,))).to_bytes()) is not None
    frames = [
        Datagram(C.BWR, 0, 0x0600, fmmu_entry(0x100, 2, 0x0010)),
        Datagram(C.FPWR, 0x1002, 0x0600, fmmu_entry(0x200, 2, 0x0010)),
    ]
    for d in frames:
        assert chain.process_frame(ethercat.frame(EcatFrame((d,))).to_bytes()) is not None

    def lrd(logical: int) -> Datagram:
        raw = ethercat.frame(EcatFrame((Datagram.logical(C.LRD, logical, bytes(2)),)))
        back = chain.process_frame(raw.to_bytes())
        assert back is not None
        return ethercat.decode(back[14:])[0].datagrams[0]

    first, second = lrd(0x100), lrd(0x200)
    # the first window: ESC 0 writes 0x1001, ESC 2 overwrites it with 0x1003 (a logical read
    # replaces the mapped bytes at every ESC in processing order)
    assert (first.wkc, first.data) == (2, struct.pack("<H", 0x1003))
    assert (second.wkc, second.data) == (1, struct.pack("<H", 0x1002))


# --- distributed clocks (emulator/esc/dc.py; datasheet I 9, II 2.20-2.22) -----------------------
def clocked_chain(n: int, starts: list[int], drifts: list[float]) -> tuple[EcatChain, list[int]]:
    """A chain whose host clock the test moves (``now[0]`` ns) and whose ESC clocks are set."""
    chain = bare_chain(n)
    now = [0]
    chain.clock_ns = lambda: now[0]
    for dev, start, drift in zip(chain.devices, starts, drifts, strict=True):
        dev.dc.retune(drift, start)
    return chain, now


def u32(d: Datagram, at: int = 0) -> int:
    return int(struct.unpack_from("<I", d.data, at)[0])


def test_dc_receive_times_latch_the_propagation_of_the_frame() -> None:
    # WIRE: one ESC pass 540 ns + 0.01 m of cable at 5 ns/m = 540.05 ns per hop both ways.
    # The frame reaches the line at host 1,000,000 ns: port 0 of ESC p at 540.05 p ns; the last
    # ESC (2) turns it around, port 1 of ESC p sees it at (2 + 1 + (1 - p)) x 540.05 ns.
    chain, now = clocked_chain(3, [5000, 7000, 0], [0.0, 0.0, 100.0])
    now[0] = 1_000_000
    assert one(chain, Datagram(C.BWR, 0, 0x0900, bytes(4))).wkc == 3
    now[0] = 9_999_999  # later reads return the latched values
    times = [one(chain, Datagram(C.APRD, -p & 0xFFFF, 0x0900, bytes(16))) for p in range(3)]
    pu = [one(chain, Datagram(C.APRD, -p & 0xFFFF, 0x0918, bytes(8))) for p in range(3)]
    # ESC 0: 5000 + 1,000,000 and 5000 + 1,002,160.2 (4 hops)
    assert [u32(times[0], 4 * k) for k in range(4)] == [1_005_000, 1_007_160, 0, 0]
    # ESC 1: 7000 + 1,000,540.05 and 7000 + 1,001,620.15 (3 hops)
    assert [u32(times[1], 4 * k) for k in range(4)] == [1_007_540, 1_008_620, 0, 0]
    # ESC 2 (last, +100 ppm): 1,001,080.1 x 1.0001 = 1,001,180.2; no link at port 1
    assert [u32(times[2], 4 * k) for k in range(4)] == [1_001_180, 0, 0, 0]
    assert [int.from_bytes(d.data, "little") for d in pu] == [1_005_000, 1_007_540, 1_001_180]
    # SOEM's propagation delay of ESC 1: ((t1 - t0) of ESC 0 - (t1 - t0) of ESC 1) / 2
    assert ((1_007_160 - 1_005_000) - (1_008_620 - 1_007_540)) // 2 == 540


def test_dc_system_time_compare_filter_and_control_loop() -> None:
    chain, _ = clocked_chain(1, [1000], [0.0])  # host time frozen at 0: local time 1000
    send(chain, Datagram(C.APWR, 0, 0x0920, struct.pack("<Q", 500)))  # offset
    send(chain, Datagram(C.APWR, 0, 0x0928, struct.pack("<I", 100)))  # delay
    send(chain, Datagram(C.APWR, 0, 0x0934, b"\x02"))  # mean over 2^2 compares
    # local copy 1000 + 500 = 1500 here; a read gives it as the frame passed the reference
    # clock, 100 ns (the delay) earlier: 1400 (datasheet II 0x0910, "including System Time Delay")
    assert int.from_bytes(one(chain, Datagram(C.APRD, 0, 0x0910, bytes(8))).data, "little") == 1400

    def compare(value: int) -> tuple[int, int]:
        assert one(chain, Datagram(C.APWR, 0, 0x0910, struct.pack("<Q", value))).wkc == 1
        d = one(chain, Datagram(C.APRD, 0, 0x092C, bytes(8)))
        return u32(d), int(struct.unpack_from("<h", d.data, 6)[0])

    # difference = local copy (1500) - received - delay (100); mean m += (d - m) / 4
    diff, speed = compare(1000)  # d = 400: m = 100
    assert diff == 100
    # the loop's first correction: -(d / 4 + d) / tau with tau = 0x1000 x 5 us = 20.48 ms:
    # -500 / 20,480,000 = -24.414 ppm, in units of 0.1 ppm
    assert speed == -244
    assert compare(2300)[0] == 0x80000000 | 150  # d = -900: m = 100 - 250 = -150 (local smaller)
    assert compare(1150)[0] == 0x80000000 | 50  # d = 250: m = -150 + 100 = -50
    # the system time register itself never jumps: the compare is no write
    assert int.from_bytes(one(chain, Datagram(C.APRD, 0, 0x0910, bytes(8))).data, "little") == 1400


def soem_dc_chain() -> tuple[EcatChain, list[int]]:
    """Four ESCs set up as SOEM's config_dc does, with host time moving 1 ms per cycle: latch,
    offsets from the processing-unit receive times, delays from the port times, speed counter
    start and filters; station addresses 0x1001-0x1004. Clocks of 0, +25, -25 and +10 ppm."""
    chain, now = clocked_chain(4, [10**9, 3 * 10**9, 17, 5 * 10**8], [0.0, 25.0, -25.0, 10.0])
    now[0] = 2_000_000
    send(chain, Datagram(C.BWR, 0, 0x0900, bytes(4)))
    master_ns = 7 * 10**12
    rt = [one(chain, Datagram(C.APRD, -p & 0xFFFF, 0x0900, bytes(8))) for p in range(4)]
    for p in range(4):
        pu = int.from_bytes(
            one(chain, Datagram(C.APRD, -p & 0xFFFF, 0x0918, bytes(8))).data, "little"
        )
        offset = (master_ns - pu) & ((1 << 64) - 1)
        send(chain, Datagram(C.APWR, -p & 0xFFFF, 0x0920, struct.pack("<Q", offset)))
    delay = 0
    for p in range(1, 4):
        parent, child = rt[p - 1], rt[p]
        delay += (
            (u32(parent, 4) - u32(parent)) - ((u32(child, 4) - u32(child)) if p < 3 else 0)
        ) // 2
        send(chain, Datagram(C.APWR, -p & 0xFFFF, 0x0928, struct.pack("<I", delay)))
    send(chain, Datagram(C.BWR, 0, 0x0930, struct.pack("<H", 0x1000)))
    send(chain, Datagram(C.BWR, 0, 0x0934, b"\x00\x0c"))
    send(chain, *(Datagram(C.APWR, -p & 0xFFFF, 0x0010, u16(0x1001 + p)) for p in range(4)))
    return chain, now


FRMW_REFERENCE = ethercat.frame(
    EcatFrame((Datagram(C.FRMW, 0x1001, 0x0910, bytes(8)),))
).to_bytes()  # SOEM's cyclic FRMW of the reference clock's system time


def test_dc_drift_compensation_brings_every_clock_to_the_reference() -> None:
    chain, now = soem_dc_chain()

    def differences() -> list[int]:
        out = []
        for p in range(1, 4):
            v = u32(one(chain, Datagram(C.APRD, -p & 0xFFFF, 0x092C, bytes(4))))
            out.append(-(v & 0x7FFFFFFF) if v & 0x80000000 else v)
        return out

    frmw = FRMW_REFERENCE
    first = None
    for cycle in range(1000):
        now[0] += 1_000_000
        back = chain.process_frame(frmw)
        assert back is not None
        if cycle == 0:
            first = differences()
    assert first is not None and max(abs(d) for d in first) > 500  # work to do at the start
    assert all(abs(d) < 100 for d in differences())


def test_sync0_pulses_and_taxels_sampled_at_sync0() -> None:
    chain = EcatChain.configured(2, 4)
    now = [0]
    chain.clock_ns = lambda: now[0]
    for dev in chain.devices:
        dev.dc.retune(0.0, 0)
    # SYNC0 every 1 ms from system time 5 ms (offsets 0): SOEM's dc_sync order
    send(chain, Datagram(C.BWR, 0, 0x0981, b"\x00"))
    send(chain, Datagram(C.BWR, 0, 0x0990, struct.pack("<Q", 5_000_000)))
    send(chain, Datagram(C.BWR, 0, 0x09A0, struct.pack("<I", 1_000_000)))
    send(chain, Datagram(C.BWR, 0, 0x0981, b"\x03"))
    d = one(chain, Datagram(C.APRD, 0, 0x0984, bytes(1)))
    assert d.data == b"\x01"  # first pulse pending
    lrd = Datagram.logical(C.LRD, 0, bytes(8))
    chain.publish([b"\x01" * 4, b"\x02" * 4])  # what the sensors hold: sampled at SYNC0 only
    assert one(chain, lrd).data == bytes(8)  # no pulse yet: the buffer SAFEOP wrote
    now[0] = 5_300_000  # the first pulse (5 ms) fired
    assert one(chain, lrd).data == b"\x01" * 4 + b"\x02" * 4
    stamp = one(chain, Datagram(C.APRD, 0, 0x0F80, bytes(8)))
    assert int.from_bytes(stamp.data, "little") == 5_000_000
    regs = one(chain, Datagram(C.APRD, 0, 0x0984, bytes(0x14)))
    assert regs.data[0] == 0  # activation done
    assert regs.data[0x098E - 0x0984] == 1  # SYNC0 status: a pulse since the last read
    assert int.from_bytes(regs.data[12:20], "little") == 6_000_000  # 0x0990: next pulse
    assert one(chain, Datagram(C.APRD, 0, 0x098E, bytes(1))).data == b"\x00"  # read cleared it
    chain.publish([b"\x03" * 4, b"\x04" * 4])
    now[0] = 5_900_000  # no new pulse: the sample of 5 ms stays
    assert one(chain, lrd).data == b"\x01" * 4 + b"\x02" * 4
    now[0] = 8_200_000  # pulses at 6, 7 and 8 ms: the sample of 8 ms
    assert one(chain, lrd).data == b"\x03" * 4 + b"\x04" * 4
    stamp = one(chain, Datagram(C.APRD, 0, 0x0F80, bytes(8)))
    assert int.from_bytes(stamp.data, "little") == 8_000_000


def sync0_chain(
    nodes: int, start_ns: int, command: C = C.BWR, adp: int = 0
) -> tuple[EcatChain, list[int]]:
    """A configured chain of ``nodes`` patches of 4 bytes whose clocks read ``now[0]`` (0 at
    first; offsets 0), with SYNC0 every 1 ms from system time ``start_ns`` at the ESCs that
    ``command`` with ``adp`` addresses (0x0990, 0x09A0, then 0x0981 = 3: SOEM's dc_sync order)."""
    chain = EcatChain.configured(nodes, 4)
    now = [0]
    chain.clock_ns = lambda: now[0]
    for dev in chain.devices:
        dev.dc.retune(0.0, 0)
    send(chain, Datagram(command, adp, 0x0990, struct.pack("<Q", start_ns)))
    send(chain, Datagram(command, adp, 0x09A0, struct.pack("<I", 1_000_000)))
    send(chain, Datagram(command, adp, 0x0981, b"\x03"))
    return chain, now


def test_a_line_publishes_each_patch_as_on_its_own() -> None:
    """The line's publish writes the patches that do not sample at SYNC0 at once: the middle
    one, with SYNC0 active (0x0981 = 3 at it alone), keeps the buffer SAFEOP wrote until a
    pulse; the others show their new rows at once, given as an array or as rows (bytes, a
    bytearray, a list of ints)."""
    chain, now = sync0_chain(3, 5_000_000, C.FPWR, 0x1002)
    lrd = Datagram.logical(C.LRD, 0, bytes(12))
    chain.publish(np.array([[1] * 4, [2] * 4, [3] * 4], np.uint8))
    assert one(chain, lrd).data == b"\x01" * 4 + bytes(4) + b"\x03" * 4
    chain.publish([[4] * 4, bytearray(b"\x05" * 4), b"\x06" * 4])  # what bytes() takes
    assert one(chain, lrd).data == b"\x04" * 4 + bytes(4) + b"\x06" * 4
    now[0] = 5_300_000  # the middle patch's first pulse (5 ms) took its sensor's sample
    assert one(chain, lrd).data == b"\x04" * 4 + b"\x05" * 4 + b"\x06" * 4
    held = [dev.app.inputs for dev in chain.devices]  # type: ignore[attr-defined]
    assert held == [b"\x04" * 4, b"\x05" * 4, b"\x06" * 4]


def test_a_publish_of_a_wrong_row_changes_no_patch() -> None:
    """One LRD, one sample: a publish whose second row is short is refused before the first
    patch holds or writes its row; the image still reads the sample before."""
    chain = EcatChain.configured(2, 4)
    chain.publish([b"\x01" * 4, b"\x02" * 4])
    with pytest.raises(TopologyError, match="3 bytes for slave 1, of 4"):
        chain.publish([b"\x03" * 4, b"\x04" * 3])
    with pytest.raises(TopologyError, match="5 bytes for slave 0, of 4"):
        chain.publish(np.full((2, 5), 7, np.uint8))
    with pytest.raises(TopologyError, match="the row of slave 1"):  # a byte holds 0..255
        chain.publish([[1] * 4, [1, 2, 3, 256]])
    assert one(chain, Datagram.logical(C.LRD, 0, bytes(8))).data == b"\x01" * 4 + b"\x02" * 4
    held = [dev.app.inputs for dev in chain.devices]  # type: ignore[attr-defined]
    assert held == [b"\x01" * 4, b"\x02" * 4]


# --- the register audit against the datasheet (issue "One ESC, written once") ------------------
def diff_ns(value: int) -> int:
    """0x092C: bit 31 set when the local copy is smaller, bits 0-30 the magnitude (II 0x092C)."""
    return -(value & 0x7FFFFFFF) if value & 0x80000000 else value


@pytest.mark.parametrize("nodes", [1, 5])  # one ESC on its own, and a broadcast's joint commit
def test_dc_speed_counter_start_resets_the_system_time_difference(nodes: int) -> None:
    # SOEM's start-up: a BWR of zeros to 0x0910 (a compare with local times of seconds), then
    # 0x0930 = 0x1000. A write of Speed Counter Start resets System Time Difference 0x092C and
    # Speed Counter Diff 0x0932 (datasheet II 0x0930): both read 0, the reference clock's too.
    chain, now = clocked_chain(nodes, [(p + 1) * 10**9 for p in range(nodes)], [0.0] * nodes)
    now[0] = 1_000_000
    send(chain, Datagram(C.BWR, 0, 0x0910, bytes(8)))
    before = [
        u32(one(chain, Datagram(C.APRD, -p & 0xFFFF, 0x092C, bytes(4)))) for p in range(nodes)
    ]
    assert all(diff_ns(v) > 10**7 for v in before)  # work to do: a 16th of a second or more
    send(chain, Datagram(C.BWR, 0, 0x0930, struct.pack("<H", 0x1000)))
    for p in range(nodes):
        d = one(chain, Datagram(C.APRD, -p & 0xFFFF, 0x092C, bytes(8)))
        assert (u32(d), d.data[6:8]) == (0, b"\x00\x00")


def test_dc_synchronised_clocks_read_one_system_time_in_one_frame() -> None:
    # datasheet II 0x0910, ECAT read: "local copy of the System Time when the frame passed the
    # reference clock (i.e. including System Time Delay)". After SOEM's set-up and 1,000 FRMW
    # cycles, four patches read 0x0910 in one frame within 100 ns of each other (their delays
    # alone are 540 ns apart a hop).
    chain, now = soem_dc_chain()
    for _ in range(1000):
        now[0] += 1_000_000
        assert chain.process_frame(FRMW_REFERENCE) is not None
    now[0] += 1_000_000
    out = send(chain, *(Datagram(C.FPRD, 0x1001 + p, 0x0910, bytes(8)) for p in range(4)))
    times = [int.from_bytes(d.data, "little") for d in out]
    assert all(d.wkc == 1 for d in out)
    assert max(times) - min(times) < 100, times


def test_dc_only_a_write_including_0x0910_compares() -> None:
    # II 0x0910: the written value is compared "if at least the first byte (0x0910) was
    # written"; 0x0914-0x0917 alone change nothing. Four bytes from 0x0910: a 32-bit compare.
    chain, _ = clocked_chain(1, [1000], [0.0])
    assert one(chain, Datagram(C.APWR, 0, 0x0914, struct.pack("<I", 7))).wkc == 1
    d = one(chain, Datagram(C.APRD, 0, 0x092C, bytes(8)))
    assert (u32(d), d.data[6:8]) == (0, b"\x00\x00")
    send(chain, Datagram(C.APWR, 0, 0x0910, struct.pack("<I", 400)))  # 1000 - 400 - delay 0
    # the mean over 2^4 compares from 0: 600 / 16 = 37.5, to the nearest ns 38
    assert diff_ns(u32(one(chain, Datagram(C.APRD, 0, 0x092C, bytes(4))))) == 38


def test_dc_sync0_times_wrap_at_64_bits() -> None:
    # the system time is 64 bits: a SYNC0 start 10 ns before its end, a cycle of 1 us, read when
    # the system time is 5 ns before the end: the pulse fired, the next is (2^64 - 10 + 1000)
    # mod 2^64 = 990 (II 0x0990 read: "next SYNC0 pulse", system time)
    chain, _ = clocked_chain(1, [1000], [0.0])
    send(chain, Datagram(C.APWR, 0, 0x0920, struct.pack("<Q", (1 << 64) - 5 - 1000)))
    send(chain, Datagram(C.APWR, 0, 0x0990, struct.pack("<Q", (1 << 64) - 10)))
    send(chain, Datagram(C.APWR, 0, 0x09A0, struct.pack("<I", 1000)))
    send(chain, Datagram(C.APWR, 0, 0x0981, b"\x07"))  # cyclic, SYNC0, SYNC1 (0x09A4 = 0)
    regs = one(chain, Datagram(C.APRD, 0, 0x098E, bytes(0x12)))
    assert regs.data[0] == 1  # SYNC0 status: a pulse
    assert int.from_bytes(regs.data[2:10], "little") == 990  # 0x0990
    assert int.from_bytes(regs.data[10:18], "little") == (1 << 64) - 10  # 0x0998: next SYNC1


def test_dc_debug_pulse_bit_reads_0_and_pulse_length_comes_from_the_eeprom() -> None:
    # II 0x0981 bit 7 (SyncSignal debug pulse) self-clears: it always reads 0. II 0x0982: the
    # pulse length of the SYNC signals, read-only for ECAT, loaded from SII word 2 (I Table 42).
    info = SlaveInfo.skin_patch(16, serial=1)
    image = bytearray(build_sii(info))
    struct.pack_into("<H", image, 4, 1000)  # word 2: 1000 x 10 ns
    image[14] = crc8(bytes(image[:14]))
    chain = EcatChain([EscDevice(info, sii=bytes(image), app=NullApp())])
    assert one(chain, Datagram(C.APRD, 0, 0x0982, bytes(2))).data == u16(1000)
    send(chain, Datagram(C.APWR, 0, 0x0981, b"\x81"))
    send(chain, Datagram(C.APWR, 0, 0x0982, u16(5)))
    assert one(chain, Datagram(C.APRD, 0, 0x0981, bytes(3))).data == b"\x01" + u16(1000)


def eeprom_word_write(chain: EcatChain, word: int, value: int) -> None:
    """ECAT writes one EEPROM word: address, data, then write enable and command 2 together
    (datasheet I 11.2.3, II 0x0502-0x050F)."""
    send(chain, Datagram(C.APWR, 0, 0x0504, struct.pack("<I", word)))
    send(chain, Datagram(C.APWR, 0, 0x0508, u16(value)))
    send(chain, Datagram(C.APWR, 0, 0x0502, u16(0x0201)))


def test_eeprom_reload_brings_pdi_operational_back_and_takes_it_away() -> None:
    # I 11.1/11.2.1: "PDI operational" (DL status bit 0) and access to process RAM follow the
    # configuration area's checksum at every load, a reload command (II 0x0502 command 4) too
    chain = bare_chain(1)
    assert one(chain, Datagram(C.APWR, 0, 0x1800, b"\x5a")).wkc == 1
    crc = crc8(bytes(chain.devices[0].sii[:14]))  # word 7's low byte (I 11.1)
    eeprom_word_write(chain, 7, crc ^ 0xFF)  # a wrong checksum
    send(chain, Datagram(C.APWR, 0, 0x0502, u16(0x0400)))  # reload
    status = word(one(chain, Datagram(C.APRD, 0, 0x0502, bytes(2))))
    assert status & 0x1800 == 0x1800  # checksum error, EEPROM not loaded (II 0x0502 bits 11, 12)
    assert word(one(chain, Datagram(C.APRD, 0, 0x0110, bytes(2)))) & 0x0001 == 0
    assert one(chain, Datagram(C.APRD, 0, 0x1800, bytes(1))).wkc == 0  # no process RAM
    eeprom_word_write(chain, 7, crc)
    send(chain, Datagram(C.APWR, 0, 0x0502, u16(0x0400)))
    assert word(one(chain, Datagram(C.APRD, 0, 0x0502, bytes(2)))) & 0x1800 == 0
    assert word(one(chain, Datagram(C.APRD, 0, 0x0110, bytes(2)))) & 0x0001 == 0x0001
    d = one(chain, Datagram(C.APRD, 0, 0x1800, bytes(1)))
    assert (d.wkc, d.data) == (1, b"\x5a")  # back, with what it held


def test_the_firmware_starts_when_a_reload_brings_the_pdi_up() -> None:
    # Without a PDI nothing reads AL control, a mailbox while device emulation is off (II
    # 0x0120): a request stays there and keeps the next out. A good reload brings the PDI up
    # (I 11.2.1); the firmware starts, reads AL control, and the master's requests go through.
    info = SlaveInfo.skin_patch(16, serial=1)
    image = bytearray(build_sii(info))
    crc = image[14]
    image[14] ^= 0xFF
    chain = EcatChain([EscDevice(info, sii=bytes(image))])
    send(chain, Datagram(C.APWR, 0, 0x0120, u16(0x0004)))  # taken, never read
    eeprom_word_write(chain, 7, crc)  # the right checksum, then a reload
    send(chain, Datagram(C.APWR, 0, 0x0502, u16(0x0400)))
    send(chain, Datagram(C.APWR, 0, 0x0120, u16(0x0002)))
    assert word(one(chain, Datagram(C.APRD, 0, 0x0120, bytes(2)))) == 0x0002
    assert chain.devices[0].al_status == 0x0002  # PREOP: the firmware took the request


def test_dl_status_shows_enhanced_link_detection_from_the_eeprom() -> None:
    # II 0x0110 bit 2: enhanced link detection activated for at least one port, which the ESC
    # configuration 0x0141 (SII word 0 bits 8-15) sets: bit 1 all ports, bits 4-7 port by port
    info = dataclasses.replace(SlaveInfo.skin_patch(16, serial=1), esc_configuration=0x02)
    chain = EcatChain([EscDevice(info, app=NullApp())])
    assert one(chain, Datagram(C.APRD, 0, 0x0141, bytes(1))).data == b"\x02"
    # a single (last) ESC: 0x5613 as in test_dl_status_middle_and_last_slave, and bit 2
    assert word(one(chain, Datagram(C.APRD, 0, 0x0110, bytes(2)))) == 0x5613 | 0x0004


def test_a_write_of_either_watchdog_counter_clears_both() -> None:
    # II 0x0442/0x0443 (watchdog counter process data, PDI): "cleared if one of the watchdog
    # counters 0x0442-0x0443 is written"; the counters as expirations would have left them
    chain = bare_chain(1)
    chain.memory[0, 0x0442:0x0444] = (5, 7)
    assert one(chain, Datagram(C.APRD, 0, 0x0442, bytes(2))).data == b"\x05\x07"
    assert one(chain, Datagram(C.APWR, 0, 0x0443, b"\x09")).wkc == 1
    assert one(chain, Datagram(C.APRD, 0, 0x0442, bytes(2))).data == b"\x00\x00"


def test_a_buffer_started_anew_is_sampled_at_sync0_when_ecat_opens_it() -> None:
    # A hostile frame found this (tests/hostile_any.py, BRW of an input buffer): the input
    # SyncManager disabled and enabled again starts anew (II 2.14, 0x0806 bit 0) with no buffer;
    # with SYNC0 active, ECAT opening it lets the patch sample at the pulse (dc.py) and the
    # read returns that sample, in a configured chain as SOEM's dc_sync leaves it.
    chain, now = sync0_chain(2, 1_000_000)
    y = chain.devices[0].info.sm_of_type(SyncManagerType.INPUTS)
    assert y is not None
    start = chain.devices[0].sm_registers(y)[0]
    for value in (b"\x00", b"\x01"):  # SM disabled, enabled: a new buffer at every ESC
        send(chain, Datagram(C.BWR, 0, 0x0800 + 8 * y + 6, value))
    chain.publish([b"\x0a" * 4, b"\x0b" * 4])
    now[0] = 1_500_000  # the first pulse fired
    d = one(chain, Datagram(C.BRW, 0, start, bytes(4)))
    assert (d.data, d.wkc) == (b"\x0b" * 4, 2)  # BRW: both read (OR), neither may write (ECAT
    # reads this buffer, II 2.14); the OR of 0x0a and 0x0b is 0x0b


def test_dc_only_bwr_and_fpwr_latch_the_receive_times() -> None:
    # II 0x0900: "a write access to this register with BWR or FPWR latches the local time of
    # the beginning of the receive frame"; other writes of it (APWR, ARMW here) latch nothing.
    # Port 0 of ESC 0 at host 1,000,000 ns plus its start of 5,000 ns (see the latch test).
    chain, now = clocked_chain(2, [5000, 7000], [0.0, 0.0])
    send(chain, *(Datagram(C.APWR, -p & 0xFFFF, 0x0010, u16(0x1001 + p)) for p in range(2)))
    now[0] = 1_000_000
    send(chain, Datagram(C.APWR, 0, 0x0900, bytes(4)), Datagram(C.ARMW, 0, 0x0900, bytes(4)))
    assert u32(one(chain, Datagram(C.APRD, 0, 0x0900, bytes(4)))) == 0  # nothing latched
    # a BWR of no bytes writes nothing, so it latches nothing, now or with a later write
    send(chain, Datagram(C.BWR, 0, 0x0901, b""))
    send(chain, Datagram(C.APWR, 0, 0x0900, bytes(4)))
    assert u32(one(chain, Datagram(C.APRD, 0, 0x0900, bytes(4)))) == 0
    send(chain, Datagram(C.FPWR, 0x1001, 0x0900, bytes(4)))
    assert u32(one(chain, Datagram(C.FPRD, 0x1001, 0x0900, bytes(4)))) == 1_005_000
    assert u32(one(chain, Datagram(C.FPRD, 0x1002, 0x0900, bytes(4)))) == 0  # not addressed
    now[0] = 2_000_000
    send(chain, Datagram(C.BWR, 0, 0x0900, bytes(4)))
    assert u32(one(chain, Datagram(C.FPRD, 0x1001, 0x0900, bytes(4)))) == 2_005_000
    # ESC 1: 7,000 + 2,000,540.05 (one hop)
    assert u32(one(chain, Datagram(C.FPRD, 0x1002, 0x0900, bytes(4)))) == 2_007_540


def test_al_control_is_a_mailbox_the_pdi_must_read() -> None:
    # II 0x0120: while device emulation is off, "the PDI has to read the AL Control register
    # after ECAT has written it. Otherwise ECAT can not write again"; after a reset ECAT can.
    # With a bad configuration area the PDI never runs (I 11.2.1), so nothing reads it.
    info = SlaveInfo.skin_patch(16, serial=1)
    image = bytearray(build_sii(info))
    image[14] ^= 0xFF  # word 7: a wrong checksum
    chain = EcatChain([EscDevice(info, sii=bytes(image))])
    assert one(chain, Datagram(C.APWR, 0, 0x0120, u16(0x0002))).wkc == 1
    assert word(one(chain, Datagram(C.APRD, 0, 0x0120, bytes(2)))) == 0x0002
    assert one(chain, Datagram(C.APWR, 0, 0x0120, u16(0x0004))).wkc == 1  # counted, not taken
    assert word(one(chain, Datagram(C.APRD, 0, 0x0120, bytes(2)))) == 0x0002
    for c in b"RES":  # ESC reset: 'R', 'E', 'S' in consecutive frames (II 0x0040)
        send(chain, Datagram(C.APWR, 0, 0x0040, bytes([c])))
    assert word(one(chain, Datagram(C.APRD, 0, 0x0120, bytes(2)))) == 0x0001  # reset value
    send(chain, Datagram(C.APWR, 0, 0x0120, u16(0x0008)))
    assert word(one(chain, Datagram(C.APRD, 0, 0x0120, bytes(2)))) == 0x0008
    # a running PDI reads every write: INIT -> PREOP -> INIT, each taken
    chain = EcatChain.skin(1, 16)
    for state in (0x0002, 0x0001, 0x0002):
        send(chain, Datagram(C.APWR, 0, 0x0120, u16(state)))
        assert word(one(chain, Datagram(C.APRD, 0, 0x0120, bytes(2)))) == state
        assert chain.devices[0].al_status == state


def test_syncmanager_interrupts_reach_the_ecat_event_request() -> None:
    # II 0x0804 bit 4 enables a SyncManager's interrupt in the ECAT event request; 0x0210 bits
    # 4-11 mirror SyncManager 0-7: an input buffer the PDI wrote and ECAT has not opened yet
    # (0x0805 bit 0). Through the event mask 0x0200 it reaches every datagram's IRQ field.
    chain = EcatChain.configured(1, 4)  # inputs on SM0 at 0x1000, control 0x20
    assert one(chain, Datagram(C.APRD, 0, 0x0804, bytes(1))).data == b"\x20"
    send(chain, Datagram(C.APWR, 0, 0x0806, b"\x00"))  # disabled: its configuration writable
    send(chain, Datagram(C.APWR, 0, 0x0804, b"\x30"))  # + ECAT interrupt
    send(chain, Datagram(C.APWR, 0, 0x0806, b"\x01"))
    send(chain, Datagram(C.APWR, 0, 0x0200, u16(0x0010)))  # mask: SM0's event
    # reading DL and AL status clears their events (bits 2, 3; datasheet I Table 3)
    send(chain, Datagram(C.APRD, 0, 0x0110, bytes(2)), Datagram(C.APRD, 0, 0x0130, bytes(2)))
    assert one(chain, Datagram(C.APRD, 0, 0x0210, bytes(2))).data == b"\x00\x00"  # no buffer
    chain.publish([b"\x07" * 4])  # the PDI writes a buffer: interrupt write (II 0x0805 bit 0)
    d = one(chain, Datagram(C.APRD, 0, 0x0210, bytes(2)))
    assert (d.data, d.irq) == (b"\x10\x00", 0x0010)
    lrd = one(chain, Datagram.logical(C.LRD, 0, bytes(4)))  # ECAT opens it: the event clears
    assert (lrd.data, lrd.wkc) == (b"\x07" * 4, 1)
    d = one(chain, Datagram(C.APRD, 0, 0x0210, bytes(2)))
    assert (d.data, d.irq) == (b"\x00\x00", 0)


def test_a_master_rewrites_a_corrupted_eeprom_configuration_area() -> None:
    # Slave 1's configuration area checksum overwritten and reloaded: no PDI (I 11.2.1), its
    # firmware cannot take the master to OP; eeprom_repair_frames writes words 0-7 back and
    # reloads (I 11.2.3), after which the line is configured to OP.
    from emulator.hostile import eeprom_repair_frames

    chain = EcatChain.skin(3, 16)
    good = [bytes(dev.sii[:16]) for dev in chain.devices]
    bad = good[1][:14] + bytes([good[1][14] ^ 0xFF, good[1][15]])
    for frame in eeprom_repair_frames([good[0], bad, good[2]]):
        chain.process_frame(frame)
    assert [bool(dev.registers(0x0110, 1)[0] & 0x01) for dev in chain.devices] == [1, 0, 1]
    for frame in eeprom_repair_frames(good):
        chain.process_frame(frame)
    assert [dev.registers(0x0502, 2)[1] & 0x08 for dev in chain.devices] == [0, 0, 0]
    for frame in configure_frames(chain.devices[0].info, 3):
        assert chain.process_frame(frame) is not None
    assert [dev.al_status for dev in chain.devices] == [0x08] * 3


def test_the_firmware_s_al_status_change_reaches_the_next_frame_s_irq_field() -> None:
    # II 0x0210 bit 3, AL status event: set when the PDI changes AL status 0x0130, cleared when
    # ECAT reads it (datasheet I Table 3); under the mask 0x0200 it is ORed into every
    # datagram's IRQ field. Three patches take a broadcast INIT -> PREOP request; their firmware
    # reacts after the frame, so the request's own frame shows no event and the next one does.
    chain = EcatChain.skin(3, 16)
    send(chain, Datagram(C.BWR, 0, 0x0200, u16(0x0008)))  # mask: the AL status event only
    send(chain, Datagram(C.BRD, 0, 0x0130, bytes(2)))  # read AL status: its event clears
    assert one(chain, Datagram(C.BRD, 0, 0x0210, bytes(2))).irq == 0
    request = one(chain, Datagram(C.BWR, 0, 0x0120, u16(0x0002)))
    assert (request.wkc, request.irq) == (3, 0)
    after = send(chain, Datagram(C.NOP, 0, 0, b""), Datagram(C.APRD, -1 & 0xFFFF, 0x0210, bytes(2)))
    assert [d.irq for d in after] == [0x0008, 0x0008]
    assert word(after[1]) & 0x0008  # the second patch's own event request
    status = one(chain, Datagram(C.BRD, 0, 0x0130, bytes(2)))  # every patch reads PREOP
    assert (word(status), status.wkc) == (0x0002, 3)
    assert one(chain, Datagram(C.BRD, 0, 0x0210, bytes(2))).irq == 0
