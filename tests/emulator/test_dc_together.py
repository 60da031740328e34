"""The system time compare over arrays (:func:`emulator.esc.dc.compare_together`) leaves every
clock and its registers as the clock-by-clock oracle (tests/dc_oracle.py) does: the same bytes, the same
floats and ints, the same types, over random clock states, partial and 32-bit writes,
differences beyond float64's exact integers (2^53 ns, where the arrays round the difference
and Python does not), first compares and long gaps; and the receive time latch (0x0900) alone
and together with a compare, at every position of the line (the last one has no port 1 time)."""

from __future__ import annotations

import copy
import random
import struct

import dc_oracle
import numpy as np
import pytest

from emulator.esc import dc
from emulator.esc.dc import DcClock, DcTimebase, compare_together, configure_together

CLOCKS = 12
EXACT = 1 << 53  # integers up to this magnitude are exact as float64
SLOTS = [s for s in DcClock.__slots__ if s not in ("timebase", "position")]
WRITES = (  # (address, length): the master's ARMW/FRMW and hostile neighbours
    (0x0910, 8), (0x0910, 4), (0x0912, 2), (0x0914, 4), (0x0916, 4), (0x090C, 8),
    (0x0911, 1), (0x0904, 4), (0x0908, 16), (0x0900, 4), (0x0918, 8), (0x0900, 24),
)  # fmt: skip


def line(rng: random.Random) -> tuple[list[DcClock], np.ndarray]:
    """``CLOCKS`` clocks on one timebase, with seeded drifts, starts and DC registers; most of
    them synchronized (offsets and delays as a master sets them, within a few us of one system
    time), so that compares feed their control loops differences too small to be clamped."""
    base = rng.randrange(1 << 64)
    timebase = DcTimebase(frame_ns=rng.randrange(1 << 40), line_length=CLOCKS)
    clocks = [DcClock(timebase=timebase, position=p) for p in range(CLOCKS)]
    memory = np.zeros((CLOCKS, 0x1000), np.uint8)
    for p, clock in enumerate(clocks):
        clock.retune(rng.uniform(-200, 200), rng.randrange(1 << 64))
        row = memoryview(memory[p])
        clock.power_on(row)
        synchronized = rng.random() < 0.8
        local = clock.local_at(timebase.frame_ns)
        offset = (
            base - local + rng.randrange(-5000, 5000) if synchronized else rng.randrange(1 << 64)
        )
        struct.pack_into("<Q", row, dc.REG_DC_OFFSET, offset & dc.MASK64)
        delay = rng.randrange(2000) if synchronized else rng.randrange(1 << 32)
        struct.pack_into("<I", row, dc.REG_DC_DELAY, delay)
        row[dc.REG_DC_DIFF_FILTER] = rng.randrange(256)
        row[dc.REG_DC_RECEIVE : dc.REG_DC_RECEIVE + 32] = rng.randbytes(32)  # latched before
        speed = rng.choice((0, 1, 0x1000, 0x1000, 0x8000, rng.randrange(1 << 16)))
        struct.pack_into("<H", row, dc.REG_DC_SPEED_START, speed)
    return clocks, memory


def written(rng: random.Random, clocks: list[DcClock], memory: np.ndarray) -> bytes:
    """What a master writes: near the first clock's system time (small differences), anywhere
    (huge ones), or a difference right at float64's limit of exact integers."""
    host = clocks[0].timebase.frame_ns
    now = clocks[0].system_time(memoryview(memory[0]), host)
    kind = rng.randrange(4)
    if kind < 2:
        value = now + rng.randrange(-20_000, 20_000)
    elif kind == 2:
        value = rng.randrange(1 << 64)
    else:
        value = now - EXACT + rng.randrange(-2, 3)
    return struct.pack("<QQ", value & dc.MASK64, rng.randrange(1 << 64))


def state(clocks: list[DcClock], memory: np.ndarray) -> list[object]:
    slots = [(s, getattr(c, s), type(getattr(c, s))) for c in clocks for s in SLOTS]
    return [memory.tobytes(), *slots]


