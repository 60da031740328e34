"""The same taxels on the legacy CAN bus, on EPL and on EtherCAT, side by side.

A skin CAN trace gives boards, triangles, samples and their period. Per sample:

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

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.model.limits import MAX_EMULATED_SLAVES
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_NS, PS_PER_US
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.can_bus import BusFrame, arbitrate, bit_time_ps
from emulator.net.result import SimResult
from skinframes import canbus, powerlink, taxel
from skinframes.canbus.log import CanLog, CanLogReader, RecordCounts

__all__ = ["LeftOut", "SkinSamples", "compare", "read_skin_samples", "samples_of"]

DEFAULT_PERIOD_PS: Final = canbus.DEFAULT_PERIOD_MS * 1_000_000_000
BUDGETS_US: Final = (1_000, 5_000)  # the reactive loops the comparison asks about
MAX_EMULATED_SAMPLES: Final = 20  # cycles emulated per Ethernet bus (the cycle repeats exactly)


@dataclass(frozen=True)
class LeftOut:
    """What a CAN log held that :class:`SkinSamples` does not carry, with the reason.

    Attributes:
        boards: per board address seen, its complete and incomplete samples and stray frames.
        boards_without_sample: boards with no complete sample: not carried at all.
        incomplete_samples: board samples missing a triangle (left out).
        stray_frames: skin frames in no sample (orphan heads/tails, malformed, a repeated
            triangle).
        missing: per board carried, the cycles in which it has no complete sample (carried as
            no-load taxels).
        other_frames: frames that are not skin data (other identifiers, error frames).
        skipped_records: records of the file that are not frames (see ``records``).
        records: the file's records, decoded or skipped with a reason.
    """

    boards: tuple[canbus.BoardCounts, ...] = ()
    boards_without_sample: tuple[int, ...] = ()
    incomplete_samples: int = 0
    stray_frames: int = 0
    missing: tuple[tuple[int, int], ...] = ()
    other_frames: int = 0
    skipped_records: int = 0
    records: RecordCounts | None = None

    @property
    def anything(self) -> bool:
        """True when a sample or a skin frame was left out, or a cycle misses a board."""
        return bool(self.incomplete_samples or self.stray_frames or self.missing)

    def to_json(self) -> dict[str, Any]:
        """The ``left_out`` object of ``skinframes compare --json``."""
        return {
            "incomplete_samples": self.incomplete_samples,
            "stray_frames": self.stray_frames,
            "boards_without_sample": list(self.boards_without_sample),
            "cycles_missing_board": {str(b): n for b, n in self.missing},
            "other_frames": self.other_frames,
            "skipped_records": self.skipped_records,
            "boards": [b.to_json() for b in self.boards],
        }

    def text(self) -> str:
        """One line: ``left out: 1 incomplete sample, 2 stray frames (board 10: 0x4a0: 2), ...``."""
        parts = [
            f"{self.incomplete_samples} incomplete board samples",
            f"{self.stray_frames} stray skin frames",
        ]
        per_board = [
            f"board {b.board}: {b.incomplete} incomplete, {b.stray_frames} stray"
            + (
                f" ({', '.join(f'{i.arbitration_id:#05x}: {i.count}' for i in b.stray[:4])})"
                if b.stray
                else ""
            )
            for b in self.boards
            if b.incomplete or b.stray
        ]
        if per_board:
            parts[-1] += f" [{'; '.join(per_board)}]"
        if self.boards_without_sample:
            parts.append(
                "boards without a complete sample, not carried: "
                + ", ".join(map(str, self.boards_without_sample))
            )
        if self.missing:
            parts.append(
                "cycles carrying no-load taxels for a board without its sample: "
                + ", ".join(f"board {b}: {n}" for b, n in self.missing)
            )
        return "left out: " + "; ".join(parts)


@dataclass(frozen=True)
class SkinSamples:
    """The skin samples of a trace, one row per board, in board order.

    A cycle holds at most one complete sample of each board (a board's sample starts a new
    cycle when the cycle already has one of that board; samples in time order).

    Attributes:
        boards: board addresses with a complete sample, ascending (EPL CN i+1 / EtherCAT slave
            i carries boards[i]).
        triangles: triangles per board sample (T: the most frequent span in the log).
        taxels: (cycles, boards, 12 * triangles) uint8, in time order; a board without its
            sample in a cycle reads no-load (``left_out.missing``).
        start_ns: (cycles,) time of each cycle's first frame.
        frames: per cycle, the skin frames that carried it.
        period_ps: the sample period (median spacing of the cycles; 50 ms with one cycle).
        left_out: what the log held that is not carried, and why.
    """

    boards: tuple[int, ...]
    triangles: int
    taxels: npt.NDArray[np.uint8]
    start_ns: npt.NDArray[np.int64]
    frames: tuple[tuple[canbus.CanFrame, ...], ...]
    period_ps: int
    left_out: LeftOut = LeftOut()

    @property
    def samples(self) -> int:
        """Cycles (each with a complete sample of at least one board)."""
        return int(self.taxels.shape[0])

    @property
    def data_bytes(self) -> int:
        """Taxel bytes per board and sample."""
        return int(self.taxels.shape[2])


def samples_of(trace: CanLog) -> SkinSamples:
    """The complete board samples of a CAN log read whole (:func:`read_can_log`).

    Raises:
        TopologyError: the trace holds no complete board sample.
    """
    collected: list[canbus.BoardSample] = []
    r = canbus.Reassembler(on_board_sample=collected.append)
    for f in trace.frames:
        r.feed(f)
    return _group(trace.path, collected, r.finish(), trace.records)


def read_skin_samples(path: str | Path) -> SkinSamples:
    """:func:`samples_of` of a CAN log file read record by record (the frames are not held;
    the samples are).

    Raises:
        TopologyError: the log holds no complete board sample.
        CanLogFormatError: the file is not a readable CAN log.
    """
    collected: list[canbus.BoardSample] = []
    r = canbus.Reassembler(on_board_sample=collected.append)
    reader = CanLogReader(path)
    for batch in reader.batches():
        for item in batch:
            if isinstance(item, tuple):
                r.feed_data(item[0], item[1], item[2])
            else:
                r.feed(item)
    return _group(str(path), collected, r.finish(), reader.record_counts)


def _group(
    path: str,
    collected: list[canbus.BoardSample],
    counts: canbus.FrameCounts,
    records: RecordCounts | None,
) -> SkinSamples:
    """Cycles of complete board samples, and what was left out."""
    t = counts.triangles
    complete = sorted(
        (b for b in collected if b.is_complete(t)), key=lambda b: (b.start_ns, b.board)
    )
    if not complete:
        raise TopologyError(f"{path}: no skin samples (class 4 head/tail pairs) in the trace")
    boards = tuple(sorted({b.board for b in complete}))
    column = {board: i for i, board in enumerate(boards)}
    period = _period_ps(complete)
    t0 = complete[0].start_ns
    slots: dict[int, dict[int, canbus.BoardSample]] = {}
    for b in complete:  # the cycle of a board sample: the period it starts in (P/4 early is fine)
        k = (4 * (b.start_ns - t0) * PS_PER_NS + period) // (4 * period)
        while b.board in slots.setdefault(k, {}):  # two samples of a board in one period
            k += 1
        slots[k][b.board] = b
    cycles = [slots[k] for k in sorted(slots)]
    count = len(cycles)
    taxels = np.full((count, len(boards), t, 12), taxel.NO_LOAD, dtype=np.uint8)
    start = np.empty(count, dtype=np.int64)
    frames: list[tuple[canbus.CanFrame, ...]] = []
    missing = dict.fromkeys(boards, 0)
    for k, cycle in enumerate(cycles):
        for board in boards:
            if board not in cycle:
                missing[board] += 1
        cycle_frames: list[canbus.CanFrame] = []
        for board, b in cycle.items():
            for ts in b.triangles:
                taxels[k, column[board], ts.sample.triangle] = ts.sample.taxels
                cycle_frames.extend(ts.can_frames())
        start[k] = min(b.start_ns for b in cycle.values())
        frames.append(tuple(sorted(cycle_frames, key=lambda fr: fr.time_ns)))
    left_out = LeftOut(
        boards=counts.boards,
        boards_without_sample=tuple(
            b.board for b in counts.boards if b.complete == 0 and b.board not in column
        ),
        incomplete_samples=sum(b.incomplete for b in counts.boards),
        stray_frames=sum(b.stray_frames for b in counts.boards),
        missing=tuple((b, n) for b, n in missing.items() if n),
        other_frames=counts.other + counts.error_frames,
        skipped_records=records.skipped if records is not None else 0,
        records=records,
    )
    return SkinSamples(
        boards,
        t,
        taxels.reshape(count, len(boards), -1),
        start,
        tuple(frames),
        period,
        left_out,
    )


def _period_ps(complete: list[canbus.BoardSample]) -> int:
    """The sample period: the median spacing of consecutive complete samples of a board (a
    missing sample makes one spacing of two periods, which the median passes over)."""
    last: dict[int, int] = {}
    spacing: list[int] = []
    for b in complete:
        if b.board in last:
            spacing.append(b.start_ns - last[b.board])
        last[b.board] = b.start_ns
    period = int(np.median(spacing)) * PS_PER_NS if spacing else DEFAULT_PERIOD_PS
    return period if period > 0 else DEFAULT_PERIOD_PS


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


def compare(s: SkinSamples, params: TimingParams) -> dict[str, Any]:
    """The comparison document (``skinframes compare --json``)."""
    bit = bit_time_ps(canbus.BITRATE_BPS)
    period_us = s.period_ps / PS_PER_US
    recorded = [sum(f.bits() for f in frames) * bit for frames in s.frames]
    can_cycle = float(np.median(recorded)) / PS_PER_US

    # re-emulated: every board queues its sample's frames at the period start, in the order sent
    bus = [
        BusFrame(k * s.period_ps, f.arbitration_id >> 4 & 0xF, f.arbitration_id, f.bits())
        for k, frames in enumerate(s.frames)
        for f in frames
    ]
    sched = arbitrate(bus, canbus.BITRATE_BPS)
    k_of = np.array([b.release_ps // s.period_ps for b in bus], dtype=np.int64)
    emulated = [int(sched.end_ps[k_of == k].max()) - k * s.period_ps for k in range(s.samples)]
    node_of = np.array([b.node for b in bus], dtype=np.int64)
    latency = {  # per board: from the period start until its last frame of the sample is through
        str(board): float(
            np.median(
                [
                    int(sched.end_ps[mine].max()) - k * s.period_ps
                    for k in range(s.samples)
                    if (mine := (k_of == k) & (node_of == board)).any()  # the board's cycles
                ]
            )
        )
        / PS_PER_US
        for board in s.boards
    }
    horizon = s.samples * s.period_ps
    mean_bits = float(np.mean([f.bits() for frames in s.frames for f in frames]))
    per_board_us = canbus.FRAMES_PER_BOARD * mean_bits * bit / PS_PER_US  # a full 16-triangle patch

    cycles = min(s.samples, MAX_EMULATED_SAMPLES)
    load = s.taxels[:cycles]
    n, size = len(s.boards), s.data_bytes
    epl = simulate_epl(n, size, params, cycles=cycles, payloads=load)
    ecat = simulate_ecat(n, size, params, cycles=cycles, payloads=load)

    def epl_fits(budget: float) -> Any:
        return lambda k: (
            simulate_epl(k, taxel.PATCH_BYTES, params, cycles=1).cycle_us()["max"] <= budget
        )

    def ecat_fits(budget: float) -> Any:
        return lambda k: (
            simulate_ecat(k, taxel.PATCH_BYTES, params, cycles=1).cycle_us()["max"] <= budget
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
            "wire_bytes_per_sample": float(
                np.median([sum(f.bits() for f in fr) for fr in s.frames])
            )
            / 8,
            **_max_nodes(int(BUDGETS_US[0] // per_board_us), int(BUDGETS_US[1] // per_board_us)),
            "emulated": {
                "cycle_us": float(np.median(emulated)) / PS_PER_US,
                "bus_load": sched.load(0, horizon),
                "latency_us": latency,
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
