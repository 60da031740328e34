"""What each access of a SyncManager's buffer leaves in its status register 0x0805 + 8 n, by the
bits of datasheet II 0x0805 (bit 0 write interrupt: a buffer completely written; bit 1 read
interrupt: completely read; bit 3 mailbox full; bits 4-5 the 3-buffer mode's last written
buffer, 3 for none yet; bit 6 read buffer open; bit 7 write buffer open) and II 0x0210 for the
interrupt for ECAT. Every expected byte is worked out by hand from those bits."""

from __future__ import annotations

import numpy as np

from emulator.esc import syncmanagers as sm

NONE_WRITTEN = 0x30  # 3-buffer mode's status at reset: bits 4-5 = 3, no buffer written yet


def test_the_pdi_writes_the_three_buffers_in_turn() -> None:
    seen, status = [], NONE_WRITTEN
    for _ in range(4):
        status = sm.pdi_wrote(status, mailbox=False)
        seen.append(status)
    assert seen == [0x01, 0x11, 0x21, 0x01]  # buffers 1, 2, 3, then 1 again; write interrupt


def test_a_mailbox_the_pdi_wrote_is_full_and_ecat_reading_it_empties_it() -> None:
    written = sm.pdi_wrote(0x02, mailbox=True)
    assert written == 0x09  # write interrupt, full; the read interrupt cleared
    opened = sm.ecat_opened(written, ecat_writes=False)
    assert opened == 0x48  # read buffer open, the write interrupt cleared
    assert sm.ecat_completed(opened, ecat_writes=False, mailbox=True) == 0x02  # read, empty


def test_ecat_reads_a_buffer_of_the_three_buffer_mode() -> None:
    assert sm.ecat_opened(0x11, ecat_writes=False) == 0x50
    assert sm.ecat_completed(0x50, ecat_writes=False, mailbox=False) == 0x12  # buffer kept


def test_ecat_writes_a_mailbox_and_the_pdi_reads_it() -> None:
    opened = sm.ecat_opened(0x02, ecat_writes=True)
    assert opened == 0x80  # write buffer open, the read interrupt cleared
    written = sm.ecat_completed(opened, ecat_writes=True, mailbox=True)
    assert written == 0x09  # closed, full, write interrupt
    assert sm.pdi_read(written, mailbox=True) == 0x02  # empty, read interrupt


def test_ecat_writes_the_first_buffer_of_the_three_buffer_mode() -> None:
    opened = sm.ecat_opened(NONE_WRITTEN, ecat_writes=True)
    assert opened == 0xB0
    assert sm.ecat_completed(opened, ecat_writes=True, mailbox=False) == 0x01  # buffer 1
    assert sm.pdi_read(0x01, mailbox=False) == 0x02


def test_the_interrupt_for_ecat_waits_on_its_own_side() -> None:
    ecat_reads, ecat_writes = 0x10 | 0x00, 0x10 | 0x04  # control bit 4, direction bits 2-3
    assert sm.ecat_interrupt_pending(ecat_reads, 0x01)  # written by the PDI, not yet opened
    assert not sm.ecat_interrupt_pending(ecat_reads, 0x02)
    assert sm.ecat_interrupt_pending(ecat_writes, 0x02)  # read by the PDI, not written again
    assert not sm.ecat_interrupt_pending(ecat_writes, 0x01)
    assert not sm.ecat_interrupt_pending(0x00, 0x01)  # not enabled by control bit 4


def test_the_tables_change_the_bytes_of_many_escs_at_once() -> None:
    memory = np.zeros((3, 4), np.uint8)
    memory[:, 2] = (0x09, 0x11, 0x21)  # a full mailbox; buffers 2 and 3 written
    sm.through(memory, slice(0, 3), 2, sm.ECAT_OPENED_READ)
    assert memory[:, 2].tolist() == [0x48, 0x50, 0x60]
    sm.through(memory, np.array([1, 2], np.intp), 2, sm.ECAT_READ)
    assert memory[:, 2].tolist() == [0x48, 0x12, 0x22]
    sm.through(memory, np.array([0], np.intp), 2, sm.ECAT_EMPTIED)
    assert memory[:, 2].tolist() == [0x02, 0x12, 0x22]
