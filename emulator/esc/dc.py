"""Distributed clocks (DC) of one emulated ESC: local clock, latches, drift control, SYNC0/SYNC1.

The ESC datasheet section I chapter 9 ("Distributed Clocks") and section II 2.19-2.22 (registers
0x0900-0x09FF) state what a master sees:

* every ESC has a 64-bit local clock in ns; here it runs at its own rate ``1 + drift_ppm e-6``
  against the host's monotonic clock (a crystal's tolerance, seeded per patch), from a seeded
  start value, so that a master's offset and drift compensation have work to do;
* a BWR or FPWR of 0x0900 (any length; other commands do not latch, datasheet II 0x0900)
  latches, in each ESC, the local time at which the frame's first bit arrived at port 0
  (0x0900) and, after the rest of the line, returned at port 1 (0x0904; ports 2 and 3 are not
  implemented and read 0), and the 64-bit local time at which it reached the processing unit
  (0x0918). The arrival times follow the propagation the
  timing model computes (:class:`emulator.model.params.TimingParams`: one ESC pass
  ``ecat_processing_ps`` plus a cable per hop, the way back ``ecat_forwarding_ps`` plus a cable);
* the local copy of the system time is local time + system time offset (0x0920); a read of
  0x0910 gives it as it was when the frame passed the reference clock (its value at this ESC
  less the system time delay 0x0928), so synchronised ESCs read one time in one frame. A write
  including 0x0910 (the master's ARMW/FRMW of the reference clock's time; 0x0911-0x0917 alone
  do nothing) is no store: the ESC compares the written value plus the delay with its own
  system time at that instant and feeds the difference to its time control loop (4 bytes: a
  32-bit compare); the mean difference is in 0x092C (bit 31 set: the local copy is smaller;
  bits 0-30 the magnitude), filtered over 2^(0x0934 bits 0-3) compares;
* the time control loop slews the local clock's rate (it never jumps). Its law is the
  emulator's own, a proportional-integral controller with a phase time constant of 0x0930
  (speed counter start) x 5 us (20.5 ms for the 0x1000 SOEM writes; a larger value gives a
  smaller bandwidth, as the datasheet says) and critical damping, its correction clamped to
  +-500 ppm; 0x0932 (speed counter diff) shows the correction in units of 0.1 ppm. A write of
  0x0930 resets the loop, 0x0932 and the mean difference 0x092C (datasheet II 0x0930);
* SYNC0/SYNC1: cyclic unit control 0x0980, activation 0x0981 (bit 0 cyclic operation, bit 1
  SYNC0, bit 2 SYNC1), start time 0x0990 (read: the system time of the next SYNC0 pulse),
  SYNC0/SYNC1 cycle times 0x09A0/0x09A4 (0: a single pulse; SYNC1 fires ``0x09A4`` after each
  SYNC0 pulse), activation status 0x0984 (bit 0/1: first SYNC0/SYNC1 pulse pending), SYNC0 and
  SYNC1 status 0x098E/0x098F (bit 0: a pulse since the last read; reading clears it), next
  SYNC1 pulse 0x0998. Pulses are computed when something looks (a register read, a taxel
  sample), never by a timer; their times are 64-bit system times and wrap as such.

Taxel samples at SYNC0: while SYNC0 is active, a skin patch takes the sample its sensor holds at
each SYNC0 pulse; the system time of the pulse at which the sample in the input buffer was
taken is in user RAM 0x0F80-0x0F87 (64 bits, little endian), where the master can read it in
the same frame as the taxels (an FPRD, or a second FMMU mapping those 8 bytes). Without SYNC0
those bytes read 0 and samples are taken when the host publishes them.

Not modelled: latch units (0x09A8-0x09CF read 0), PDI control of the cyclic unit (0x0980
bit 0 = 1 is stored but ECAT still writes), SYNC pulse outputs (their length 0x0982 is loaded
from SII word 2 and read-only), the debug pulse (0x0981 bit 7 reads 0), the start time plausibility check, 32-bit DC.
"""

from __future__ import annotations

