"""A CAN log's skin samples grouped into cycles, one complete sample of each board per cycle.

The grouping (which board samples make a cycle, the sample period, what is left out) needs the
whole log: T, the triangles of a complete board sample, is the most frequent span in it, and
the samples are ordered by start time. :class:`SkinLog` therefore reads a log twice. The first
pass keeps a few integers per board sample (board, start, span) and works out the cycle of every
complete one; the second streams the cycles in order, chunk by chunk, so a long log is carried
(``can convert``) and compared (``compare``) in memory that does not grow with its frames.
:class:`SkinSamples` is the same grouping held whole (small logs, tests).
"""

from __future__ import annotations

import array
import dataclasses
from collections.abc import Callable, Generator, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.model.units import PS_PER_NS
from skinframes import canbus, taxel
from skinframes.canbus.lines import DataTuple
from skinframes.canbus.log import CanLog, CanLogFormatError, CanLogReader, RecordCounts
from skinframes.pcap import Skipped

__all__ = [
    "CycleChunk",
    "LeftOut",
    "SkinLog",
    "SkinSamples",
    "read_skin_samples",
    "samples_of",
]

DEFAULT_PERIOD_PS: Final = canbus.DEFAULT_PERIOD_MS * 1_000_000_000
CHUNK_CYCLES: Final = 256  # cycles per chunk of the second pass
_PRUNE_SLOTS: Final = 4096  # cycle slots remembered while assigning (older ones are full)
# times kept as int64 ns: within +-2**62 ns (146 years around 1970), so differences fit too
MAX_TIME_NS: Final = 1 << 62

Batch = list[canbus.CanFrame | DataTuple]
# a log opened for one pass: its frames in batches, and its record accounting once read
Opener = Callable[[], tuple[Iterable[Batch], Callable[[], RecordCounts | None]]]


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
        damaged: the first damaged records with their index and reason (a truncated log: the
            reader stopped, the rest of the file unread), as ``can decode`` lists them.
    """

    boards: tuple[canbus.BoardCounts, ...] = ()
    boards_without_sample: tuple[int, ...] = ()
    incomplete_samples: int = 0
    stray_frames: int = 0
    missing: tuple[tuple[int, int], ...] = ()
    other_frames: int = 0
    skipped_records: int = 0
    records: RecordCounts | None = None
    damaged: tuple[Skipped, ...] = ()

    @property
    def damaged_records(self) -> int:
        """Skipped records that are damage (``records.damaged``), not headers or comments."""
        return self.records.damaged if self.records is not None else len(self.damaged)

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
            "damaged_records": self.damaged_records,
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
class CycleChunk:
    """Consecutive cycles from cycle ``first`` on.

    Attributes:
        first: the index of the first cycle.
        taxels: (m, boards, 12 * triangles) uint8; a board without its sample reads no-load.
        start_ns: (m,) time of each cycle's first frame.
        frames: per cycle, the skin frames that carried it in time order (empty when not
            asked for).
    """

    first: int
    taxels: npt.NDArray[np.uint8]
    start_ns: npt.NDArray[np.int64]
    frames: tuple[tuple[canbus.CanFrame, ...], ...] = ()


@dataclass(frozen=True)
class SkinSamples:
    """The skin samples of a log held whole, one row per board, in board order.

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

    def cycles(self, *, frames: bool = True, chunk: int = CHUNK_CYCLES) -> Iterator[CycleChunk]:
        """The cycles in chunks of at most ``chunk``, as :meth:`SkinLog.cycles` gives them."""
        for lo in range(0, self.samples, chunk):
            hi = min(lo + chunk, self.samples)
            yield CycleChunk(
                lo, self.taxels[lo:hi], self.start_ns[lo:hi], self.frames[lo:hi] if frames else ()
            )


@dataclass
class _Cycle:
    """A cycle being filled in the second pass."""

    taxels: npt.NDArray[np.uint8]  # (boards, T, 12)
    found: int = 0  # board samples placed
    parts: list[tuple[int, list[canbus.CanFrame]]] = field(default_factory=list)


