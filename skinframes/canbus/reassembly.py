"""Skin samples from a stream of CAN frames: :class:`Reassembler` pairs heads with tails and
accounts for every other frame (:class:`FrameCounts`); :func:`reassemble` runs it over a stream."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Final

from skinframes.canbus.codec import (
    FRAMES_PER_TRIANGLE,
    HEAD_MARKER,
    MAX_BOARD,
    MAX_CLASS,
    SKIN_CLASS,
    SKIN_DLC,
    TAIL_MARKER,
    TriangleSample,
)
from skinframes.canbus.wire import CanFrame, check_range

MAX_LISTED_MALFORMED: Final = 1000  # malformed frames kept with their reason; the rest counted


@dataclass(frozen=True, slots=True)
class TimedSample:
    """A reassembled :class:`TriangleSample` with the timestamps of its two frames.

    Attributes:
        time_ns: timestamp of the head frame (the start of the sample on the bus).
        sample: the triangle's taxels and status.
        end_time_ns: timestamp of the tail frame.
    """

    time_ns: int
    sample: TriangleSample
    end_time_ns: int

    def to_json(self) -> dict[str, int | list[int]]:
        """The ``skinframes can decode --json`` object."""
        s = self.sample
        return {
            "time_ns": self.time_ns,
            "board": s.board,
            "triangle": s.triangle,
            "taxels": list(s.taxels),
            "error": s.error,
            "out_of_range": s.out_of_range,
        }

    def can_frames(self) -> tuple[CanFrame, CanFrame]:
        """The head (at ``time_ns``) and the tail (at ``end_time_ns``) as :class:`CanFrame`."""
        (ident, head), (_, tail) = self.sample.can_frames()
        return CanFrame(ident, head, time_ns=self.time_ns), CanFrame(
            ident, tail, time_ns=self.end_time_ns
        )


@dataclass(frozen=True, slots=True)
class IdCount:
    """How many frames of one identifier were seen (``extended`` for 29-bit ids)."""

    arbitration_id: int
    extended: bool
    count: int


@dataclass(frozen=True, slots=True)
class BoardCounts:
    """One board's samples in a stream (a board sample: its triangles 0..T-1 of one period).

    Attributes:
        board: the board address.
        skin_class: the identifier class its frames use.
        complete: board samples with every triangle 0..T-1 (T: :attr:`FrameCounts.triangles`).
        incomplete: board samples that miss a triangle (a lost frame, a stray pair of frames).
        stray: the board's frames that are in no triangle sample of a board sample (orphan
            heads and tails, malformed frames, a triangle repeated), per CAN identifier.
    """

    board: int
    skin_class: int
    complete: int
    incomplete: int
    stray: tuple[IdCount, ...] = ()

    @property
    def stray_frames(self) -> int:
        """Frames counted in :attr:`stray`."""
        return sum(i.count for i in self.stray)

    def to_json(self) -> dict[str, Any]:
        """``{"board", "skin_class", "complete", "incomplete", "stray_frames", "stray_ids"}``
        (``stray_ids``: ``{"0x4e0": frames}``)."""
        return {
            "board": self.board,
            "skin_class": self.skin_class,
            "complete": self.complete,
            "incomplete": self.incomplete,
            "stray_frames": self.stray_frames,
            "stray_ids": {f"{i.arbitration_id:#05x}": i.count for i in self.stray},
        }


@dataclass(frozen=True, slots=True)
class BoardSample:
    """The triangle samples one board sent in one period, in ascending triangle order."""

    board: int
    skin_class: int
    triangles: tuple[TimedSample, ...]

    @property
    def start_ns(self) -> int:
        """Time of the first triangle's head frame."""
        return self.triangles[0].time_ns

    @property
    def span(self) -> int:
        """Highest triangle + 1."""
        return self.triangles[-1].sample.triangle + 1

    @property
    def contiguous(self) -> bool:
        """Triangles 0..span-1, none missing."""
        return len(self.triangles) == self.span

    def is_complete(self, triangles: int) -> bool:
        """Every triangle 0..triangles-1 present (and no other)."""
        return self.contiguous and self.span == triangles