import random
import struct
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc.registers import (  # the DC unit's registers, re-exported here
    DC_SYNC0_ACTIVE,
    REG_DC_ACTIVATION,
    REG_DC_ACTIVATION_STATUS,
    REG_DC_CYCLIC_CONTROL,
    REG_DC_DELAY,
    REG_DC_DIFF,
    REG_DC_DIFF_FILTER,
    REG_DC_END,
    REG_DC_NEXT_SYNC1,
    REG_DC_OFFSET,
    REG_DC_PULSE_LENGTH,
    REG_DC_RECEIVE,
    REG_DC_RECEIVE_PU,
    REG_DC_SPEED_DIFF,
    REG_DC_SPEED_FILTER,
    REG_DC_SPEED_START,
    REG_DC_START_TIME,
    REG_DC_SYNC0_CYCLE,
    REG_DC_SYNC0_STATUS,
    REG_DC_SYNC1_CYCLE,
    REG_DC_SYNC1_STATUS,
    REG_DC_SYSTEM_TIME,
    REG_SAMPLE_TIME,
    Memory,
    dc_write_masks,
)
from emulator.model.params import WIRE, TimingParams

__all__ = [
    "DC_FEATURES",
    "DEFAULT_DRIFT_PPM",
    "MAX_CORRECTION",
    "MAX_DRIFT_PPM",
    "REG_DC_ACTIVATION",
    "REG_DC_ACTIVATION_STATUS",
    "REG_DC_CYCLIC_CONTROL",
    "REG_DC_DELAY",
    "REG_DC_DIFF",
    "REG_DC_DIFF_FILTER",
    "REG_DC_NEXT_SYNC1",
    "REG_DC_OFFSET",
    "REG_DC_PULSE_LENGTH",
    "REG_DC_RECEIVE",
    "REG_DC_RECEIVE_PU",
    "REG_DC_SPEED_DIFF",
    "REG_DC_SPEED_FILTER",
    "REG_DC_SPEED_START",
    "REG_DC_START_TIME",
    "REG_DC_SYNC0_CYCLE",
    "REG_DC_SYNC0_STATUS",
    "REG_DC_SYNC1_CYCLE",
    "REG_DC_SYNC1_STATUS",
    "REG_DC_SYSTEM_TIME",
    "REG_SAMPLE_TIME",
    "DcClock",
    "DcTimebase",
    "compare_together",
    "configure_together",
    "dc_write_masks",
    "seed_clocks",
]

DC_FEATURES: Final = 0x000C  # ESC features 0x0008: bit 2 DC available, bit 3 DC width 64 bit

# reset values (datasheet II 2.20): speed counter start 0x1000, filter depths 4 and 12
SPEED_START_RESET: Final = 0x1000
DIFF_FILTER_RESET: Final = 0x04
SPEED_FILTER_RESET: Final = 0x0C
PHASE_NS_PER_SPEED_COUNT: Final = 5_000  # the emulator's loop: tau = 0x0930 x 5 us
INTEGRAL_FACTOR: Final = 4  # tau_i = 4 tau: critical damping of the PI loop
MAX_CORRECTION: Final = 500e-6  # +-500 ppm
MAX_DRIFT_PPM: Final = 200.0  # accepted oscillator drift, within what the loop can correct
DEFAULT_DRIFT_PPM: Final = 25.0  # ET1100 datasheet: 25 MHz crystal, +-25 ppm
SPEED_DIFF_UNIT: Final = 1e-7  # 0x0932 in 0.1 ppm
MASK64: Final = (1 << 64) - 1
_U64 = struct.Struct("<Q")
_U32 = struct.Struct("<I")