class SkinLog:
    """The skin samples of a CAN log, grouped into cycles as :class:`SkinSamples`, read twice
    instead of held: the attributes come from the first pass, :meth:`cycles` is the second.

    Use :meth:`open` for a file and :meth:`of` for a log already read. ``progress``: called
    with the number of frames of each batch the first pass reads.

    Raises:
        TopologyError: the log holds no complete board sample.
        CanLogFormatError: the file is not a readable CAN log, or changed between the passes.
    """

    def __init__(
        self, name: str, opener: Opener, progress: Callable[[int], None] | None = None
    ) -> None:
        self.name = name
        self._opener = opener
        board = array.array("B")
        start = array.array("q")
        span = array.array("B")
        whole = array.array("B")

        def note(b: canbus.BoardSample) -> None:
            if not -MAX_TIME_NS <= b.start_ns <= MAX_TIME_NS:
                raise CanLogFormatError(
                    f"{name}: a frame at {b.start_ns / 1e9:.6g} s: times beyond "
                    f"{MAX_TIME_NS / 1e9:.3g} s (146 years) from 0 are not carried"
                )
            board.append(b.board)
            start.append(b.start_ns)
            span.append(b.span)
            whole.append(b.contiguous)

        counts, records = _exhaust(_one_pass(opener, note, progress))
        self._board = np.frombuffer(board, np.uint8) if board else np.zeros(0, np.uint8)
        self._start = np.frombuffer(start, np.int64) if start else np.zeros(0, np.int64)
        t = counts.triangles
        complete = np.flatnonzero(
            (np.frombuffer(whole, np.uint8) == 1) & (np.frombuffer(span, np.uint8) == t)
            if board
            else np.zeros(0, bool)
        )
        if not len(complete):
            raise TopologyError(f"{name}: no skin samples (class 4 head/tail pairs) in the log")
        self.triangles = t
        # complete board samples by (start, board), ties in the order they closed
        order = complete[np.lexsort((self._board[complete], self._start[complete]))]
        self.period_ps = _period_ps(self._board[order], self._start[order])
        slot = _slots(self._board[order].tolist(), self._start[order].tolist(), self.period_ps)
        distinct, cycle_of_sorted = np.unique(slot, return_inverse=True)
        self.samples = len(distinct)
        self._cycle = np.full(len(self._board), -1, np.int64)  # per board sample, as closed
        self._cycle[order] = cycle_of_sorted
        self._rank = np.full(len(self._board), -1, np.int64)  # its place in (start, board)
        self._rank[order] = np.arange(len(order))
        self._expected = np.bincount(cycle_of_sorted, minlength=self.samples)
        self.start_ns = np.full(self.samples, np.iinfo(np.int64).max, np.int64)
        np.minimum.at(self.start_ns, cycle_of_sorted, self._start[order])
        carried = np.bincount(self._board[order], minlength=16)
        self.boards = tuple(int(b) for b in np.flatnonzero(carried))
        self._column = {b: i for i, b in enumerate(self.boards)}
        self.left_out = LeftOut(
            boards=counts.boards,
            boards_without_sample=tuple(
                b.board for b in counts.boards if b.complete == 0 and b.board not in self._column
            ),
            incomplete_samples=sum(b.incomplete for b in counts.boards),
            stray_frames=sum(b.stray_frames for b in counts.boards),
            missing=tuple(
                (b, self.samples - int(carried[b]))
                for b in self.boards
                if self.samples > carried[b]
            ),
            other_frames=counts.other + counts.error_frames,
            skipped_records=records.skipped if records is not None else 0,
            records=records,
        )

    @classmethod
    def open(cls, path: str | Path, progress: Callable[[int], None] | None = None) -> SkinLog:
        """A CAN log file (any format :class:`CanLogReader` reads)."""

        readers: list[CanLogReader] = []

        def opener() -> tuple[Iterable[Batch], Callable[[], RecordCounts | None]]:
            reader = CanLogReader(path)
            if not readers:  # the first pass: its accounting is the log's
                readers.append(reader)
            return reader.batches(), lambda: reader.record_counts

        log = cls(str(path), opener, progress)
        log.left_out = dataclasses.replace(log.left_out, damaged=tuple(readers[0].damaged))
        return log

    @classmethod
    def of(cls, log: CanLog) -> SkinLog:
        """A CAN log read whole (:func:`skinframes.canbus.log.read_can_log`)."""
        frames: Batch = list(log.frames)
        skin = cls(log.path, lambda: ((frames,), lambda: log.records))
        skin.left_out = dataclasses.replace(skin.left_out, damaged=log.skipped)
        return skin

    @property
    def data_bytes(self) -> int:
        """Taxel bytes per board and sample."""
        return self.triangles * taxel.TAXELS_PER_TRIANGLE

    def cycles(self, *, frames: bool = True, chunk: int = CHUNK_CYCLES) -> Iterator[CycleChunk]:
        """The cycles in order, in chunks of at most ``chunk`` (the second pass over the log).

        ``frames``: also the skin frames of each cycle (``compare`` times them on CAN).
        """
        shape = (len(self.boards), self.triangles, taxel.TAXELS_PER_TRIANGLE)
        filling: dict[int, _Cycle] = {}
        done: list[_Cycle] = []
        ready = 0  # the next cycle to hand out
        closed = 0  # board samples closed so far in this pass

        def place(b: canbus.BoardSample) -> None:
            nonlocal closed
            i = closed
            closed += 1
            if i >= len(self._board) or (b.board, b.start_ns) != (
                int(self._board[i]),
                int(self._start[i]),
            ):
                raise CanLogFormatError(f"{self.name}: the log changed while it was read")
            c = int(self._cycle[i])
            if c < 0:
                return
            cyc = filling.get(c)
            if cyc is None:
                cyc = filling[c] = _Cycle(np.full(shape, taxel.NO_LOAD, np.uint8))
            column = cyc.taxels[self._column[b.board]]
            for ts in b.triangles:
                column[ts.sample.triangle] = ts.sample.taxels
            cyc.found += 1
            if frames:
                cyc.parts.append(
                    (int(self._rank[i]), [f for ts in b.triangles for f in ts.can_frames()])
                )

        def chunk_of(first: int, cycles: list[_Cycle]) -> CycleChunk:
            return CycleChunk(
                first,
                np.stack([c.taxels for c in cycles]).reshape(len(cycles), len(self.boards), -1),
                self.start_ns[first : first + len(cycles)],
                tuple(_frames_of(c) for c in cycles) if frames else (),
            )

        pending: list[canbus.BoardSample] = []

        def handed_out() -> Iterator[CycleChunk]:
            """Place the board samples closed so far; the chunks of cycles now complete."""
            nonlocal ready, done
            for b in pending:
                place(b)
            pending.clear()
            while ready in filling and filling[ready].found == self._expected[ready]:
                done.append(filling.pop(ready))
                ready += 1
                if len(done) == chunk:
                    yield chunk_of(ready - len(done), done)
                    done = []

        reading = _one_pass(self._opener, pending.append)
        for _ in reading:
            yield from handed_out()
        yield from handed_out()  # the board samples the end of the log closed
        if closed != len(self._board) or ready != self.samples:
            raise CanLogFormatError(f"{self.name}: the log changed while it was read")
        if done:
            yield chunk_of(ready - len(done), done)

    def taxel_chunks(self, chunk: int = CHUNK_CYCLES) -> Iterator[npt.NDArray[np.uint8]]:
        """The cycles' taxels, (m, boards, data_bytes) at a time: ``payloads`` of
        :func:`emulator.simulate_epl` and :func:`emulator.simulate_ecat`."""
        return (c.taxels for c in self.cycles(frames=False, chunk=chunk))

    def whole(self) -> SkinSamples:
        """Every cycle held: :class:`SkinSamples`."""
        parts = list(self.cycles())
        return SkinSamples(
            self.boards,
            self.triangles,
            np.concatenate([c.taxels for c in parts]),
            self.start_ns.copy(),
            tuple(f for c in parts for f in c.frames),
            self.period_ps,
            self.left_out,
        )


