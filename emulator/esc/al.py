"""AL control and AL status of ESCs (datasheet I 10.1, II 0x0120-0x0135): the registers of the
application layer, between a master and each slave's firmware.

AL control 0x0120 is a mailbox to the PDI while device emulation is off (PDI control 0x0141
bit 0): a write the firmware has not read yet keeps the next one out (:func:`control_free`).
After a frame wrote it (:func:`control_written`), in device emulation AL status follows at
once; else the firmware reacts (the ESM,
:meth:`emulator.slave.state_machine.SlaveApplication.al_control`) and writes AL status and
its code through the PDI (:func:`status_written`), which raises the AL status event of the
ECAT event request, 0x0210 bit 3, where the status changed. Which part of a frame's register
writes reaches AL control is :mod:`emulator.esc.write_plans`'s; how the firmware's reaction
is held until the frame has passed is the ESC's (:meth:`emulator.esc.device.EscDevice._hold`).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Final, Protocol, TypeVar

import numpy as np
import numpy.typing as npt

from emulator.esc.registers import (
    DEVICE_EMULATION,
    EVENT_AL_STATUS,
    REG_AL_CONTROL,
    REG_AL_STATUS,
    REG_ECAT_EVENT,
    REG_PDI_CONTROL,
    Memory,
)

__all__ = [
    "AL_CONTROL",
    "AlEsc",
    "AlMailbox",
    "control_free",
    "control_written",
    "reactions",
    "status",
    "status_written",
]

AL_CONTROL: Final = (REG_AL_CONTROL, REG_AL_CONTROL + 2)  # [start, end): a mailbox to the PDI
_Rows = npt.NDArray[np.intp]


class AlMailbox(Protocol):
    """An ESC's AL control as a mailbox: whether it holds a write the firmware has not read."""

    al_control_full: bool


class AlEsc(AlMailbox, Protocol):
    """What AL control asks of an ESC besides (:class:`AlMailbox`): whether its PDI runs (the
    EEPROM's load), and the PDI's write of AL status."""

    pdi_operational: bool

    def pdi_set_al_status(self, state: int, *, error: bool, code: int) -> None: ...


E = TypeVar("E", bound=AlEsc)


def control_free(
    devices: Sequence[AlMailbox], memory: npt.NDArray[np.uint8], rows: _Rows
) -> npt.NDArray[np.bool_]:
    """Per ESC of ``devices`` (memory ``memory[rows]``), whether ECAT may write AL control now:
    its last write read by the firmware, or device emulation on (datasheet II 0x0120)."""
    free = np.fromiter([not dev.al_control_full for dev in devices], np.bool_, len(devices))
    free |= (memory[rows, REG_PDI_CONTROL + 1] & DEVICE_EMULATION) != 0
    return free


def control_written(
    devices: Sequence[E],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    which: npt.NDArray[np.intp],
) -> list[tuple[E, int]]:
    """After a frame's writes reached AL control of ``devices[i]`` for ``i`` in ``which``
    (memory ``memory[rows]``): outside device emulation the mailbox is full until the firmware
    reads it; then :func:`reactions` to the values written."""
    at = rows[which]
    value = memory[at, REG_AL_CONTROL].astype(np.int64)
    value |= memory[at, REG_AL_CONTROL + 1].astype(np.int64) << 8
    control = memory[at, REG_PDI_CONTROL + 1].tolist()
    writers = [devices[i] for i in which.tolist()]
    for writer, pdi in zip(writers, control, strict=True):
        writer.al_control_full = not pdi & DEVICE_EMULATION
    return reactions(writers, value.tolist(), control)


def reactions(
    devices: Sequence[E], values: Sequence[int], pdi_control: Sequence[int]
) -> list[tuple[E, int]]:
    """At each of ``devices`` whose PDI runs, AL control ``values`` written, with its PDI control
    byte 0x0141: in device emulation (bit 0) AL status follows AL control at once (state bits
    0-3, error bit 4, code 0); else its firmware is to react to the value (datasheet I 10.1):
    those (ESC, value), in order, for the caller, who holds them until the frame has passed."""
    firmware: list[tuple[E, int]] = []
    for dev, value, control in zip(devices, values, pdi_control, strict=True):
        if not dev.pdi_operational:
            continue
        if control & DEVICE_EMULATION:
            dev.pdi_set_al_status(value & 0x0F, error=bool(value & 0x10), code=0)
        else:
            firmware.append((dev, value))
    return firmware


def status(mem: Memory) -> int:
    """AL status 0x0130 of an ESC's memory ``mem``: the state in bits 0-3, error bit 4."""
    return mem[REG_AL_STATUS] | mem[REG_AL_STATUS + 1] << 8


def status_written(mem: Memory, state: int, *, error: bool, code: int) -> bool:
    """AL status 0x0130 (``state``, the error indication bit 4) and AL status code 0x0134 as
    the PDI writes them into an ESC's memory ``mem``: whether AL status changed, which sets
    the AL status event 0x0210 bit 3 (set here; the ESC's IRQ is the caller's)."""
    value = (state & 0x0F) | (0x10 if error else 0)
    changed = value != status(mem)
    if changed:
        mem[REG_ECAT_EVENT] |= EVENT_AL_STATUS
    struct.pack_into("<HxxH", mem, REG_AL_STATUS, value, code)
    return changed
