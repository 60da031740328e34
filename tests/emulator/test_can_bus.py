"""CAN arbitration, worked by hand."""

from __future__ import annotations

import pytest

from emulator.errors import ScheduleError
from emulator.net.can_bus import BusFrame, CanArbiter, arbitrate, bit_time_ps


def test_lowest_identifier_wins_and_bits_take_time() -> None:
    frames = [
        BusFrame(0, node=2, can_id=0x420, bits=100),
        BusFrame(0, node=1, can_id=0x410, bits=120),
        BusFrame(0, node=1, can_id=0x411, bits=110),
    ]
    s = arbitrate(frames)  # 1 Mbit/s: 1 us per bit
    # node 1 wins twice (0x410 < 0x411 < 0x420), then node 2
    assert s.start_ps.tolist() == [230_000_000, 0, 120_000_000]
    assert s.end_ps.tolist() == [330_000_000, 120_000_000, 230_000_000]
    assert s.busy_ps(0, 330_000_000) == 330_000_000
    assert s.load(0, 660_000_000) == pytest.approx(0.5)


def test_a_node_sends_its_queue_in_order_even_against_lower_ids() -> None:
    # node 1 queues 0x500 then 0x100: 0x100 cannot overtake its own queue head
    frames = [BusFrame(0, 1, 0x500, 50), BusFrame(0, 1, 0x100, 50), BusFrame(0, 2, 0x300, 50)]
    s = arbitrate(frames)
    assert s.start_ps.tolist() == [50_000_000, 100_000_000, 0]


def test_idle_bus_waits_for_release() -> None:
    s = arbitrate([BusFrame(1_000_000_000, 1, 0x10, 47), BusFrame(0, 2, 0x20, 47)])
    assert s.start_ps.tolist() == [1_000_000_000, 0]


def test_same_identifier_from_two_nodes_is_an_error() -> None:
    with pytest.raises(ScheduleError):
        arbitrate([BusFrame(0, 1, 0x410, 100), BusFrame(0, 2, 0x410, 100)])


def test_bit_time() -> None:
    assert bit_time_ps(1_000_000) == 1_000_000
    assert bit_time_ps(500_000) == 2_000_000


def test_the_arbiter_fed_period_by_period_keeps_a_backlog_across_periods() -> None:
    """By hand, 1 us per bit: node 1 queues three 100-bit frames (0x10) at 0; node 2 one
    (0x05, it would win) at 150 us. Frames 1 and 2 take the bus at 0 and 100 us (node 2 is not
    there yet); at 200 us node 2 beats node 1's third frame."""
    us = 1_000_000
    bus = CanArbiter()
    bus.offer((BusFrame(0, 1, 0x10, 100), i) for i in range(3))
    first = bus.run(until_ps=150 * us)  # frame 3's turn comes at 200 us: not decided yet
    assert [(tag, t0, t1) for _, tag, t0, t1 in first] == [
        (0, 0, 100 * us),
        (1, 100 * us, 200 * us),
    ]
    bus.offer([(BusFrame(150 * us, 2, 0x05, 100), 3)])
    rest = bus.run()
    assert [(tag, t0, t1) for _, tag, t0, t1 in rest] == [
        (3, 200 * us, 300 * us),
        (2, 300 * us, 400 * us),
    ]
    with pytest.raises(ScheduleError, match="offered after"):
        bus.offer([(BusFrame(100 * us, 1, 0x10, 100), 4)])


def test_an_idle_bus_waits_for_the_next_period_without_deciding_it() -> None:
    us = 1_000_000
    bus = CanArbiter()
    bus.offer([(BusFrame(0, 1, 0x20, 50), 0)])
    assert [t0 for _, _, t0, _ in bus.run(until_ps=100 * us)] == [0]
    assert bus.run(until_ps=100 * us) == []  # nothing offered at or after 100 us yet
    bus.offer([(BusFrame(100 * us, 2, 0x30, 50), 1), (BusFrame(100 * us, 1, 0x20, 50), 2)])
    assert [(tag, t0) for _, tag, t0, _ in bus.run()] == [(2, 100 * us), (1, 150 * us)]
