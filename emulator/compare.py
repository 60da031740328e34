"""The same taxels on the legacy CAN bus, on EPL and on EtherCAT, side by side.

A skin CAN log gives boards, triangles, samples and their period. Per sample:

* CAN as recorded: the exact wire time of the sample's frames (``skinframes.canwire``: stuff bits
  and intermission included) on the 1 Mbit/s bus, back to back;
* CAN re-emulated: every board queues its frames at the start of the period and the bus
  arbitrates them (:mod:`emulator.net.can_bus`); the time until the last frame is through;
* EPL and EtherCAT: the emulated cycle that carries the same samples, one node per board.

``bus_load`` is the share of the sample period the bus is busy moving the skin's data;
``wire_bytes_per_sample`` counts what travels on the wire (CAN: bits / 8; Ethernet: preamble,
padded frame and FCS of every frame the master's port sends or receives once, IFG excluded).
"""

from __future__ import annotations

import array
from collections.abc import Callable
from typing import Any, Final

import numpy as np

from emulator.model.limits import MAX_EMULATED_SLAVES
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_US
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.can_bus import BusFrame, CanArbiter, bit_time_ps
from emulator.net.result import SimResult
from emulator.net.sweep import ecat_cycle_ps, epl_cycle_ps
from emulator.skin_samples import LeftOut, SkinLog, SkinSamples, read_skin_samples, samples_of
from skinframes import canbus, powerlink, taxel

__all__ = [
    "LeftOut",
    "SkinLog",
    "SkinSamples",
    "compare",
    "read_skin_samples",
    "samples_of",
]

BUDGETS_US: Final = (1_000, 5_000)  # the reactive loops the comparison asks about
MAX_EMULATED_SAMPLES: Final = 20  # cycles emulated per Ethernet bus (the cycle repeats exactly)


class _BusTimes:
    """What the re-emulated bus did, kept as the frames go through (:class:`CanArbiter`):
    per cycle, when its last frame was through; per board and cycle, when the board's last
    frame of the cycle was; and the bus time the frames occupied before ``horizon_ps``."""

    def __init__(self, cycles: int, period_ps: int, horizon_ps: int) -> None:
        self.period_ps, self.horizon_ps = period_ps, horizon_ps
        self.last_ps = np.zeros(cycles, np.int64)  # per cycle: its last frame's end
        self.busy_ps = 0
        self._board: dict[int, tuple[int, int]] = {}  # per board: (cycle, end) of its latest
        self._latency: dict[int, array.array[int]] = {}  # per board: last end - cycle start

    def add(self, done: list[tuple[BusFrame, int, int, int]]) -> None:
        """Frames through the bus: (frame, cycle, start_ps, end_ps), in bus order."""
        last, horizon, latest = self.last_ps, self.horizon_ps, self._board
        for frame, k, start, end in done:
            last[k] = max(last[k], end)
            self.busy_ps += min(end, horizon) - min(start, horizon)
            before = latest.get(frame.node)
            if before is not None and before[0] != k:  # a board's frames go in order (FIFO)
                self._close(frame.node, *before)
            latest[frame.node] = (k, end)

    def _close(self, board: int, k: int, end: int) -> None:
        self._latency.setdefault(board, array.array("q")).append(end - k * self.period_ps)

    def close(self) -> None:
        """The bus is through: each board's latest cycle is complete."""
        for board, latest in self._board.items():
            self._close(board, *latest)
        self._board.clear()

    def cycle_us(self) -> float:
        """The median time from a period's start until its last frame is through."""
        since = self.last_ps - np.arange(len(self.last_ps), dtype=np.int64) * self.period_ps
        return float(np.median(since)) / PS_PER_US

    def latency_us(self, board: int) -> float:
        """The median time from a period's start until ``board``'s last frame of it is
        through, over the cycles that carry the board's frames (after :meth:`close`)."""
        return float(np.median(np.frombuffer(self._latency[board], np.int64))) / PS_PER_US


def _ethernet_wire_bytes(r: SimResult, outbound_only: bool) -> int:
    return r.wire_bytes_sent_per_cycle if outbound_only else r.wire_bytes_per_cycle


def _max_nodes(within_1ms: int, within_5ms: int) -> dict[str, int]:
    """The most nodes of 192 bytes served within 1 ms and 5 ms, under ``max_nodes_*`` and the
    old keys ``max_patches_*`` (the same values; docs/interface.md, Old names)."""
    return {
        "max_nodes_1ms": within_1ms,
        "max_nodes_5ms": within_5ms,
        "max_patches_1ms": within_1ms,
        "max_patches_5ms": within_5ms,
    }


