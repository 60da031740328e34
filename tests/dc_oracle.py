"""A clock-by-clock model of what writes do to an ESC's distributed clocks: the oracle that
:func:`emulator.esc.dc.compare_together` and :func:`~emulator.esc.dc.configure_together` (the
product's one implementation, over rows of clocks) are held equal to.

It is the per-clock code the product had before those array functions became the only ones
(issue "One ESC, written once"), with the datasheet fixes since: a compare needs 0x0910 itself,
0x0930 resets 0x092C and 0x0932 (datasheet II 0x0910, 0x0930). Functions of a
:class:`~emulator.esc.dc.DcClock` (its state, read and written as the clock keeps it) and the
ESC's memory.
"""

from __future__ import annotations

import struct

from emulator.esc.dc import (
    INTEGRAL_FACTOR,
    MAX_CORRECTION,
    PHASE_NS_PER_SPEED_COUNT,
    REG_DC_ACTIVATION,
    REG_DC_DELAY,
    REG_DC_DIFF,
    REG_DC_DIFF_FILTER,
    REG_DC_RECEIVE,
    REG_DC_RECEIVE_PU,
    REG_DC_SPEED_DIFF,
    REG_DC_SPEED_START,
    REG_DC_START_TIME,
    REG_DC_SYSTEM_TIME,
    SPEED_DIFF_UNIT,
    DcClock,
)
from emulator.esc.registers import Memory

_U64 = struct.Struct("<Q")
_U32 = struct.Struct("<I")


def write(self: DcClock, mem: Memory, lo: int, data: bytes) -> None:
    """A write into 0x0900-0x0917: the receive time latch or a system time compare."""
    hi = lo + len(data)
    if lo < REG_DC_RECEIVE + 4 and hi > REG_DC_RECEIVE:
        _latch(self, mem)
    if lo <= REG_DC_SYSTEM_TIME < hi:  # only "if at least the first byte (0x0910) was
        a, b = REG_DC_SYSTEM_TIME, min(hi, REG_DC_RECEIVE_PU)  # written" (II 0x0910)
        current = bytearray(_U64.pack(self.system_time(mem, self._arrival_ns() or 0)))
        current[a - REG_DC_SYSTEM_TIME : b - REG_DC_SYSTEM_TIME] = data[a - lo : b - lo]
        compare(self, mem, _U64.unpack(current)[0], wide=b - REG_DC_SYSTEM_TIME > 4)


def configured(self: DcClock, mem: Memory, lo: int, hi: int) -> None:
    """After writes of [lo, hi) in 0x0920-0x09A7 took effect (end of the frame)."""
    if lo < REG_DC_SPEED_START + 2 and hi > REG_DC_SPEED_START:
        # a write resets the system time difference 0x092C and the speed counter diff
        # 0x0932 (datasheet II 0x0930): the loop and its mean start anew
        self._integral = self._diff_ns = 0.0
        mem[REG_DC_DIFF : REG_DC_DIFF + 4] = bytes(4)
        mem[REG_DC_SPEED_DIFF : REG_DC_SPEED_DIFF + 2] = bytes(2)
        _set_rate(self, self._arrival_ns() or 0, 0.0)
    if lo <= REG_DC_ACTIVATION < hi:
        _activate(self, mem)


def _latch(self: DcClock, mem: Memory) -> None:
    t0 = self._arrival_ns(0)
    t1 = self._arrival_ns(1)
    assert t0 is not None
    port0 = self.local_at(t0)
    _U32.pack_into(mem, REG_DC_RECEIVE, port0 & 0xFFFFFFFF)
    _U32.pack_into(mem, REG_DC_RECEIVE + 4, 0 if t1 is None else self.local_at(t1) & 0xFFFFFFFF)
    mem[REG_DC_RECEIVE + 8 : REG_DC_RECEIVE + 16] = bytes(8)
    _U64.pack_into(mem, REG_DC_RECEIVE_PU, port0)


def compare(self: DcClock, mem: Memory, received: int, *, wide: bool = True) -> int:
    """Compare a received system time with the local copy at this frame's arrival; feed the
    time control loop; returns the difference (local copy - received - delay, ns)."""
    host = self._arrival_ns()
    assert host is not None
    delay: int = _U32.unpack_from(mem, REG_DC_DELAY)[0]
    mod = 1 << (64 if wide else 32)
    diff: int = (self.system_time(mem, host) - received - delay) % mod
    if diff >= mod // 2:
        diff -= mod
    depth = mem[REG_DC_DIFF_FILTER] & 0x0F
    self._diff_ns += (diff - self._diff_ns) / (1 << depth)
    mean = round(self._diff_ns)
    magnitude = min(abs(mean), 0x7FFFFFFF)
    _U32.pack_into(mem, REG_DC_DIFF, magnitude | (0x80000000 if mean < 0 else 0))
    _control(self, mem, host, diff)
    return diff


def _control(self: DcClock, mem: Memory, host: float, diff: int) -> None:
    """The PI time control loop (the emulator's law; see the module docstring)."""
    speed_start = max(1, _U32.unpack_from(mem, REG_DC_SPEED_START)[0] & 0x7FFF)
    tau_ns = speed_start * PHASE_NS_PER_SPEED_COUNT
    dt = tau_ns if self._last_compare is None else min(host - self._last_compare, tau_ns)
    self._last_compare = round(host)
    self._integral -= diff * dt / (tau_ns * INTEGRAL_FACTOR * tau_ns)
    self._integral = max(-MAX_CORRECTION, min(MAX_CORRECTION, self._integral))
    correction = max(-MAX_CORRECTION, min(MAX_CORRECTION, self._integral - diff / tau_ns))
    _set_rate(self, host, correction)
    units = max(-0x8000, min(0x7FFF, round(correction / SPEED_DIFF_UNIT)))
    struct.pack_into("<h", mem, REG_DC_SPEED_DIFF, units)


def _set_rate(self: DcClock, host_ns: float, correction: float) -> None:
    """Change the clock's rate from ``host_ns`` on (continuous: no jump)."""
    self._anchor_local = self.local_at(host_ns)
    self._anchor_host = round(host_ns)
    self._rate = (1.0 + self.drift_ppm * 1e-6) * (1.0 + correction)


def _activate(self: DcClock, mem: Memory) -> None:
    self._sync0_status = self._sync1_status = 0
    self._last_pulse = self._sampled_pulse = None
    self._next_sync1 = None
    if mem[REG_DC_ACTIVATION] & 0x03 != 0x03:
        self._next_sync0 = None
        return
    self._next_sync0 = _U64.unpack_from(mem, REG_DC_START_TIME)[0]
