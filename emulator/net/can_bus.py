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
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import ScheduleError, TopologyError
from emulator.model.units import PS_PER_NS, PS_PER_S
from skinframes import canbus
from skinframes.canbus.wire import CanFrame

__all__ = ["BusFrame", "CanArbiter", "CanSchedule", "arbitrate", "bit_time_ps", "skin_bus"]

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
    bus = CanArbiter(bitrate_bps)
    start = np.zeros(len(frames), dtype=np.int64)
    end = np.zeros(len(frames), dtype=np.int64)
    order = sorted(range(len(frames)), key=lambda i: (frames[i].release_ps, i))
    bus.offer((frames[i], i) for i in order)
    for _, i, t0, t1 in bus.run():
        start[i], end[i] = t0, t1
    return CanSchedule(tuple(frames), start, end, bus.bit_ps)


class CanArbiter:
    """:func:`arbitrate` for frames offered batch by batch, in order of release time.

    :meth:`run` schedules the frames as far as those offered decide: a frame offered later is
    released no earlier than ``until_ps``, so every choice the bus makes before then is final.
    Memory is that of the frames offered and not yet through, however long the log.
    """

    def __init__(self, bitrate_bps: int = DEFAULT_BITRATE_BPS) -> None:
        self.bit_ps = bit_time_ps(bitrate_bps)
        self._queues: dict[int, deque[tuple[BusFrame, int]]] = {}  # per node: its FIFO
        self._free: dict[int, int] = {}  # per node: when its last frame left the bus
        self._waiting: list[tuple[int, int]] = []  # (release, node) of unreleased queue heads
        self._ready: list[tuple[int, int, int]] = []  # (can_id, node, seq) of released heads
        self._t = 0  # bus time: the bus is idle from here
        self._released = 0  # the latest release offered

    def offer(self, frames: Iterable[tuple[BusFrame, int]]) -> None:
        """Queue ``(frame, tag)`` pairs, in order of release (ties: in the order given)."""
        for frame, tag in frames:
            if frame.release_ps < self._released:
                raise ScheduleError(
                    f"CAN: a frame released at {frame.release_ps} ps offered after one "
                    f"released at {self._released} ps"
                )
            self._released = frame.release_ps
            q = self._queues.setdefault(frame.node, deque())
            q.append((frame, tag))
            if len(q) == 1:  # the node's new head: it competes once released and its FIFO free
                heapq.heappush(
                    self._waiting,
                    (max(frame.release_ps, self._free.get(frame.node, 0)), frame.node),
                )

    def run(self, until_ps: int | None = None) -> list[tuple[BusFrame, int, int, int]]:
        """Schedule the frames whose turn comes before ``until_ps`` (None: all of them):
        ``(frame, tag, start_ps, end_ps)`` in the order they take the bus."""
        waiting, ready, queues = self._waiting, self._ready, self._queues
        out: list[tuple[BusFrame, int, int, int]] = []
        t = self._t
        while waiting or ready:
            if until_ps is not None and t >= until_ps:
                break
            while waiting and waiting[0][0] <= t:
                _, node = heapq.heappop(waiting)
                frame = queues[node][0][0]
                heapq.heappush(ready, (frame.can_id, node, queues[node][0][1]))
            if not ready:
                if until_ps is not None and waiting[0][0] >= until_ps:
                    break
                t = waiting[0][0]
                continue
            can_id, node, _ = heapq.heappop(ready)
            if ready and ready[0][0] == can_id:
                raise ScheduleError(f"CAN: nodes {node} and {ready[0][1]} both send id {can_id:#x}")
            q = queues[node]
            frame, tag = q.popleft()
            out.append((frame, tag, t, t + frame.bits * self.bit_ps))
            t += frame.bits * self.bit_ps
            self._free[node] = t
            if q:
                heapq.heappush(waiting, (max(q[0][0].release_ps, t), node))
        self._t = t
        return out


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
