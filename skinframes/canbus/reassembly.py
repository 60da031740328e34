"""Skin samples from a stream of CAN frames: :class:`Reassembler` pairs heads with tails and
accounts for every other frame (:class:`FrameCounts`); :func:`reassemble` runs it over a stream."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass

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
    """

    frames: int = 0
    sample_frames: int = 0
    orphan_heads: int = 0
    orphan_tails: int = 0
    malformed: int = 0
    other: int = 0
    error_frames: int = 0
    other_ids: tuple[IdCount, ...] = ()

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
    """Pair head and tail frames per (class, board, triangle) into :class:`TimedSample`.

    The host does the same (``CanBusSkin.cpp`` L633-644), keyed by identifier, so frames of
    several boards may interleave on the bus. Nothing raises: frames that are not skin data are
    counted (:class:`FrameCounts`), malformed skin frames are listed with their reason.

    Args:
        boards: accept only these board addresses (as ``CanBusSkin`` filters on its configured
            ``skinCanIds``); ``None`` accepts 0..15. Class 3 is shared with other analog sensors,
            so give the boards when decoding a legacy-configuration bus.
        skin_classes: identifier classes that carry skin data (default: class 4 only).

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
        self._n = 0
        self._sample_frames = 0
        self._orphan_heads = 0
        self._orphan_tails = 0
        self._error_frames = 0
        self._finished = False

    def _is_skin_id(self, ident: int) -> bool:
        if ident >> 8 not in self._classes:
            return False
        return self._boards is None or (ident >> 4) & 0xF in self._boards

    def feed(self, frame: CanFrame) -> TimedSample | None:
        """Take one frame; returns a sample when ``frame`` completes one."""
        index = self._n
        self._n += 1
        if frame.error:
            self._error_frames += 1
            return None
        ident = frame.arbitration_id
        if frame.extended or frame.remote or frame.fd or not self._is_skin_id(ident):
            self._other_ids[ident, frame.extended] += 1
            return None
        data = frame.data
        if len(data) != SKIN_DLC or frame.dlc not in (None, SKIN_DLC):
            reason = f"DLC {frame.dlc_field}, skin frames have 8 data bytes"
            self._malformed.append(Malformed(index, frame.time_ns, ident, reason))
            return None
        marker = data[0]
        if marker == HEAD_MARKER:
            if ident in self._pending:
                self._orphan_heads += 1
            self._pending[ident] = (frame.time_ns, bytes(data))
            return None
        if marker != TAIL_MARKER:
            reason = f"byte 0 is {marker:#04x}, expected 0x40 (head) or 0xc0 (tail)"
            self._malformed.append(Malformed(index, frame.time_ns, ident, reason))
            return None
        head = self._pending.pop(ident, None)
        if head is None:
            self._orphan_tails += 1
            return None
        self._sample_frames += FRAMES_PER_TRIANGLE
        sample = TriangleSample._from_data(ident, head[1], data)
        return TimedSample(head[0], sample, frame.time_ns)

    def finish(self) -> FrameCounts:
        """End of stream: heads still waiting for their tail become orphans; returns the counts."""
        if not self._finished:
            self._orphan_heads += len(self._pending)
            self._pending.clear()
            self._finished = True
        return self.counts

    @property
    def counts(self) -> FrameCounts:
        """The counts so far (pending heads are not counted until :meth:`finish`)."""
        return FrameCounts(
            frames=self._n,
            sample_frames=self._sample_frames,
            orphan_heads=self._orphan_heads,
            orphan_tails=self._orphan_tails,
            malformed=len(self._malformed),
            other=sum(self._other_ids.values()),
            error_frames=self._error_frames,
            other_ids=tuple(
                IdCount(i, e, n)
                for (i, e), n in sorted(self._other_ids.items(), key=lambda kv: (-kv[1], kv[0]))
            ),
        )

    @property
    def malformed(self) -> tuple[Malformed, ...]:
        """Frames with a skin identifier that were not a valid head or tail."""
        return tuple(self._malformed)


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
