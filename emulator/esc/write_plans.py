"""How a register write of (address, length) is cut, once per ESC configuration: the plain parts
masked as whole integers, the registers with side effects in the parts the ESC handles one by
one (datasheet I 3.4, II "ECAT" write columns)."""

from __future__ import annotations

from typing import ClassVar, Final

import numpy as np

from emulator.esc.dc import REG_DC_END, REG_DC_OFFSET, REG_DC_RECEIVE, REG_DC_RECEIVE_PU
from emulator.esc.mapping import PLAN_CACHE_ENTRIES, remember
from emulator.esc.registers import (
    FMMU_BYTES,
    REG_AL_CONTROL,
    REG_DL_CONTROL,
    REG_EEPROM_CONFIG,
    REG_EEPROM_CONTROL,
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

__all__ = ["TOUCHES_FMMU", "TOUCHES_SM", "WritePlans", "mark"]

TOUCHES_FMMU: Final = 1
TOUCHES_SM: Final = 2
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

    _by_config: ClassVar[dict[EscConfig, WritePlans]] = {}

    @classmethod
    def of(cls, config: EscConfig) -> WritePlans:
        plans = cls._by_config.get(config)
        if plans is None:
            plans = cls._by_config[config] = cls(config)
        return plans

    def __init__(self, config: EscConfig) -> None:
        self.masks = write_masks(config)
        self.mask_array = np.frombuffer(self.masks, np.uint8)  # for many ESCs' rows at once
        self.fmmu_end = REG_FMMU + FMMU_BYTES * config.fmmus
        self.sm_end = REG_SM + SM_BYTES * config.syncmanagers
        self.special = (  # registers written in parts (side effects), ascending
            (REG_ERROR_COUNTERS, 0x0314),
            (0x0442, 0x0444),
            (REG_EEPROM_CONFIG, 0x0510),
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
                    pos <= REG_AL_CONTROL < hi
                    or (pos < REG_DL_CONTROL + 4 and hi > REG_DL_CONTROL)
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
        if lo < REG_PU_ERRORS:  # the RX error counters, cleared together
            return min(end, REG_PU_ERRORS)
        if lo < 0x0314:
            return min(end, 0x0314)
        if lo < REG_EEPROM_CONFIG:  # 0x0442-0x0443
            return min(end, 0x0444)
        if lo < REG_EEPROM_CONTROL:  # 0x0500, 0x0501: byte by byte
            return lo + 1
        if lo < 0x0510:
            return min(end, 0x0510)
        if lo >= REG_DC_RECEIVE:
            return min(end, REG_DC_RECEIVE_PU)
        return min(end, self.sm_end)


def mark(
    lo: int, hi: int, flags: list[bool], fmmu_end: int, dc: tuple[int, int] | None
) -> tuple[int, int] | None:
    """Note in ``flags`` what a masked register write of [lo, hi) changed (AL control, DL
    control, the FMMUs below ``fmmu_end``); the DC registers written, [lo, hi) joined to ``dc``."""
    if lo <= REG_AL_CONTROL < hi:
        flags[0] = True
    if lo < REG_DL_CONTROL + 4 and hi > REG_DL_CONTROL:
        flags[2] = True
    if lo < fmmu_end and hi > REG_FMMU:
        flags[3] = True
    if lo < REG_DC_END and hi > REG_DC_OFFSET:
        return (lo, hi) if dc is None else (min(dc[0], lo), max(dc[1], hi))
    return dc
