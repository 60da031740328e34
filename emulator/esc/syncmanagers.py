"""SyncManagers (datasheet I 8, II 2.14): the run-time state of one (:class:`SmRun`) and what an
access of its buffer does to its status register 0x0805 + 8 n, written once.

Each side, ECAT and the PDI, opens a buffer and completes it (datasheet I 8.1, 8.2; II 0x0805):
a function of the status byte says what each event leaves there (:func:`ecat_opened`,
:func:`ecat_completed`, :func:`pdi_wrote`, :func:`pdi_read`), for one ESC's byte; the tables
(:data:`ECAT_OPENED_READ`, :data:`ECAT_READ`, :data:`ECAT_EMPTIED`) are the same functions at
every byte value, for the bytes of many ESCs at once (:func:`through`). The table of
SyncManagers and how a change of it keeps or starts them anew are
:mod:`emulator.esc.mapping`'s (:func:`~emulator.esc.mapping.sm_table`,
:func:`~emulator.esc.mapping.sm_change`); which SyncManager an ESC's access meets is
:class:`emulator.esc.device.EscDevice`'s.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.esc.registers import (
    SM_ECAT_INTERRUPT,
    SM_IRQ_READ,
    SM_IRQ_WRITE,
    SM_MAILBOX_FULL,
    SM_READ_OPEN,
    SM_WRITE_OPEN,
)

__all__ = [
    "ECAT_EMPTIED",
    "ECAT_OPENED_READ",
    "ECAT_READ",
    "SmRun",
    "ecat_completed",
    "ecat_interrupt_pending",
    "ecat_opened",
    "pdi_read",
    "pdi_wrote",
    "through",
]

_Rows = npt.NDArray[np.intp]


class SmRun:
    """Run-time state of one enabled SyncManager (datasheet I 8.1/8.2)."""

    __slots__ = (
        "buf",
        "complete",
        "control",
        "ecat_interrupt",
        "ecat_writes",
        "end",
        "full",
        "index",
        "length",
        "locked",
        "mailbox",
        "open",
        "shared",
        "start",
    )

    def __init__(
        self,
        index: int,
        start: int,
        length: int,
        control: int,
        locked: bool = False,
        shared: bool = False,
    ) -> None:
        self.index = index
        self.start = start
        self.length = length
        self.end = start + length
        self.control = control
        # as new, shared by the ESCs with its table entry until one changes it (EscDevice._own)
        self.shared = shared
        self.mailbox = control & 0x03 == 0x02  # control bits 0-1: mode
        self.ecat_writes = control & 0x0C == 0x04  # bits 2-3: direction
        self.ecat_interrupt = control & SM_ECAT_INTERRUPT != 0  # bit 4: into 0x0210
        self.locked = locked  # deactivated by the PDI: the whole area is protected
        # ECAT side opened the buffer (accessed the start address); accessed the end address
        # in this frame; the mailbox is full (mailbox mode)
        self.open = self.complete = self.full = False
        # ECAT's buffer while open: a write SyncManager's, written at the end of the frame
        # that completes it; a read SyncManager's as it was opened (its bytes in memory, the
        # buffer the PDI completed last: the PDI writes a read buffer whole, pdi_write)
        self.buf: bytes | bytearray | None = None


def _written(status: int, mailbox: bool) -> int:
    """The status once one side wrote a buffer whole: the write interrupt set, and a mailbox
    full, else the 3-buffer mode's next buffer (bits 4-5: 0, 1, 2, round again; 3, no buffer
    written yet, goes to 0)."""
    status |= SM_IRQ_WRITE
    if mailbox:
        return status | SM_MAILBOX_FULL
    last = (status >> 4) & 0x03
    return (status & 0xCF) | ((last + 1) % 3 if last < 3 else 0) << 4


def ecat_opened(status: int, ecat_writes: bool) -> int:
    """ECAT accessed the buffer's start address: a write buffer open (the read interrupt, for
    the PDI, cleared), or a read buffer open (its write interrupt cleared)."""
    if ecat_writes:
        return (status & ~SM_IRQ_READ) | SM_WRITE_OPEN
    return (status & ~SM_IRQ_WRITE) | SM_READ_OPEN


def ecat_completed(status: int, ecat_writes: bool, mailbox: bool) -> int:
    """The frame that accessed the buffer's end address has passed (the buffer exchange): a
    write buffer written (no longer open, :func:`_written`), or a read buffer read (no longer
    open, the read interrupt for the PDI, and a mailbox empty)."""
    if ecat_writes:
        return _written(status & ~SM_WRITE_OPEN, mailbox)
    if mailbox:
        return (status & ~(SM_READ_OPEN | SM_MAILBOX_FULL)) | SM_IRQ_READ
    return (status & ~SM_READ_OPEN) | SM_IRQ_READ


def pdi_wrote(status: int, mailbox: bool) -> int:
    """The PDI wrote a read buffer whole (:func:`_written`): the read interrupt cleared."""
    return _written(status, mailbox) & ~SM_IRQ_READ


def pdi_read(status: int, mailbox: bool) -> int:
    """The PDI read a write buffer: the write interrupt cleared, the read interrupt set, and a
    mailbox empty."""
    status = (status & ~SM_IRQ_WRITE) | SM_IRQ_READ
    return status & ~SM_MAILBOX_FULL if mailbox else status


def ecat_interrupt_pending(control: int, status: int) -> bool:
    """Whether a SyncManager's interrupt for ECAT (0x0210 bits 4-11) is pending, by its control
    and status bytes (datasheet II 0x0210, 0x0804): enabled by control bit 4, and a buffer the
    PDI wrote that ECAT has not opened (status bit 0, ECAT reads it), or read and ECAT has not
    written again (bit 1, ECAT writes it)."""
    for_ecat = SM_IRQ_READ if control & 0x0C == 0x04 else SM_IRQ_WRITE
    return bool(control & SM_ECAT_INTERRUPT and status & for_ecat)


def _table(change: Callable[[int], int]) -> npt.NDArray[np.uint8]:
    """``change`` at each of the 256 values of a status byte: every ESC's byte changed in one
    look-up (:func:`through`); read-only."""
    table = np.array([change(b) & 0xFF for b in range(256)], np.uint8)
    table.flags.writeable = False
    return table


# a read SyncManager's status as ECAT opens its buffer, and completes it (a mailbox's too)
ECAT_OPENED_READ: Final = _table(lambda status: ecat_opened(status, False))
ECAT_READ: Final = _table(lambda status: ecat_completed(status, False, False))
ECAT_EMPTIED: Final = _table(lambda status: ecat_completed(status, False, True))


def through(
    memory: npt.NDArray[np.uint8], at: _Rows | slice, column: int, table: npt.NDArray[np.uint8]
) -> None:
    """The bytes ``memory[at, column]`` through ``table`` (256 values), in place."""
    if isinstance(at, slice):
        view = memory[at, column]
        table.take(view, out=view)
    else:
        memory[at, column] = table.take(memory[at, column])
