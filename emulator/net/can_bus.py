"""The legacy skin CAN bus: boards queue their frames, identifiers arbitrate, bits take time.

ISO 11898-1 arbitration: whenever the bus is idle (after a frame's 3-bit intermission), every node
offers the frame at the head of its transmit queue and the lowest identifier wins; the others
retry after it. A node sends its own frames in order (one FIFO per board: the head frame of a
triangle before its tail, triangles 0..15), so a board's next frame competes only once its
previous one is on the wire. Frame lengths are the exact bit counts of ``skinframes.canbus``
(stuff bits and intermission included), so the timeline is exact to the bit.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import ScheduleError, TopologyError
from emulator.model.units import PS_PER_NS, PS_PER_S
from skinframes import canbus
from skinframes.canbus.wire import CanFrame

__all__ = ["BusFrame", "CanSchedule", "arbitrate", "bit_time_ps", "skin_bus"]

DEFAULT_BITRATE_BPS: Final = 1_000_000  # the skin bus (can.md 1.5)


def bit_time_ps(bitrate_bps: int = DEFAULT_BITRATE_BPS) -> int:
    """One bit in ps (1_000_000 at 1 Mbit/s)."""
    if bitrate_bps <= 0 or PS_PER_S % bitrate_bps:
        raise TopologyError(f"CAN: {bitrate_bps} bit/s is not a whole number of ps per bit")
    return PS_PER_S // bitrate_bps


@dataclass(frozen=True, slots=True)
class BusFrame:
    """A frame a node wants to send.

    Attributes:
        release_ps: when the node queues it.
        node: the sending board (its FIFO).
        can_id: the arbitration identifier (lower wins).
        bits: its length on the wire, stuff bits and 3-bit intermission included.
    """

    release_ps: int
    node: int
    can_id: int
    bits: int


@dataclass(frozen=True)
class CanSchedule:
    """When each frame held the bus: ``start_ps[i]``, ``end_ps[i]`` for ``frames[i]``."""

    frames: tuple[BusFrame, ...]
    start_ps: npt.NDArray[np.int64]
    end_ps: npt.NDArray[np.int64]
    bit_ps: int

    def busy_ps(self, lo: int, hi: int) -> int:
        """Bus time occupied by frames within [lo, hi)."""
        s = np.clip(self.start_ps, lo, hi)
        e = np.clip(self.end_ps, lo, hi)
        return int((e - s).sum())

    def load(self, lo: int, hi: int) -> float:
        """Fraction of [lo, hi) the bus was busy."""
        return self.busy_ps(lo, hi) / (hi - lo)


def arbitrate(frames: list[BusFrame], bitrate_bps: int = DEFAULT_BITRATE_BPS) -> CanSchedule:
    """Run the bus: non-preemptive, lowest identifier first among the nodes' queue heads.

    Raises:
        ScheduleError: two nodes offer the same identifier at once (a real bus would see a
            bit error in the data field; skin ids are unique per board).
    """
    bit = bit_time_ps(bitrate_bps)
    if not frames:
        empty = np.zeros(0, dtype=np.int64)
        return CanSchedule((), empty, empty, bit)
    queues: dict[int, list[int]] = {}
    for i in sorted(range(len(frames)), key=lambda i: (frames[i].release_ps, i)):
        queues.setdefault(frames[i].node, []).append(i)
    heads = dict.fromkeys(queues, 0)
    start = np.zeros(len(frames), dtype=np.int64)
    end = np.zeros(len(frames), dtype=np.int64)
    # candidates: (can_id, node, index) of queue heads already released
    ready: list[tuple[int, int, int]] = []
    waiting: list[tuple[int, int]] = []  # (release, node) of queue heads not yet released
    for node, q in queues.items():
        heapq.heappush(waiting, (frames[q[0]].release_ps, node))
    t = 0
    done = 0
    while done < len(frames):
        while waiting and waiting[0][0] <= t:
            _, node = heapq.heappop(waiting)
            i = queues[node][heads[node]]
            heapq.heappush(ready, (frames[i].can_id, node, i))
        if not ready:
            t = waiting[0][0]
            continue
        can_id, node, i = heapq.heappop(ready)
        if ready and ready[0][0] == can_id:
            raise ScheduleError(f"CAN: nodes {node} and {ready[0][1]} both send id {can_id:#x}")
        start[i] = t
        t += frames[i].bits * bit
        end[i] = t
        done += 1
        heads[node] += 1
        if heads[node] < len(queues[node]):
            nxt = queues[node][heads[node]]
            heapq.heappush(waiting, (max(frames[nxt].release_ps, t), node))
    return CanSchedule(tuple(frames), start, end, bit)


def skin_bus(
    boards: list[int],
    taxels: npt.NDArray[np.uint8],
    period_ps: int,
    *,
    skin_class: int = 4,
    bitrate_bps: int = DEFAULT_BITRATE_BPS,
) -> tuple[list[CanFrame], CanSchedule]:
    """The legacy skin bus at work: each board queues its 2T frames at every period start.

    Args:
        boards: board addresses (1..14) on the bus.
        taxels: (samples, len(boards), T, 12) uint8 taxel values.
        period_ps: the boards' transmit period (50 ms by default in the firmware).

    Returns:
        The frames as a trace would record them (timestamp = start of the frame on the bus, in
        time order) and the bus schedule.
    """
    arr = np.asarray(taxels)
    if arr.ndim != 4 or arr.shape[1] != len(boards):
        raise TopologyError(f"taxels: shape {arr.shape}, expected (samples, {len(boards)}, T, 12)")
    payloads: list[tuple[int, bytes]] = []
    bus: list[BusFrame] = []
    for k in range(arr.shape[0]):
        for i, board in enumerate(boards):
            for ident, data in canbus.encode_board(board, arr[k, i], skin_class=skin_class):
                payloads.append((ident, data))
                bus.append(BusFrame(k * period_ps, board, ident, CanFrame(ident, data).bits()))
    sched = arbitrate(bus, bitrate_bps)
    frames = [
        CanFrame(ident, data, time_ns=int(t) // PS_PER_NS)
        for (ident, data), t in zip(payloads, sched.start_ps, strict=True)
    ]
    order = np.argsort(sched.start_ps, kind="stable")
    return [frames[i] for i in order], sched
