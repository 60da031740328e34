"""Register writes: how a write of (address, length) is cut, once per ESC configuration (the plain
parts masked as whole integers, datasheet I 3.4, II "ECAT" write columns), and what a write of
the registers with side effects does (:func:`write_special`): the one description of those
registers, which the commit of a frame's writes (:func:`emulator.esc.device.commit_together`)
reads for every ESC."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Final, Protocol

import numpy as np
import numpy.typing as npt

from emulator.esc.al import AL_CONTROL, control_free
from emulator.esc.dc import DcClock, compare_together
from emulator.esc.mapping import PLAN_CACHE_ENTRIES, Caches, remember
from emulator.esc.registers import (
    FMMU_BYTES,
    REG_DC_END,
    REG_DC_OFFSET,
    REG_DC_RECEIVE,
    REG_DC_RECEIVE_PU,
    REG_DL_CONTROL,
    REG_EEPROM_CONFIG,
    REG_EEPROM_CONTROL,
    REG_EEPROM_PDI,
    REG_ERROR_COUNTERS,
    REG_FMMU,
    REG_PU_ERRORS,
    REG_RESET_ECAT,
    REG_SM,
    REGISTER_END,
    SM_BYTES,
    EscConfig,
    write_masks,
)

__all__ = [
    "AL_CONTROL",
    "EEPROM_INTERFACE",
    "ERROR_COUNTERS",
    "TOUCHES_FMMU",
    "TOUCHES_SM",
    "WATCHDOG_COUNTERS",
    "WritePlans",
    "WriteTarget",
    "mark",
    "write_masked",
    "write_special",
]

# The registers whose ECAT writes do more than store (datasheet II), besides the SyncManagers and
# the DC latch and compare: [start, end) of each block; what a write there does: write_special
ERROR_COUNTERS: Final = (REG_ERROR_COUNTERS, 0x0314)  # RX, forwarded, PU, PDI, lost link (II 2.6)
WATCHDOG_COUNTERS: Final = (0x0442, 0x0444)  # process data, PDI: a write clears both (II 0x0442)
EEPROM_INTERFACE: Final = (REG_EEPROM_CONFIG, 0x0510)  # SII EEPROM interface (I 11.2, II 2.11)


class WriteTarget(Protocol):
    """What :func:`write_special` asks of an ESC: its distributed clocks, whether a BWR or FPWR
    of the receive time register 0x0900 reached it in this frame (the writes that latch,
    datasheet II 0x0900), and whether its AL control holds a write the PDI has not read."""

    dc: DcClock
    latch_due: bool
    al_control_full: bool


TOUCHES_FMMU: Final = 1
TOUCHES_SM: Final = 2
_Rows = npt.NDArray[np.intp]
Segment = tuple[int, int, int, bool]  # lo, hi, mask (-1: side effects), may set a flag
WritePlan = tuple[tuple[Segment, ...], int]


class WritePlans:
    """How a register write of (address, length) is cut for ESCs of one configuration.

    Plain parts are masked as whole integers (their write mask, datasheet II "ECAT" column,
    and whether they touch AL control, DL control, FMMUs or DC registers); the registers with
    side effects (error counters 0x0300-0x0313, 0x0442-0x0443, the EEPROM interface
    0x0500-0x050F byte 0x0500/0x0501 one by one, SyncManagers, DC receive times 0x0900-0x0917)
    are cut into the parts :func:`emulator.esc.device.write_special` handles. One plan serves every
    ESC a broadcast reaches.
    """

    @classmethod
    def of(cls, caches: Caches, config: EscConfig) -> WritePlans:
        """The plans for ``config`` kept in a chain's ``caches``: one object for its ESCs of
        that configuration."""
        plans: WritePlans | None = caches.write_plans.get(config)
        if plans is None:
            plans = caches.write_plans[config] = cls(config)
        return plans

    def __init__(self, config: EscConfig) -> None:
        self.masks = write_masks(config)
        self.mask_array = np.frombuffer(self.masks, np.uint8)  # for many ESCs' rows at once
        self.fmmu_end = REG_FMMU + FMMU_BYTES * config.fmmus
        self.sm_end = REG_SM + SM_BYTES * config.syncmanagers
        self.special = (  # registers written in parts (side effects), ascending
            AL_CONTROL,
            ERROR_COUNTERS,
            WATCHDOG_COUNTERS,
            EEPROM_INTERFACE,
            (REG_SM, self.sm_end),
            (REG_DC_RECEIVE, REG_DC_RECEIVE_PU),
        )
        self._plans: dict[tuple[int, int], WritePlan] = {}

    def plan(self, addr: int, n: int) -> WritePlan:
        """The segments of a write of ``n`` bytes at ``addr`` (< 0x0F80, not beyond it)."""
        key = (addr, n)
        found = self._plans.get(key)
        if found is None:
            found = remember(self._plans, key, self._cut(addr, addr + n), PLAN_CACHE_ENTRIES)
        return found

    def inert(self, addr: int, n: int) -> bool:
        """Whether a write of ``n`` bytes at ``addr`` (< 0x0F80, not beyond it) changes nothing:
        registers without side effects whose ECAT write mask is 0 (read-only or reserved), and
        not the reset register, whose writes count towards a reset (datasheet II 2.3)."""
        if addr <= REG_RESET_ECAT < addr + n:
            return False
        return all(mask == 0 for _, _, mask, _ in self.plan(addr, n)[0])

    def _cut(self, pos: int, end: int) -> WritePlan:
        segments: list[Segment] = []
        touches = 0
        while pos < end:
            hi = min(end, self._next_special(pos))
            if hi > pos:
                mask = int.from_bytes(self.masks[pos:hi], "little")
                marks = (
                    (pos < REG_DL_CONTROL + 4 and hi > REG_DL_CONTROL)
                    or (pos < self.fmmu_end and hi > REG_FMMU)
                    or (pos < REG_DC_END and hi > REG_DC_OFFSET)
                )
                segments.append((pos, hi, mask, marks))
                if pos < self.fmmu_end and hi > REG_FMMU:
                    touches |= TOUCHES_FMMU
                pos = hi
            if pos < end:
                hi = self._special_end(pos, end)
                segments.append((pos, hi, -1, True))
                if REG_SM <= pos < self.sm_end:
                    touches |= TOUCHES_SM
                pos = hi
        return tuple(segments), touches

    def _next_special(self, pos: int) -> int:
        """The first register at or after ``pos`` that a write cannot simply mask."""
        for lo, hi in self.special:
            if pos < hi:
                return max(pos, lo)
        return REGISTER_END

    def _special_end(self, lo: int, end: int) -> int:
        """Where the part of a write at ``lo`` (in a special block) that one call of
        :func:`emulator.esc.device.write_special` handles ends."""
        if lo < AL_CONTROL[1]:
            return min(end, AL_CONTROL[1])
        if lo < REG_PU_ERRORS:  # the RX error counters, cleared together
            return min(end, REG_PU_ERRORS)
        if lo < ERROR_COUNTERS[1]:
            return min(end, ERROR_COUNTERS[1])
        if lo < REG_EEPROM_CONFIG:  # the watchdog counters
            return min(end, WATCHDOG_COUNTERS[1])
        if lo < REG_EEPROM_CONTROL:  # 0x0500, 0x0501: byte by byte
            return lo + 1
        if lo < EEPROM_INTERFACE[1]:
            return min(end, EEPROM_INTERFACE[1])
        if lo >= REG_DC_RECEIVE:
            return min(end, REG_DC_RECEIVE_PU)
        return min(end, self.sm_end)


def mark(
    lo: int, hi: int, flags: list[bool], fmmu_end: int, dc: tuple[int, int] | None
) -> tuple[int, int] | None:
    """Note in ``flags`` what a masked register write of [lo, hi) changed (DL control, the FMMUs
    below ``fmmu_end``); the DC registers written, [lo, hi) joined to ``dc``."""
    if lo < REG_DL_CONTROL + 4 and hi > REG_DL_CONTROL:
        flags[2] = True
    if lo < fmmu_end and hi > REG_FMMU:
        flags[3] = True
    if lo < REG_DC_END and hi > REG_DC_OFFSET:
        return (lo, hi) if dc is None else (min(dc[0], lo), max(dc[1], hi))
    return dc


# bytes a row from which write_masked writes a run of whole bytes straight and masks only its ends:
# that saves passes over the bytes, but takes four more accesses of the rows, dearer for fewer
_WIDE: Final = 256


def write_masked(
    memory: npt.NDArray[np.uint8],
    rows: _Rows | slice,
    lo: int,
    hi: int,
    data: npt.NDArray[np.uint8],
    mask: npt.NDArray[np.uint8],
) -> None:
    """Bytes [lo, hi) of ``rows`` from ``data`` (one row, or one per row) where ``mask`` has
    bits: read-only and reserved bits keep their value (datasheet II, column ECAT)."""
    if hi - lo >= _WIDE and (mask[1:-1] == 0xFF).all():  # whole bytes: only the ends masked
        memory[rows, lo + 1 : hi - 1] = data[..., 1:-1]
        for k in (0, hi - lo - 1):
            if mask[k]:
                old_k = memory[rows, lo + k]
                memory[rows, lo + k] = (old_k & ~mask[k]) | (data[..., k] & mask[k])
        return
    old = memory[rows, lo:hi]
    memory[rows, lo:hi] = (old & ~mask) | (data & mask)


def write_special(
    devices: Sequence[WriteTarget],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    lo: int,
    hi: int,
    data: npt.NDArray[np.uint8],
    enabled: npt.NDArray[np.uint8] | None,
    masks: npt.NDArray[np.uint8],
    flags: list[bool],
    eeprom: npt.NDArray[np.bool_],
    al: npt.NDArray[np.bool_],
) -> None:
    """A write of ``data`` (one row, or one per row) into [lo, hi) at every row, a part of one
    register block with side effects (cut by :meth:`WritePlans.plan`) of ``devices``: AL control
    where ECAT may write it (:func:`emulator.esc.al.control_free`; ``al`` marks the rows whose
    firmware is to react), error counters and watchdog counters cleared (II 2.6, 0x0442), the
    EEPROM interface where ECAT owns it (I 11.2.2), SyncManager bytes 0-4 kept where the
    SyncManager was enabled (II 2.14.1), DC receive times and system time compare
    (:func:`compare_together`)."""
    if lo < AL_CONTROL[1]:  # a mailbox (al.control_free); the firmware reacts to ``al``'s rows
        free = control_free(devices, memory, rows)
        if free.any():
            taken = data[free] if data.ndim > 1 else data
            write_masked(memory, rows[free], lo, hi, taken, masks[lo:hi])
            if lo == AL_CONTROL[0]:  # (a write of its high byte alone is no request)
                al |= free
        return
    if lo < REG_PU_ERRORS:  # one write clears all RX error counters
        memory[rows, REG_ERROR_COUNTERS:REG_PU_ERRORS] = 0
        return
    if lo < ERROR_COUNTERS[1]:  # each other counter is cleared by a write of it
        memory[rows, lo:hi] = 0
        return
    if lo < REG_EEPROM_CONFIG:  # a write of either watchdog counter clears both (II 0x0442)
        memory[rows, WATCHDOG_COUNTERS[0] : WATCHDOG_COUNTERS[1]] = 0
        return
    if lo < REG_EEPROM_CONTROL:  # 0x0500 may hand the interface to ECAT
        if lo == REG_EEPROM_CONFIG:
            force = np.broadcast_to((data[..., 0] & 0x02) != 0, rows.shape)
            memory[rows[force], REG_EEPROM_PDI] &= 0xFE  # force ECAT access
        write_masked(memory, rows, lo, hi, data, masks[lo:hi])
        return
    if lo < EEPROM_INTERFACE[1]:
        owner = ((memory[rows, REG_EEPROM_CONFIG] | memory[rows, REG_EEPROM_PDI]) & 0x01) == 0
        if owner.any():
            mine = data[owner] if data.ndim > 1 else data
            write_masked(memory, rows[owner], lo, hi, mine, masks[lo:hi])
            if lo < REG_EEPROM_CONTROL + 2:
                eeprom |= owner
        return
    if lo >= REG_DC_RECEIVE:  # receive time latch, system time compare
        latching = np.fromiter([dev.latch_due for dev in devices], np.bool_, len(devices))
        for dev in devices:
            dev.latch_due = False
        mine = data if data.ndim > 1 else data.tobytes()
        compare_together([dev.dc for dev in devices], memory, rows, lo, mine, latching)
        return
    assert enabled is not None
    # configuration bytes 0-4 of a SyncManager enabled before the frame keep their value
    at = np.arange(lo - REG_SM, hi - REG_SM)
    keep = (enabled[:, at // SM_BYTES] & 0x01).astype(np.bool_) & (at % SM_BYTES < 5)
    old = memory[rows, lo:hi]
    new = np.where(keep, old, data)
    mask = masks[lo:hi]
    memory[rows, lo:hi] = (old & ~mask) | (new & mask)  # _masked, the bytes before at hand
    flags[4] = True