def _one_pass(
    opener: Opener,
    on_board_sample: Callable[[canbus.BoardSample], object],
    progress: Callable[[int], None] | None = None,
) -> Generator[None, None, tuple[canbus.FrameCounts, RecordCounts | None]]:
    """One pass over the log through a :class:`canbus.Reassembler`: yields after each batch
    (the board samples it closed have been handed to ``on_board_sample``) and returns the
    counts and the record accounting at the end (where the last board samples close)."""
    source, records = opener()
    r = canbus.Reassembler(on_board_sample=on_board_sample)
    feed, feed_data = r.feed, r.feed_data
    for batch in source:
        for item in batch:
            if isinstance(item, tuple):
                feed_data(item[0], item[1], item[2])
            else:
                feed(item)
        if progress is not None:
            progress(len(batch))
        yield
    return r.finish(), records()


def _exhaust(
    reading: Generator[None, None, tuple[canbus.FrameCounts, RecordCounts | None]],
) -> tuple[canbus.FrameCounts, RecordCounts | None]:
    """Run :func:`_one_pass` to its end; what it returns."""
    while True:
        try:
            next(reading)
        except StopIteration as end:
            result: tuple[canbus.FrameCounts, RecordCounts | None] = end.value
            return result


def _period_ps(board: npt.NDArray[np.uint8], start_ns: npt.NDArray[np.int64]) -> int:
    """The sample period: the median spacing of consecutive complete samples of a board (a
    missing sample makes one spacing of two periods, which the median passes over); samples in
    start order."""
    spacing = [np.diff(start_ns[board == b]) for b in np.unique(board)]
    gaps = np.concatenate(spacing) if spacing else np.zeros(0, np.int64)
    period = int(np.median(gaps)) * PS_PER_NS if len(gaps) else DEFAULT_PERIOD_PS
    return period if period > 0 else DEFAULT_PERIOD_PS