@dataclass(frozen=True, slots=True)
class FrameCounts:
    """Where every frame of a stream went; :attr:`accounted` checks the sum.

    Attributes:
        frames: frames fed to the reassembler.
        sample_frames: frames that became samples (2 per sample).
        orphan_heads: heads not followed by their tail (replaced by a new head, or at the end).
        orphan_tails: tails without a pending head.
        malformed: frames with a skin identifier that are not a valid head or tail.
        other: frames that are not skin data (other ids or classes, 29-bit ids, remote, CAN FD).
        error_frames: error frames.
        other_ids: the identifiers of the ``other`` frames with their counts, most frequent first.
        triangles: triangles per board sample (T), the most frequent span of the board samples
            (0 before :meth:`Reassembler.finish`).
        boards: per board address, its complete and incomplete samples and stray frames
            (after :meth:`Reassembler.finish`).
    """

    frames: int = 0
    sample_frames: int = 0
    orphan_heads: int = 0
    orphan_tails: int = 0
    malformed: int = 0
    other: int = 0
    error_frames: int = 0
    other_ids: tuple[IdCount, ...] = ()
    triangles: int = 0
    boards: tuple[BoardCounts, ...] = ()

    @property
    def samples(self) -> int:
        """Complete triangle samples."""
        return self.sample_frames // FRAMES_PER_TRIANGLE

    @property
    def accounted(self) -> bool:
        """True when every frame is in exactly one category."""
        return self.frames == (
            self.sample_frames
            + self.orphan_heads
            + self.orphan_tails
            + self.malformed
            + self.other
            + self.error_frames
        )


@dataclass(frozen=True, slots=True)
class Malformed:
    """A frame with a skin identifier that is not skin data, with the reason."""

    index: int
    time_ns: int
    arbitration_id: int
    reason: str


@dataclass(frozen=True, slots=True)
class Reassembly:
    """The result of :func:`reassemble`."""

    samples: tuple[TimedSample, ...]
    counts: FrameCounts
    malformed: tuple[Malformed, ...]


