"""The process data interface (PDI) as a slave's firmware sees its ESC.

A real ESC and its microcontroller meet at the PDI (datasheet I 10, "PDI"; section III for the
physical interfaces): the firmware reads and writes the ESC's memory (a whole input buffer is a
buffer exchange, datasheet I 8.1), sets AL status and its code (I 10.1), deactivates
SyncManagers and acknowledges repeat requests through 0x0807 (II 2.14.7), and learns of events
(AL control written, a mailbox or SyncManager event, a SYNC0 pulse) through calls of its
application (:class:`emulator.slave.state_machine.PdiApplication`). The firmware modules
(:mod:`~emulator.slave.state_machine`, :mod:`~emulator.slave.mailbox`, :mod:`~emulator.slave.coe`,
:mod:`~emulator.slave.objects`) are written against :class:`Pdi`, not against the ESC that
implements it (:class:`emulator.esc.device.EscDevice`), so that the ESC and its firmware depend
on one narrow interface and never on each other.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol

from emulator.esc.registers import EscConfig

__all__ = ["Pdi"]


class Pdi(Protocol):
    """What a slave application may do with its ESC."""

    @property
    def config(self) -> EscConfig:
        """The ESC's identity registers (how many SyncManagers it has)."""

    @property
    def al_status(self) -> int:
        """AL status 0x0130: state in bits 0-3, error indication bit 4."""

    @property
    def al_status_code(self) -> int:
        """AL status code 0x0134."""

    @property
    def dc_sampling(self) -> bool:
        """SYNC0 is active and the application samples at its pulses (0x0981 bits 0, 1)."""

    def registers(self, addr: int, length: int) -> bytes:
        """Memory as the PDI reads it, without side effects (status registers, for example)."""

    def sm_registers(self, index: int) -> tuple[int, int, int, int]:
        """(start, length, control, activate) of SyncManager ``index``."""

    def pdi_read(self, addr: int, length: int) -> bytes:
        """Read memory: a write SyncManager's buffer the master committed (its read event)."""

    def pdi_write(self, addr: int, data: bytes) -> None:
        """Write memory: a whole read SyncManager buffer is a buffer exchange."""

    def pdi_set_al_status(self, state: int, *, error: bool, code: int) -> None:
        """Write AL status and AL status code (datasheet I 10.1)."""

    def pdi_deactivate_sms(self, indices: Iterable[int], deactivate: bool) -> None:
        """Lock or release SyncManagers (0x0807 bit 0, datasheet I 8.7)."""

    def pdi_set_repeat_ack(self, index: int, value: bool) -> None:
        """A mailbox's repeat acknowledge (0x0807 bit 1, datasheet II 2.14.7)."""