def _slots(boards: list[int], starts_ns: list[int], period_ps: int) -> npt.NDArray[np.int64]:
    """The cycle slot of each complete board sample (in start order): the period it starts in
    (P/4 early is fine), the next free one when the board already has a sample there."""
    t0 = starts_ns[0]
    out = np.empty(len(boards), np.int64)
    taken: dict[int, int] = {}  # slot -> boards in it (bit mask)
    for j, (board, start) in enumerate(zip(boards, starts_ns, strict=True)):
        k = (4 * (start - t0) * PS_PER_NS + period_ps) // (4 * period_ps)
        if len(taken) > _PRUNE_SLOTS:  # later samples start no earlier: slots below k are done
            taken = {s: m for s, m in taken.items() if s >= k}
        bit = 1 << board
        while taken.get(k, 0) & bit:
            k += 1
        taken[k] = taken.get(k, 0) | bit
        out[j] = k
    return out


def _frames_of(cycle: _Cycle) -> tuple[canbus.CanFrame, ...]:
    """A cycle's skin frames in time order (ties: board samples in start order)."""
    frames = [f for _, part in sorted(cycle.parts, key=lambda p: p[0]) for f in part]
    return tuple(sorted(frames, key=lambda fr: fr.time_ns))


def samples_of(log: CanLog) -> SkinSamples:
    """The complete board samples of a CAN log read whole (:func:`read_can_log`).

    Raises:
        TopologyError: the log holds no complete board sample.
    """
    return SkinLog.of(log).whole()


def read_skin_samples(path: str | Path) -> SkinSamples:
    """:func:`samples_of` of a CAN log file read record by record (:class:`SkinLog` streams
    the cycles instead of holding them).

    Raises:
        TopologyError: the log holds no complete board sample.
        CanLogFormatError: the file is not a readable CAN log.
    """
    return SkinLog.open(path).whole()
