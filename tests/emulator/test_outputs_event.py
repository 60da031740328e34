"""Outputs reach the application: the master completes a write SyncManager's buffer with an LRW
through the configured FMMU, the ESC signals the PDI (datasheet I 8.1, buffer exchange), the
application reads the buffer and, in OP, its output objects take the values.

Expected values by hand from the ESI (soes_linux_lan9252demo.xml: RxPdo 0x1600 on Sm 2 maps
0x7000:01 and 0x7000:02, 8 bits each, in that order; TxPdo 0x1A00 on Sm 3 maps 0x6000:01, 8
bits) and from the skin patch's description (RxPDO 0x1600: one UNSIGNED8 entry 0x7000:n per
output byte). The configuration maps each slave's inputs from logical 0 and its outputs after
the last input (EcatChain.configured): here the ESI slave's input byte at 0, its two output
bytes at 1 and 2. Read back over CoE with an expedited SDO upload through the mailbox, as a
master reads them (ETG.1000.6 5.6.2.4: the data in bytes 12..15 of the mailbox message).
"""

from __future__ import annotations

import struct
from pathlib import Path

from emulator.esc.chain import STATION_BASE, EcatChain
from emulator.esc.device import EscDevice
from emulator.slave.esi_slave import entry_values, esi_device, load_esi_slave
from emulator.slave.sii import SlaveInfo
from skinframes import ecat_mailbox as mb
from skinframes import ethercat
from skinframes.ethercat import Command, Datagram, EcatFrame

LAN9252 = "soes_linux_lan9252demo.xml"
SAFEOP = 0x04
SM1_STATUS = 0x080D  # the send mailbox's status; bit 3: full (datasheet II 2.14)
COUNTERS: dict[int, int] = {}  # the last mailbox counter sent to each chain (1..7, ETG.1000.4)


def one(chain: EcatChain, d: Datagram) -> Datagram:
    back = chain.process_frame(ethercat.frame(EcatFrame((d,))).to_bytes())
    assert back is not None
    ecat, _, _ = ethercat.decode(back[14:], strict=False)
    return ecat.datagrams[0]


def sdo_upload(chain: EcatChain, position: int, index: int, subindex: int) -> bytes:
    """An expedited SDO upload through the mailbox (SM0 in, SM1 out): the 4 data bytes."""
    station = STATION_BASE + position
    rx, tx = chain.devices[position].info.sync_managers[:2]
    counter = COUNTERS[id(chain)] = mb.next_counter(COUNTERS.get(id(chain), 0))
    body = mb.sdo_upload_request(index, subindex)
    request = mb.mailbox(mb.MailboxType.COE, body, counter, size=rx.length)
    assert one(chain, Datagram(Command.FPWR, station, rx.start, request)).wkc == 1
    assert one(chain, Datagram(Command.FPRD, station, SM1_STATUS, bytes(1))).data[0] & 0x08
    answer = one(chain, Datagram(Command.FPRD, station, tx.start, bytes(tx.length))).data
    assert answer[8] & 0xE0 == 0x40, answer[:16].hex()  # upload response, not an abort
    return answer[12:16]


def lrw(chain: EcatChain, data: bytes) -> Datagram:
    return one(chain, Datagram.logical(Command.LRW, 0, data))


def test_an_lrw_sets_the_esi_slaves_output_objects(shared_esi: Path) -> None:
    dev = esi_device(load_esi_slave(str(shared_esi / LAN9252)))
    chain = EcatChain.configured(0, 1, devices=[dev])
    assert [sdo_upload(chain, 0, 0x7000, s)[0] for s in (1, 2)] == [0, 0]
    back = lrw(chain, bytes([0xEE, 0xA5, 0x3C]))
    # a read through one FMMU counts 1, a write through another 2 (ETG.1000.4 Table 14)
    assert back.wkc == 3
    assert back.data[0] == 0  # the inputs: 0x6000:01, no publication yet
    assert [sdo_upload(chain, 0, 0x7000, s)[0] for s in (1, 2)] == [0xA5, 0x3C]


def test_outputs_stay_safe_in_safeop(shared_esi: Path) -> None:
    dev = esi_device(load_esi_slave(str(shared_esi / LAN9252)))
    chain = EcatChain.configured(0, 1, devices=[dev])
    lrw(chain, bytes([0, 0x11, 0x22]))
    one(chain, Datagram(Command.BWR, 0, 0x0120, struct.pack("<H", SAFEOP)))
    assert dev.al_status == SAFEOP
    assert lrw(chain, bytes([0, 0x77, 0x66])).wkc == 3  # the ESC takes it; the firmware not
    assert [sdo_upload(chain, 0, 0x7000, s)[0] for s in (1, 2)] == [0x11, 0x22]


def test_a_skin_patch_with_outputs_takes_them() -> None:
    patch = EscDevice(SlaveInfo.skin_patch(16, serial=1, output_bytes=4, mailbox=True))
    chain = EcatChain.configured(0, 1, devices=[patch])
    back = lrw(chain, bytes(16) + bytes([1, 2, 3, 4]))  # inputs at 0..15, outputs at 16..19
    assert back.wkc == 3
    assert [sdo_upload(chain, 0, 0x7000, s)[0] for s in (1, 2, 3, 4)] == [1, 2, 3, 4]


def test_entry_values_unpack_bit_by_bit() -> None:
    """ETG.1000.6 5.6.7 by hand: 0x51 0x05 0x00 holds a 1-bit entry (1), a 3-bit gap, a 4-bit
    entry (5) and a 16-bit entry (5)."""
    layout = [(0x7000, 1, 1), (0, 0, 3), (0x7000, 2, 4), (0x7001, 0, 16)]
    assert entry_values(layout, bytes([0x51, 0x05, 0x00])) == [
        (0x7000, 1, b"\x01"),
        (0x7000, 2, b"\x05"),
        (0x7001, 0, b"\x05\x00"),
    ]