class Reassembler:
    """Pair head and tail frames per (class, board, triangle) into :class:`TimedSample`, and
    group each board's triangles into board samples (:class:`BoardSample`).

    The host does the same (``CanBusSkin.cpp`` L633-644), keyed by identifier, so frames of
    several boards may interleave on the bus. Nothing raises: frames that are not skin data are
    counted (:class:`FrameCounts`), malformed skin frames are listed with their reason. Memory:
    per board the open sample (at most 16 triangles) and a few counters, whatever the stream's
    length.

    A board sends its triangles in ascending order every period (``skin_bus``; the firmware's
    loop over its 16 triangles), so a triangle not above the previous one starts the board's next
    sample; the same triangle twice in a row is a stray pair. After :meth:`finish`, T (the
    triangles per board sample) is the most frequent span, and each board's samples are
    complete (triangles 0..T-1) or incomplete (:class:`BoardCounts`).

    Args:
        boards: accept only these board addresses (as ``CanBusSkin`` filters on its configured
            ``skinCanIds``); ``None`` accepts 0..15. Class 3 is shared with other analog sensors,
            so give the boards when decoding a legacy-configuration bus.
        skin_classes: identifier classes that carry skin data (default: class 4 only).
        on_board_sample: called with every :class:`BoardSample` when it closes (the board's
            next sample begins, or :meth:`finish`), complete or not.

    Example::

        r = Reassembler(boards=[14, 13])
        for f in frames:
            if (s := r.feed(f)) is not None:
                print(s.sample.taxels)
        r.finish()  # pending heads become orphans
    """

    def __init__(
        self,
        *,
        boards: Iterable[int] | None = None,
        skin_classes: Iterable[int] = (SKIN_CLASS,),
        on_board_sample: Callable[[BoardSample], object] | None = None,
    ) -> None:
        self._boards = None if boards is None else frozenset(int(b) for b in boards)
        self._classes = frozenset(int(c) for c in skin_classes)
        for c in self._classes:
            check_range("skin_class", c, MAX_CLASS)
        for b in self._boards or ():
            check_range("board", b, MAX_BOARD)
        self._pending: dict[int, tuple[int, bytes]] = {}  # id -> (time_ns, head data)
        self._other_ids: Counter[tuple[int, bool]] = Counter()
        self._malformed: list[Malformed] = []
        self._malformed_count = 0
        self._n = 0
        self._sample_frames = 0
        self._orphan_heads = 0
        self._orphan_tails = 0
        self._error_frames = 0
        self._finished = False
        # per board key (class << 4 | board): the open board sample, spans seen, stray frames
        self._open: dict[int, list[TimedSample]] = {}
        self._spans: dict[int, Counter[tuple[int, bool]]] = {}
        self._stray: dict[int, Counter[int]] = {}
        self._on_board_sample = on_board_sample
        self._triangles = 0
        self._board_counts: tuple[BoardCounts, ...] = ()

    def _is_skin_id(self, ident: int) -> bool:
        if ident >> 8 not in self._classes:
            return False
        return self._boards is None or (ident >> 4) & 0xF in self._boards

    def feed(self, frame: CanFrame) -> TimedSample | None:
        """Take one frame; returns a sample when ``frame`` completes one."""
        if frame.error:
            self._n += 1
            self._error_frames += 1
            return None
        if frame.extended or frame.remote or frame.fd:
            self._n += 1
            self._other_ids[frame.arbitration_id, frame.extended] += 1
            return None
        return self.feed_data(frame.time_ns, frame.arbitration_id, frame.data, frame.dlc)

    def feed_data(
        self, time_ns: int, ident: int, data: bytes, dlc: int | None = None
    ) -> TimedSample | None:
        """:meth:`feed` for a classic 11-bit data frame given by its fields (faster)."""
        index = self._n
        self._n += 1
        if ident >> 8 not in self._classes or (
            self._boards is not None and (ident >> 4) & 0xF not in self._boards
        ):
            self._other_ids[ident, False] += 1
            return None
        if len(data) != SKIN_DLC or dlc not in (None, SKIN_DLC):
            reason = f"DLC {len(data) if dlc is None else dlc}, skin frames have 8 data bytes"
            self._add_malformed(Malformed(index, time_ns, ident, reason))
            return None
        marker = data[0]
        if marker == HEAD_MARKER:
            if ident in self._pending:
                self._orphan_heads += 1
                self._stray_frame(ident)
            self._pending[ident] = (time_ns, data if type(data) is bytes else bytes(data))
            return None
        if marker != TAIL_MARKER:
            reason = f"byte 0 is {marker:#04x}, expected 0x40 (head) or 0xc0 (tail)"
            self._add_malformed(Malformed(index, time_ns, ident, reason))
            return None
        head = self._pending.pop(ident, None)
        if head is None:
            self._orphan_tails += 1
            self._stray_frame(ident)
            return None
        self._sample_frames += FRAMES_PER_TRIANGLE
        sample = _timed(head[0], TriangleSample._from_data(ident, head[1], data), time_ns)
        # the board's sample (_add_triangle inlined: this is the hot path of `can decode`)
        key = ident >> 4
        current = self._open.get(key)
        if current is not None and (ident & 0xF) > current[-1].sample.triangle:
            current.append(sample)
        else:
            self._add_triangle(ident, sample)
        return sample

    def _add_malformed(self, m: Malformed) -> None:
        self._malformed_count += 1
        if len(self._malformed) < MAX_LISTED_MALFORMED:
            self._malformed.append(m)
        self._stray_frame(m.arbitration_id)

    def _stray_frame(self, ident: int, frames: int = 1) -> None:
        key = ident >> 4
        if key not in self._stray:
            self._stray[key] = Counter()
        self._stray[key][ident] += frames

    def _add_triangle(self, ident: int, sample: TimedSample) -> None:
        key = ident >> 4
        current = self._open.get(key)
        if current is None:
            self._open[key] = [sample]
            self._spans.setdefault(key, Counter())
            return
        last = current[-1].sample.triangle
        triangle = ident & 0xF
        if triangle == last:  # the same triangle again: a stray pair
            self._stray_frame(ident, FRAMES_PER_TRIANGLE)
            return
        if triangle < last:
            self._close(key)
            self._open[key] = [sample]
            return
        current.append(sample)

    def _close(self, key: int) -> None:
        triangles = self._open.pop(key)
        b = BoardSample(key & 0xF, key >> 4, tuple(triangles))
        self._spans[key][b.span, b.contiguous] += 1
        if self._on_board_sample is not None:
            self._on_board_sample(b)

    def finish(self) -> FrameCounts:
        """End of stream: heads still waiting for their tail become orphans, open board samples
        close; returns the counts (with :attr:`FrameCounts.boards`)."""
        if not self._finished:
            self._orphan_heads += len(self._pending)
            for ident in self._pending:
                self._stray_frame(ident)
            self._pending.clear()
            for key in sorted(self._open, key=lambda k: self._open[k][0].time_ns):
                self._close(key)
            self._finished = True
            spans: Counter[int] = Counter()
            for c in self._spans.values():
                for (span, contiguous), n in c.items():
                    if contiguous:
                        spans[span] += n
            self._triangles = max(spans, key=lambda t: (spans[t], t)) if spans else 0
            counts = []
            for key in sorted(self._spans.keys() | self._stray.keys(), key=lambda k: (k & 0xF, k)):
                c = self._spans.get(key, Counter())
                complete = c[self._triangles, True]
                stray = self._stray.get(key, Counter())
                counts.append(
                    BoardCounts(
                        key & 0xF,
                        key >> 4,
                        complete,
                        sum(c.values()) - complete,
                        tuple(IdCount(i, False, n) for i, n in sorted(stray.items())),
                    )
                )
            self._board_counts = tuple(counts)
        return self.counts

    @property
    def counts(self) -> FrameCounts:
        """The counts so far (pending heads and open board samples count from :meth:`finish`)."""
        return FrameCounts(
            frames=self._n,
            sample_frames=self._sample_frames,
            orphan_heads=self._orphan_heads,
            orphan_tails=self._orphan_tails,
            malformed=self._malformed_count,
            other=sum(self._other_ids.values()),
            error_frames=self._error_frames,
            other_ids=tuple(
                IdCount(i, e, n)
                for (i, e), n in sorted(self._other_ids.items(), key=lambda kv: (-kv[1], kv[0]))
            ),
            triangles=self._triangles,
            boards=self._board_counts,
        )

    @property
    def malformed(self) -> tuple[Malformed, ...]:
        """Frames with a skin identifier that were not a valid head or tail (the first
        :data:`MAX_LISTED_MALFORMED`; :attr:`FrameCounts.malformed` counts them all)."""
        return tuple(self._malformed)