@dataclass
class DcTimebase:
    """What every ESC of a line shares: the host time at which the current frame reached the
    first ESC's port 0 (ns), the line's length and the propagation constants."""

    frame_ns: int = 0
    line_length: int = 1
    params: TimingParams = WIRE
    _times_key: tuple[TimingParams, int] | None = field(default=None, repr=False, compare=False)
    _times: dict[int, tuple[int, int | None]] = field(
        default_factory=dict, repr=False, compare=False
    )

    def port_times_ps(self, position: int) -> tuple[int, int | None]:
        """When the frame's first bit arrives at port 0 of ``position`` and returns at its
        port 1 (None for the last ESC), in ps after it reached the first ESC's port 0."""
        key = self._times_key
        if key is None or key[0] is not self.params or key[1] != self.line_length:
            self._times_key, self._times = (self.params, self.line_length), {}  # a new line
        found = self._times.get(position)
        if found is None:  # the rows' formulas at a row of one, once per line and position
            at = np.array([position], np.int64)
            back, there = self.port1_times_ps(at)
            t0 = int(self.port0_times_ps(at)[0])
            found = self._times[position] = (t0, int(back[0]) if there[0] else None)
        return found

    def port0_times_ps(self, positions: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        """The port 0 times of :meth:`port_times_ps` at many positions at once."""
        return positions * _forward_ps(self.params)

    def port1_times_ps(
        self, positions: npt.NDArray[np.int64]
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
        """The port 1 times of :meth:`port_times_ps` at many positions at once, and where
        there is one (not at the last ESC); 0 where there is none."""
        p, last = self.params, self.line_length - 1
        forward, back = _forward_ps(p), p.ecat_forwarding_ps + p.cable_ps  # a pass each way
        there = positions < last
        # the last ESC turns the frame around (one processing pass and its cable back), then
        # each ESC between it and the position forwards it once
        return np.where(there, (last + 1) * forward + (last - 1 - positions) * back, 0), there


def _forward_ps(p: TimingParams) -> int:
    """One pass in processing direction: an ESC and its cable to the next."""
    return p.ecat_processing_ps + p.cable_ps


class DcClock:
    """The DC unit of one ESC; the ESC calls :meth:`refresh` before reads of 0x0900-0x09FF; a
    frame's writes reach its clock at the end of the frame, over the rows of all the ESCs they
    reach: :func:`compare_together` for 0x0900-0x0917, :func:`configure_together` for the
    other registers. ``drift_ppm``: the local oscillator's deviation; ``start_ns``: its value at
    the host time 0."""

    __slots__ = (
        "_anchor_host",
        "_anchor_local",
        "_diff_ns",
        "_integral",
        "_last_compare",
        "_last_pulse",
        "_next_sync0",
        "_next_sync1",
        "_rate",
        "_sampled_pulse",
        "_sync0_status",
        "_sync1_status",
        "drift_ppm",
        "position",
        "timebase",
    )
    _last_compare: int | None  # host time of the last compare
    _next_sync0: int | None
    _next_sync1: int | None
    _last_pulse: int | None  # system time of the last SYNC0 pulse fired
    _sampled_pulse: int | None  # the pulse of the last taxel sample

    def __init__(
        self,
        *,
        drift_ppm: float = 0.0,
        start_ns: int = 0,
        timebase: DcTimebase | None = None,
        position: int = 0,
    ) -> None:
        self.timebase = timebase if timebase is not None else DcTimebase()
        self.position = position
        self.retune(drift_ppm, start_ns)
        self.reset()

    # --- the clock ------------------------------------------------------------------------
    def local_at(self, host_ns: float) -> int:
        """The local time (64 bit) at host time ``host_ns``."""
        elapsed = host_ns - self._anchor_host
        return (self._anchor_local + round(elapsed * self._rate)) & MASK64

    def _arrival_ns(self, port: int = 0) -> float | None:
        t0, t1 = self.timebase.port_times_ps(self.position)
        t = t0 if port == 0 else t1
        return None if t is None else self.timebase.frame_ns + t / 1000

    def system_time(self, mem: Memory, host_ns: float) -> int:
        """The local copy of the system time: local time + offset (0x0920)."""
        offset: int = _U64.unpack_from(mem, REG_DC_OFFSET)[0]
        return (self.local_at(host_ns) + offset) & MASK64

    def retune(self, drift_ppm: float, start_ns: int) -> None:
        """Another oscillator: ``drift_ppm`` from now on, local time ``start_ns`` at host 0."""
        self.drift_ppm = drift_ppm
        self._anchor_host, self._anchor_local = 0, start_ns
        self._rate = 1.0 + drift_ppm * 1e-6

    # --- the ESC's hooks --------------------------------------------------------------------
    def power_on(self, mem: Memory) -> None:
        """Reset values of the DC registers (datasheet II 2.20-2.22) and of the clock's loop
        and pulses: :func:`registers_power_on` of a line of one, and :meth:`reset`."""
        registers_power_on(np.frombuffer(mem, np.uint8).reshape(1, -1), np.zeros(1, np.intp))
        self.reset()

    def reset(self) -> None:
        """The clock's loop and SYNC pulses as at power-on (its oscillator runs on)."""
        self._integral = self._diff_ns = 0.0
        self._last_compare = None
        self._next_sync0 = self._next_sync1 = None
        self._sync0_status = self._sync1_status = 0
        self._last_pulse = self._sampled_pulse = None

    def refresh(self, mem: Memory, lo: int, hi: int) -> None:
        """Bring the registers a read of [lo, hi) sees up to the current frame's time."""
        t = self._arrival_ns()
        assert t is not None
        if lo < REG_DC_RECEIVE_PU and hi > REG_DC_SYSTEM_TIME:
            # the local copy "when the frame passed the reference clock, i.e. including System
            # Time Delay" (datasheet II 0x0910): its time at this ESC less the delay 0x0928
            delay: int = _U32.unpack_from(mem, REG_DC_DELAY)[0]
            _U64.pack_into(mem, REG_DC_SYSTEM_TIME, (self.system_time(mem, t) - delay) & MASK64)
        if lo < REG_DC_END and hi > REG_DC_ACTIVATION_STATUS:
            self._advance(mem, t)
            active = self._next_sync0 is not None or self._last_pulse is not None
            status = 0x01 if active and self._last_pulse is None else 0  # first pulse pending
            if active and mem[REG_DC_ACTIVATION] & 0x04 and self._next_sync1 is None:
                status |= 0x02
            mem[REG_DC_ACTIVATION_STATUS] = status
            mem[REG_DC_SYNC0_STATUS] = self._sync0_status
            mem[REG_DC_SYNC1_STATUS] = self._sync1_status
            if self._next_sync0 is not None:
                _U64.pack_into(mem, REG_DC_START_TIME, self._next_sync0)
            if self._next_sync1 is not None:
                _U64.pack_into(mem, REG_DC_NEXT_SYNC1, self._next_sync1)
            if lo <= REG_DC_SYNC0_STATUS < hi:
                self._sync0_status = 0  # reading clears the status (datasheet II 2.22)
            if lo <= REG_DC_SYNC1_STATUS < hi:
                self._sync1_status = 0

    # --- SYNC0 / SYNC1 ------------------------------------------------------------------------
    def _advance(self, mem: Memory, host_ns: float) -> None:
        """Fire the SYNC0 (and SYNC1) pulses due by ``host_ns``."""
        nxt = self._next_sync0
        if nxt is None:
            return
        now = self.system_time(mem, host_ns)
        if now < nxt:
            return
        cycle = _U32.unpack_from(mem, REG_DC_SYNC0_CYCLE)[0]
        if cycle == 0:  # single shot
            last, self._next_sync0 = nxt, None
        else:
            last = nxt + (now - nxt) // cycle * cycle
            self._next_sync0 = (last + cycle) & MASK64  # 64-bit system time: wraps
        self._last_pulse = last
        self._sync0_status = 1
        if mem[REG_DC_ACTIVATION] & 0x04:
            self._next_sync1 = (last + _U32.unpack_from(mem, REG_DC_SYNC1_CYCLE)[0]) & MASK64
            if now >= self._next_sync1:
                self._sync1_status = 1

    def sample_due(self, mem: Memory) -> int | None:
        """The system time of a SYNC0 pulse that fired since the last sample (the patch then
        takes the sample its sensor holds), else None. Called when the master opens the input
        buffer."""
        if self._next_sync0 is None and self._last_pulse is None:
            return None
        t = self._arrival_ns()
        assert t is not None
        self._advance(mem, t)
        if self._last_pulse is None or self._last_pulse == self._sampled_pulse:
            return None
        self._sampled_pulse = self._last_pulse
        return self._last_pulse


def registers_power_on(memory: npt.NDArray[np.uint8], rows: npt.NDArray[np.intp] | slice) -> None:
    """Reset values of the DC registers (datasheet II 2.20-2.22) at every row: 0 but speed
    counter start 0x1000 and the filter depths 4 and 12; the sample time in user RAM 0."""
    memory[rows, REG_DC_RECEIVE:REG_DC_END] = 0
    memory[rows, REG_DC_SPEED_START] = SPEED_START_RESET & 0xFF
    memory[rows, REG_DC_SPEED_START + 1] = SPEED_START_RESET >> 8
    memory[rows, REG_DC_DIFF_FILTER] = DIFF_FILTER_RESET
    memory[rows, REG_DC_SPEED_FILTER] = SPEED_FILTER_RESET
    memory[rows, REG_SAMPLE_TIME : REG_SAMPLE_TIME + 8] = 0


def seed_clocks(clocks: Sequence[DcClock], max_drift_ppm: float, seed: int) -> None:
    """Give each clock a seeded drift in [-max_drift_ppm, +max_drift_ppm] and a seeded local
    time at power-on (below 2^40 ns, about 18 minutes).

    Raises:
        TopologyError: ``max_drift_ppm`` not a finite number in 0..MAX_DRIFT_PPM.
    """
    if not 0 <= max_drift_ppm <= MAX_DRIFT_PPM:  # also refuses nan
        raise TopologyError(f"clock drift: {max_drift_ppm} ppm (0..{MAX_DRIFT_PPM:g})")
    rng = random.Random(seed)
    for clock in clocks:
        clock.retune(rng.uniform(-max_drift_ppm, max_drift_ppm), rng.randrange(1 << 40))


def compare_together(
    clocks: Sequence[DcClock],
    memory: npt.NDArray[np.uint8],
    rows: npt.NDArray[np.intp],
    lo: int,
    data: bytes | npt.NDArray[np.uint8],
    latching: npt.NDArray[np.bool_] | None = None,
) -> None:
    """A write of ``data`` at ``lo`` (0x0900-0x0917) at every clock, whose ESC's memory is
    ``memory[rows]``, at the end of the frame: the same bytes, or a row of bytes per clock (a
    logical datagram's, each ESC's own frame bytes). A single ESC is a line of one.

    A write of 0x0900 by a BWR or FPWR (``latching``: the clocks whose ESC took one; None: all)
    latches the local times at which the frame passed port 0 and came back to port 1 (0x0900,
    0x0904; 0x0918 the 64-bit port 0 time; datasheet II 0x0900); a write including 0x0910 (a
    master's ARMW/FRMW of the reference clock's time) compares the written value plus the
    system time delay with the local copy at the frame's arrival, modulo 2^64 (2^32 when only
    0x0910-0x0913 are written), filters the difference into 0x092C and feeds the PI loop
    (module docstring), whose correction 0x0932 shows. In float64 over arrays: the difference
    is rounded to float64 first, exact up to 2^53 ns; beyond it the correction is clamped to
    +-500 ppm anyway. Clocks of different lines go line by line. (Each clock's state is read
    attribute by attribute, the latch written as one block, and ``min(max())`` clamps: on the
    compares of three hostile frames at 157-160 clocks, 0.87 of the time reading whole states
    with ``np.clip`` took.) tests/dc_oracle.py holds the clock-by-clock model these
    arrays once were, as a test oracle.
    """
    hi = lo + (len(data) if isinstance(data, bytes) else data.shape[1])
    if not clocks:
        return
    timebase = clocks[0].timebase  # equal timebases give the same times
    if not all(c.timebase is timebase or c.timebase == timebase for c in clocks):
        for group in _by_timebase(clocks):  # (clocks of several lines: each line's own times)
            part = data if isinstance(data, bytes) else data[group]
            mine = None if latching is None else latching[group]
            compare_together([clocks[k] for k in group], memory, rows[group], lo, part, mine)
        return
    latch = lo < REG_DC_RECEIVE + 4 and hi > REG_DC_RECEIVE
    compare = lo <= REG_DC_SYSTEM_TIME < hi  # a compare needs 0x0910 itself (II 0x0910)
    if not (latch or compare):
        return  # 0x0904-0x090F: nothing happens
    count = len(clocks)
    positions = np.fromiter([c.position for c in clocks], np.int64, count)
    anchors = (
        np.fromiter([c._anchor_host for c in clocks], np.int64, count),
        np.array([c._anchor_local for c in clocks], np.uint64),
        np.fromiter([c._rate for c in clocks], np.float64, count),
    )
    host = timebase.frame_ns + timebase.port0_times_ps(positions) / 1000  # _arrival_ns
    local = _local_at(host, *anchors)
    if latch:  # the local times the frame passed port 0 and came back to port 1
        back_ps, back = timebase.port1_times_ps(positions)
        port1 = np.where(back, _local_at(timebase.frame_ns + back_ps / 1000, *anchors), 0)
        latched = np.zeros((count, 4), "<u4")  # 0x0900, 0x0904, ports 2 and 3: 0
        latched[:, 0], latched[:, 1] = local, port1  # (modulo 2^32)
        at = rows if latching is None else rows[latching]
        which = slice(None) if latching is None else latching
        memory[at, REG_DC_RECEIVE : REG_DC_RECEIVE + 16] = latched[which].view(np.uint8)
        memory[at, REG_DC_RECEIVE_PU : REG_DC_RECEIVE_PU + 8] = (
            local[which].astype("<u8").view(np.uint8).reshape(-1, 8)
        )
        if not compare:
            return
    system = local + _u64(memory, rows, REG_DC_OFFSET)
    a, b = max(lo, REG_DC_SYSTEM_TIME), min(hi, REG_DC_RECEIVE_PU)
    received = system.astype("<u8").view(np.uint8).reshape(count, 8)
    received[:, a - REG_DC_SYSTEM_TIME : b - REG_DC_SYSTEM_TIME] = (
        np.frombuffer(data, np.uint8, b - a, a - lo)
        if isinstance(data, bytes)
        else data[:, a - lo : b - lo]
    )
    raw = system - received.view("<u8").ravel() - _u32(memory, rows, REG_DC_DELAY)
    if b - REG_DC_SYSTEM_TIME > 4:  # the difference modulo 2^64 or 2^32
        diff = raw.view(np.int64)
    else:
        diff = (raw & 0xFFFFFFFF).astype(np.int64)
        diff[diff >= 1 << 31] -= 1 << 32
    d = diff.astype(np.float64)
    depth = (memory[rows, REG_DC_DIFF_FILTER] & 0x0F).astype(np.int64)
    mean_ns = np.fromiter([c._diff_ns for c in clocks], np.float64, count)
    mean_ns += (d - mean_ns) / (1 << depth).astype(np.float64)
    mean = np.rint(mean_ns)
    magnitude = np.minimum(np.abs(mean), 0x7FFFFFFF).astype(np.uint32)
    magnitude[mean < 0] |= 0x80000000
    _put(memory, rows, REG_DC_DIFF, magnitude)
    # the loop: dt is the time since the last compare, as a float, unless that is no
    # compare or more than tau: then tau, an int, and diff * tau / (4 tau^2) is diff / (4 tau)
    # rounded once (Python's int division), as float64 divides two exact operands
    speed = memory[rows, REG_DC_SPEED_START : REG_DC_SPEED_START + 2].copy().view("<u2")
    tau = np.maximum(1, speed.ravel().astype(np.int64) & 0x7FFF) * PHASE_NS_PER_SPEED_COUNT
    last = [c._last_compare for c in clocks]
    never = np.fromiter([t is None for t in last], np.bool_, count)
    gap = host - np.fromiter([0 if t is None else t for t in last], np.int64, count)
    step = d * gap / (tau * INTEGRAL_FACTOR * tau).astype(np.float64)
    whole = never | (tau < gap)
    step[whole] = d[whole] / (INTEGRAL_FACTOR * tau[whole]).astype(np.float64)
    held = np.fromiter([c._integral for c in clocks], np.float64, count) - step
    held = np.minimum(np.maximum(held, -MAX_CORRECTION), MAX_CORRECTION)
    correction = held - d / tau.astype(np.float64)
    correction = np.minimum(np.maximum(correction, -MAX_CORRECTION), MAX_CORRECTION)
    compared_at = np.rint(host).astype(np.int64)
    drift = np.fromiter([c.drift_ppm for c in clocks], np.float64, count)
    new_rate = (1.0 + drift * 1e-6) * (1.0 + correction)
    units = np.rint(correction / SPEED_DIFF_UNIT)
    units = np.minimum(np.maximum(units, -0x8000), 0x7FFF).astype("<i2")
    memory[rows, REG_DC_SPEED_DIFF : REG_DC_SPEED_DIFF + 2] = units.view(np.uint8).reshape(-1, 2)
    for clock, at_local, at_host, new, held_i, mean_i in zip(
        clocks,
        local.tolist(),
        compared_at.tolist(),
        new_rate.tolist(),
        held.tolist(),
        mean_ns.tolist(),
        strict=True,
    ):  # the new rate from the compare on (no jump), and the loop's state
        clock._anchor_local, clock._anchor_host, clock._rate = at_local, at_host, new
        clock._integral, clock._diff_ns, clock._last_compare = held_i, mean_i, at_host


def configure_together(
    clocks: Sequence[DcClock],
    memory: npt.NDArray[np.uint8],
    rows: npt.NDArray[np.intp],
    lo: int,
    hi: int,
) -> None:
    """What writes of [lo, hi) (0x0920-0x09A7) do at every clock, whose ESC's memory is
    ``memory[rows]``, once they took effect at the end of a frame: a write of the speed counter
    start 0x0930 resets the loop, 0x092C and 0x0932 and sets the rate anew at the frame's
    arrival (datasheet II 0x0930); a write of the activation register 0x0981 (de)activates
    SYNC0 from the start time 0x0990, clearing the pulse states. A single ESC is a line of
    one; clocks of different lines go line by line."""
    speed = lo < REG_DC_SPEED_START + 2 and hi > REG_DC_SPEED_START
    activation = lo <= REG_DC_ACTIVATION < hi
    if not (speed or activation) or not clocks:
        return
    timebase = clocks[0].timebase
    if any(clock.timebase is not timebase for clock in clocks):
        for group in _by_timebase(clocks):  # (clocks of several lines: each line's own times)
            configure_together([clocks[k] for k in group], memory, rows[group], lo, hi)
        return
    if speed:  # the rate anew from the arrival on (no jump), the loop and its mean reset
        memory[rows, REG_DC_DIFF : REG_DC_DIFF + 4] = 0
        memory[rows, REG_DC_SPEED_DIFF : REG_DC_SPEED_DIFF + 2] = 0
        state = [(c.position, c._anchor_host, c._anchor_local, c._rate) for c in clocks]
        position, anchor_host, anchor_local, rate = zip(*state, strict=True)
        host = timebase.frame_ns + timebase.port0_times_ps(np.array(position, np.int64)) / 1000
        local = _local_at(
            host,
            np.array(anchor_host, np.int64),
            np.array(anchor_local, np.uint64),
            np.array(rate),
        )
        for clock, at_local, at_host in zip(
            clocks, local.tolist(), np.rint(host).astype(np.int64).tolist(), strict=True
        ):
            clock._integral = clock._diff_ns = 0.0
            clock._anchor_local, clock._anchor_host = at_local, at_host
            clock._rate = 1.0 + clock.drift_ppm * 1e-6  # (times 1 + a correction of 0)
    if activation:  # SYNC0 from the start time, or off; no pulse yet
        active = ((memory[rows, REG_DC_ACTIVATION] & DC_SYNC0_ACTIVE) == DC_SYNC0_ACTIVE).tolist()
        starts = _u64(memory, rows, REG_DC_START_TIME).tolist()
        for clock, on, start in zip(clocks, active, starts, strict=True):
            clock._sync0_status = clock._sync1_status = 0
            clock._last_pulse = clock._sampled_pulse = clock._next_sync1 = None
            clock._next_sync0 = start if on else None


def _by_timebase(clocks: Sequence[DcClock]) -> list[list[int]]:
    """The indices of ``clocks`` grouped by their timebase (equal ones together)."""
    groups: list[tuple[DcTimebase, list[int]]] = []
    for k, clock in enumerate(clocks):
        for timebase, members in groups:
            if clock.timebase is timebase or clock.timebase == timebase:
                members.append(k)
                break
        else:
            groups.append((clock.timebase, [k]))
    return [members for _, members in groups]


def _local_at(
    host_ns: npt.NDArray[np.float64],
    anchor_host: npt.NDArray[np.int64],
    anchor_local: npt.NDArray[np.uint64],
    rate: npt.NDArray[np.float64],
) -> npt.NDArray[np.uint64]:
    """:meth:`DcClock.local_at` of many clocks (modulo 2^64 as the uint64 sum wraps)."""
    elapsed = host_ns - anchor_host
    return anchor_local + np.rint(elapsed * rate).astype(np.int64).astype(np.uint64)


def _u64(
    memory: npt.NDArray[np.uint8], rows: npt.NDArray[np.intp], at: int
) -> npt.NDArray[np.uint64]:
    return np.ascontiguousarray(memory[rows, at : at + 8]).view("<u8").ravel().astype(np.uint64)


def _u32(
    memory: npt.NDArray[np.uint8], rows: npt.NDArray[np.intp], at: int
) -> npt.NDArray[np.uint64]:
    return np.ascontiguousarray(memory[rows, at : at + 4]).view("<u4").ravel().astype(np.uint64)


def _put(
    memory: npt.NDArray[np.uint8],
    rows: npt.NDArray[np.intp],
    at: int,
    values: npt.NDArray[np.uint32],
) -> None:
    memory[rows, at : at + 4] = values.astype("<u4").view(np.uint8).reshape(-1, 4)