@pytest.mark.parametrize("seed", range(6))
def test_compare_together_equals_clock_by_clock(seed: int) -> None:
    rng = random.Random(seed)
    clocks, memory = line(rng)
    rows = np.arange(CLOCKS, dtype=np.intp)
    for step in range(300):
        ones, mem_ones = copy.deepcopy((clocks, memory))
        lo, n = rng.choice(WRITES)
        before = rng.randbytes(max(0, dc.REG_DC_SYSTEM_TIME - lo))  # latch, ports 1-3
        data = (before + written(rng, clocks, memory))[:n]
        together = rng.sample(range(CLOCKS), rng.randint(1, CLOCKS))  # a group of the line
        for p in together:
            dc_oracle.write(ones[p], memoryview(mem_ones[p]), lo, data)
        compare_together([clocks[p] for p in together], memory, rows[together], lo, data)
        assert state(clocks, memory) == state(ones, mem_ones), (seed, step, hex(lo), n)
        # the next frame: the same instant, a cycle later, exactly the first clock's tau later
        # (the last compare's gap, a float, equals tau, an int: Python takes the float), or
        # after more than tau
        speed = max(1, struct.unpack_from("<H", memory[0], dc.REG_DC_SPEED_START)[0] & 0x7FFF)
        tau_ns = speed * dc.PHASE_NS_PER_SPEED_COUNT
        advance = rng.choice((0, 1_000_000, tau_ns, rng.randrange(1 << 30), 1 << 40))
        clocks[0].timebase.frame_ns += advance


CONFIGURED = (  # [lo, hi) of register writes that took effect: speed start, activation, both
    (0x0930, 0x0932), (0x0931, 0x0932), (0x092F, 0x0930), (0x0981, 0x0982), (0x0980, 0x0990),
    (0x0990, 0x09A8), (0x0920, 0x09A8), (0x0930, 0x0982),
)  # fmt: skip


@pytest.mark.parametrize("seed", range(4))
def test_configure_together_equals_clock_by_clock(seed: int) -> None:
    """:func:`configure_together` leaves every clock and its registers as
    :func:`dc_oracle.configured` does clock by clock: after writes of the speed counter start, of
    the activation register (SYNC0 on or off, from random start times) or of both, at random
    groups of the line, with compares and time passing in between; and clocks on different
    timebases go line by line."""
    rng = random.Random(seed)
    clocks, memory = line(rng)
    rows = np.arange(CLOCKS, dtype=np.intp)
    for step in range(200):
        for p, clock in enumerate(clocks):  # SYNC0 as a master may have left it
            memory[p, dc.REG_DC_ACTIVATION] = rng.choice((0, 3, 7, rng.randrange(256)))
            memory[p, dc.REG_DC_START_TIME : dc.REG_DC_START_TIME + 8] = list(rng.randbytes(8))
            clock._last_pulse, clock._sampled_pulse = rng.randrange(1 << 40), rng.randrange(1 << 40)
            clock._sync0_status = clock._sync1_status = 1
        ones, mem_ones = copy.deepcopy((clocks, memory))
        lo, hi = rng.choice(CONFIGURED)
        together = rng.sample(range(CLOCKS), rng.randint(1, CLOCKS))
        for p in together:
            dc_oracle.configured(ones[p], memoryview(mem_ones[p]), lo, hi)
        configure_together([clocks[p] for p in together], memory, rows[together], lo, hi)
        assert state(clocks, memory) == state(ones, mem_ones), (seed, step, hex(lo), hex(hi))
        compare_together(clocks, memory, rows, 0x0910, written(rng, clocks, memory))
        clocks[0].timebase.frame_ns += rng.choice((0, 1_000_000, rng.randrange(1 << 30)))
    apart = [DcClock(timebase=DcTimebase(frame_ns=5_000 * p), position=p) for p in range(3)]
    ones = copy.deepcopy(apart)
    for clock, mine in zip(apart, ones, strict=True):
        clock.retune(10.0, 1 << 30)
        mine.retune(10.0, 1 << 30)
    mem_ones = memory[:3].copy()
    for p, mine in enumerate(ones):
        dc_oracle.configured(mine, memoryview(mem_ones[p]), 0x0930, 0x0982)
    configure_together(apart, memory, rows[:3], 0x0930, 0x0982)
    assert state(apart, memory[:3]) == state(ones, mem_ones)