def _timed(time_ns: int, sample: TriangleSample, end_time_ns: int) -> TimedSample:
    """``TimedSample(time_ns, sample, end_time_ns)`` without the call of the frozen ``__init__``
    (the reassembler's hot path; the fields are the same)."""
    timed = object.__new__(TimedSample)
    set_field = object.__setattr__
    set_field(timed, "time_ns", time_ns)
    set_field(timed, "sample", sample)
    set_field(timed, "end_time_ns", end_time_ns)
    return timed


def sample_frames(samples: Iterable[TimedSample]) -> list[CanFrame]:
    """The head and tail :class:`CanFrame` of every sample, ordered by time (stable), ready to be
    written as a trace."""
    frames = [f for s in samples for f in s.can_frames()]
    frames.sort(key=lambda f: f.time_ns)
    return frames


def reassemble(
    frames: Iterable[CanFrame | tuple[int, int, bytes]],
    *,
    boards: Iterable[int] | None = None,
    skin_classes: Iterable[int] = (SKIN_CLASS,),
) -> Reassembly:
    """Samples from a whole stream of frames or of ``(time_ns, arbitration_id, data)`` triples.

    Tuples stand for 11-bit data frames. See :class:`Reassembler` for the options.
    """
    r = Reassembler(boards=boards, skin_classes=skin_classes)
    samples: list[TimedSample] = []
    for f in frames:
        frame = f if isinstance(f, CanFrame) else CanFrame(f[1], bytes(f[2]), time_ns=f[0])
        s = r.feed(frame)
        if s is not None:
            samples.append(s)
    counts = r.finish()
    return Reassembly(tuple(samples), counts, r.malformed)