def _largest(fits: Any, hi: int) -> int:
    """Largest n in 0..hi with fits(n) (fits is monotone: true up to some n)."""
    lo = 0
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if fits(mid):
            lo = mid
        else:
            hi = mid - 1
    return lo


def compare(
    s: SkinSamples | SkinLog,
    params: TimingParams,
    *,
    progress: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """The comparison document (``skinframes compare --json``), from the cycles as they come
    (a :class:`SkinLog` is read once more; memory does not grow with its frames).
    ``progress``: called with the number of cycles of each chunk done."""
    bit = bit_time_ps(canbus.BITRATE_BPS)
    period_us = s.period_ps / PS_PER_US
    horizon = s.samples * s.period_ps
    cycles = min(s.samples, MAX_EMULATED_SAMPLES)
    load = np.zeros((cycles, len(s.boards), s.data_bytes), np.uint8)  # the Ethernet buses'
    recorded = np.zeros(s.samples, np.int64)  # bits of each cycle's frames as recorded
    frames = total_bits = 0
    # re-emulated: every board queues its sample's frames at the period start, in the order sent
    bus = CanArbiter(canbus.BITRATE_BPS)
    emulated = _BusTimes(s.samples, s.period_ps, horizon)
    for chunk in s.cycles(frames=True):
        k = chunk.first
        if k < cycles:
            load[k : k + len(chunk.taxels)] = chunk.taxels[: cycles - k]
        for cycle_frames in chunk.frames:
            bits = [f.bits() for f in cycle_frames]
            recorded[k] = sum(bits)
            frames += len(bits)
            total_bits += recorded[k]
            bus.offer(
                (BusFrame(k * s.period_ps, f.arbitration_id >> 4 & 0xF, f.arbitration_id, n), k)
                for f, n in zip(cycle_frames, bits, strict=True)
            )
            k += 1
        emulated.add(bus.run(until_ps=k * s.period_ps))
        if progress is not None:
            progress(len(chunk.taxels))
    emulated.add(bus.run())
    emulated.close()
    can_cycle = float(np.median(recorded * bit)) / PS_PER_US
    mean_bits = float(total_bits / frames)
    per_board_us = canbus.FRAMES_PER_BOARD * mean_bits * bit / PS_PER_US  # a full 16-triangle patch

    n, size = len(s.boards), s.data_bytes
    epl = simulate_epl(n, size, params, cycles=cycles, payloads=load)
    ecat = simulate_ecat(n, size, params, cycles=cycles, payloads=load)

    # the most patches within a budget: one steady cycle each, from the engines' timing-only
    # sweep (emulator.net.sweep: the same timing as simulate(..., cycles=1), no frame bytes)
    patch = np.array([taxel.PATCH_BYTES], dtype=np.int64)

    def epl_fits(budget: float) -> Any:
        return lambda k: int(epl_cycle_ps(k, patch, params)[0]) / PS_PER_US <= budget

    def ecat_fits(budget: float) -> Any:
        return lambda k: (
            int(ecat_cycle_ps(k, patch, params, closed_ring=False)[0]) / PS_PER_US <= budget
        )

    doc: dict[str, Any] = {
        "boards": list(s.boards),
        "triangles": s.triangles,
        "samples": s.samples,
        "period_us": period_us,
        "bytes_per_board": size,
        "preset": params.name,
        "left_out": s.left_out.to_json(),
        "can": {
            "cycle_us": can_cycle,
            "bus_load": can_cycle / period_us,
            "wire_bytes_per_sample": float(np.median(recorded)) / 8,
            **_max_nodes(int(BUDGETS_US[0] // per_board_us), int(BUDGETS_US[1] // per_board_us)),
            "emulated": {
                "cycle_us": emulated.cycle_us(),
                "bus_load": emulated.busy_ps / horizon,
                "latency_us": {str(board): emulated.latency_us(board) for board in s.boards},
            },
        },
    }
    for name, r, fits, hi, outbound_only in (
        ("epl", epl, epl_fits, powerlink.MAX_CN_NODE_ID, False),
        ("ecat", ecat, ecat_fits, MAX_EMULATED_SLAVES, True),
    ):
        cycle = r.cycle_us()["median"]
        doc[name] = {
            "cycle_us": cycle,
            "bus_load": cycle / period_us,
            "wire_bytes_per_sample": _ethernet_wire_bytes(r, outbound_only),
            **_max_nodes(_largest(fits(BUDGETS_US[0]), hi), _largest(fits(BUDGETS_US[1]), hi)),
        }
    return doc
