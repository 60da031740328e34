"""The iCub skin's legacy CAN frames: identifiers, head/tail payloads, reassembly, DBC.

Sources (see ../shared/reference/can.md, sections 1-2, for the full evidence):

- Identifier, 11 bits: ``class << 8 | board << 4 | triangle`` (TSD-ICUBUNIT-canprotocol-sensorboards
  section 2; icub-firmware-shared ``iCubCanProto_classes.h`` L49-56; mtb3 ``main_V3.c`` L995-1004;
  icub-main ``CanBusSkin.cpp`` L163-177, L614-616). Class 4 (``PERIODIC_SKIN``) with the "new"
  board configuration, class 3 (``PERIODIC_ANALOGSENSOR``) with the legacy 0x4C configuration.
- Payload: two 8-byte frames per triangle and sample (mtb3 ``main_V3.c`` L1006-1020; mtb4
  ``embot_prot_can_skin_periodic.cpp`` L78-111; protocol doc section 4.3)::

      head  [0x40][P0][P1][P2][P3][P4][P5][P6]
      tail  [0xC0][P7][P8][P9][P10][P11][OOR 11..4][OOR 3..0 << 4 | error]

  OOR: 12 out-of-range bits, one per taxel; error: 0 ok, 1 no-ack, 2 not connected.
- Taxel values are 8-bit and inverted (no load ~0xF0, pressure lowers them): ``skinframes.taxel``.
- Bit rate 1 Mbit/s, firmware period 50 ms by default, 2 frames per enabled triangle (can.md 1.5).

The public model is frozen dataclasses: :class:`SkinFrame` (one CAN frame, half a triangle),
:class:`TriangleSample` (12 taxels + status of one triangle) and :class:`TimedSample`.
:class:`Reassembler` pairs heads and tails from a stream of :class:`CanFrame` and counts (never
raises on) what is not skin data. The exact length of any classic CAN frame on the wire
(:func:`frame_bits`, :func:`worst_case_bits`, ...) and :class:`CanFrame` live in
:mod:`skinframes.canwire` and are re-exported here. Trace files (python-can formats, SocketCAN
pcap) are in :mod:`skinframes.cantrace`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass
from enum import IntEnum, IntFlag
from typing import Final

import construct as cs
import numpy as np
import numpy.typing as npt

from skinframes.canwire import (
    CAN_EFF_FLAG,
    CAN_ERR_FLAG,
    CAN_RTR_FLAG,
    MAX_SFF_ID,
    SOCKETCAN_MTU,
    CanFrame,
    crc15,
    frame_bits,
    frame_bits_batch,
    stuff_bits,
    unstuffed_bits,
    worst_case_bits,
)
from skinframes.errors import (
    FieldRangeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
    decoding,
    encoding,
)
from skinframes.taxel import NO_LOAD, TAXELS_PER_TRIANGLE, TRIANGLES_PER_PATCH

__all__ = [
    "BITRATE_BPS",
    "CAN_EFF_FLAG",
    "CAN_ERR_FLAG",
    "CAN_RTR_FLAG",
    "DEFAULT_PERIOD_MS",
    "FRAMES_PER_BOARD",
    "HEAD_MARKER",
    "LEGACY_SKIN_CLASS",
    "MAX_BOARD",
    "SKIN_CLASS",
    "SKIN_DLC",
    "SOCKETCAN_MTU",
    "TAIL_MARKER",
    "CanFrame",
    "FrameCounts",
    "IdCount",
    "Malformed",
    "Part",
    "Reassembler",
    "Reassembly",
    "SensorError",
    "SkinFrame",
    "TimedSample",
    "TriangleSample",
    "board_ids",
    "crc15",
    "dbc_text",
    "decode_board",
    "encode_board",
    "frame_bits",
    "frame_bits_batch",
    "idle_board",
    "pack_frames",
    "parse_skin_id",
    "reassemble",
    "sample_frames",
    "skin_id",
    "stuff_bits",
    "unpack_frames",
    "unstuffed_bits",
    "worst_case_bits",
]

# --- skin protocol constants (can.md 1.1-1.5) ------------------------------------------------------
SKIN_CLASS: Final = 4  # ICUBCANPROTO_CLASS_PERIODIC_SKIN, iCubCanProto_classes.h L53
LEGACY_SKIN_CLASS: Final = 3  # ICUBCANPROTO_CLASS_PERIODIC_ANALOGSENSOR (legacy 0x4C config)
MAX_CLASS: Final = 7  # 3-bit class field
MAX_BOARD: Final = 15  # 4-bit source address; boards use 1..14, the host is 0
HEAD_MARKER: Final = 0x40  # byte 0 of the first frame of a triangle (main_V3.c L1006)
TAIL_MARKER: Final = 0xC0  # byte 0 of the second frame (main_V3.c L1013)
SKIN_DLC: Final = 8  # both frames are sent with DLC 8 (CAN1_send(PMsgID, 1, 8, data))
HEAD_TAXELS: Final = 7  # P0..P6
TAIL_TAXELS: Final = TAXELS_PER_TRIANGLE - HEAD_TAXELS  # P7..P11
OUT_OF_RANGE_BITS: Final = TAXELS_PER_TRIANGLE  # one flag per taxel
MAX_OUT_OF_RANGE: Final = (1 << OUT_OF_RANGE_BITS) - 1
ERROR_BITS: Final = 4
MAX_ERROR: Final = (1 << ERROR_BITS) - 1
FRAMES_PER_TRIANGLE: Final = 2
FRAMES_PER_BOARD: Final = FRAMES_PER_TRIANGLE * TRIANGLES_PER_PATCH  # 32
BITRATE_BPS: Final = 1_000_000  # protocol doc section 2; CanBusSkin.cpp L122
DEFAULT_PERIOD_MS: Final = 50  # mtb3 options.h L22, mtb4 theSkin.cpp L155, robot configs


class Part(IntEnum):
    """Byte 0 of a skin frame: which half of the triangle it carries."""

    HEAD = HEAD_MARKER
    TAIL = TAIL_MARKER


class SensorError(IntFlag):
    """The tail's error nibble (mtb3 ``enum Errors`` L139-144; mtb4 bit 0 no-ack, bit 1 not connected)."""

    OK = 0
    NOACK = 1  # the AD7147 did not acknowledge on I2C
    NOT_CONNECTED = 2


# --- construct schemas: the reference layout ------------------------------------------------------
_head_schema = cs.Struct(
    "marker" / cs.Const(HEAD_MARKER, cs.Int8ub),
    "taxels" / cs.Array(HEAD_TAXELS, cs.Int8ub),  # P0..P6
)
_tail_schema = cs.Struct(
    "marker" / cs.Const(TAIL_MARKER, cs.Int8ub),
    "taxels" / cs.Array(TAIL_TAXELS, cs.Int8ub),  # P7..P11
    "status"
    / cs.BitStruct(  # bytes 6-7, MSB first: OOR bits 11..0, then the error nibble
        "out_of_range" / cs.BitsInteger(OUT_OF_RANGE_BITS),
        "error" / cs.BitsInteger(ERROR_BITS),
    ),
)


# --- identifiers -----------------------------------------------------------------------------------
def skin_id(board: int, triangle: int, skin_class: int = SKIN_CLASS) -> int:
    """The 11-bit identifier ``class << 8 | board << 4 | triangle`` (board 1, triangle 0 -> 0x410).

    Raises:
        FieldRangeError: a field does not fit its width (class 3 bits, board and triangle 4 bits).
    """
    _check_range("skin_class", skin_class, MAX_CLASS)
    _check_range("board", board, MAX_BOARD)
    _check_range("triangle", triangle, TRIANGLES_PER_PATCH - 1)
    return skin_class << 8 | board << 4 | triangle


def parse_skin_id(arbitration_id: int) -> tuple[int, int, int]:
    """``(skin_class, board, triangle)`` of an 11-bit identifier (no check that it is skin data).

    Raises:
        InvalidFieldError: not an 11-bit identifier.
    """
    if not 0 <= arbitration_id <= MAX_SFF_ID:
        raise InvalidFieldError(
            f"CAN id {arbitration_id:#x}: skin identifiers are 11 bits", field="arbitration_id"
        )
    return arbitration_id >> 8, (arbitration_id >> 4) & 0xF, arbitration_id & 0xF


def board_ids(
    board: int, triangles: int = TRIANGLES_PER_PATCH, skin_class: int = SKIN_CLASS
) -> npt.NDArray[np.uint16]:
    """Identifiers of the ``2 * triangles`` frames of one board's sample, in transmit order."""
    _check_range("triangles", triangles, TRIANGLES_PER_PATCH)
    base = skin_id(board, 0, skin_class)
    return np.repeat(np.arange(base, base + triangles, dtype=np.uint16), FRAMES_PER_TRIANGLE)


def _check_range(name: str, value: int, high: int, low: int = 0) -> None:
    if not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an int, not {type(value).__name__}")
    if not low <= value <= high:
        raise FieldRangeError(f"{name}={value} is outside {low}..{high}", field=name)


def _taxel_tuple(values: Iterable[int], count: int, what: str) -> tuple[int, ...]:
    out = tuple(int(v) for v in values)
    if len(out) != count:
        raise FieldRangeError(f"{what}: {len(out)} taxels, expected {count}", field="taxels")
    for k, v in enumerate(out):
        if not 0 <= v <= 0xFF:
            raise FieldRangeError(f"{what}: taxel {k} = {v} is outside 0..255", field="taxels")
    return out


# --- dataclasses -----------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class SkinFrame:
    """One skin CAN frame: the head (taxels 0-6) or the tail (taxels 7-11 + status) of a triangle.

    can.md 1.2; mtb3 ``main_V3.c`` L1006-1020. ``out_of_range`` and ``error`` exist on the tail
    only and must be 0 on a head. Values are checked on construction.
    """

    board: int
    triangle: int
    part: Part
    taxels: tuple[int, ...]
    out_of_range: int = 0
    error: int = 0
    skin_class: int = SKIN_CLASS

    def __post_init__(self) -> None:
        _check_range("skin_class", self.skin_class, MAX_CLASS)
        _check_range("board", self.board, MAX_BOARD)
        _check_range("triangle", self.triangle, TRIANGLES_PER_PATCH - 1)
        try:
            part = Part(self.part)
        except ValueError:
            raise FieldRangeError(
                f"part {self.part!r}: expected 0x40 (head) or 0xC0 (tail)", field="part"
            ) from None
        object.__setattr__(self, "part", part)
        count = HEAD_TAXELS if part is Part.HEAD else TAIL_TAXELS
        object.__setattr__(self, "taxels", _taxel_tuple(self.taxels, count, f"skin {part.name}"))
        _check_range("out_of_range", self.out_of_range, MAX_OUT_OF_RANGE)
        _check_range("error", self.error, MAX_ERROR)
        if part is Part.HEAD and (self.out_of_range or self.error):
            raise FieldRangeError("a head frame carries no out-of-range bits nor error nibble")

    @property
    def arbitration_id(self) -> int:
        """The 11-bit CAN identifier."""
        return skin_id(self.board, self.triangle, self.skin_class)

    def to_bytes(self) -> bytes:
        """The 8 data bytes."""
        with encoding(f"skin {self.part.name.lower()} frame"):
            if self.part is Part.HEAD:
                return bytes(_head_schema.build({"taxels": self.taxels}))
            status = {"out_of_range": self.out_of_range, "error": self.error}
            return bytes(_tail_schema.build({"taxels": self.taxels, "status": status}))

    @classmethod
    def from_bytes(
        cls, arbitration_id: int, data: bytes, *, skin_classes: Collection[int] = (3, 4)
    ) -> SkinFrame:
        """Decode one frame strictly (DLC 8, marker 0x40/0xC0, a skin class).

        Raises:
            InvalidFieldError: not an 11-bit id of one of ``skin_classes``, or an unknown marker.
            LengthMismatchError: not 8 data bytes.
        """
        skin_class, board, triangle = parse_skin_id(arbitration_id)
        if skin_class not in skin_classes:
            raise InvalidFieldError(
                f"CAN id {arbitration_id:#05x}: class {skin_class} is not a skin class "
                f"({sorted(skin_classes)})",
                field="arbitration_id",
            )
        if len(data) != SKIN_DLC:
            raise LengthMismatchError(
                f"skin frame {arbitration_id:#05x}: {len(data)} data bytes, expected 8",
                field="dlc",
            )
        marker = data[0]
        with decoding(f"skin frame {arbitration_id:#05x}"):
            if marker == HEAD_MARKER:
                c = _head_schema.parse(data)
                return cls(board, triangle, Part.HEAD, tuple(c.taxels), skin_class=skin_class)
            if marker == TAIL_MARKER:
                c = _tail_schema.parse(data)
                return cls(
                    board,
                    triangle,
                    Part.TAIL,
                    tuple(c.taxels),
                    c.status.out_of_range,
                    c.status.error,
                    skin_class,
                )
        raise InvalidFieldError(
            f"skin frame {arbitration_id:#05x}: byte 0 is {marker:#04x}, expected 0x40 or 0xc0",
            field="marker",
            offset=0,
        )


@dataclass(frozen=True, slots=True)
class TriangleSample:
    """One triangle's sample: 12 taxels, 12 out-of-range bits and the error nibble.

    It travels as two frames (:meth:`frames`); see can.md 1.2. Values are checked on
    construction; ``taxels`` accepts any iterable of 12 ints (a numpy row too) and is stored as a
    tuple.
    """

    board: int
    triangle: int
    taxels: tuple[int, ...]
    out_of_range: int = 0
    error: int = 0
    skin_class: int = SKIN_CLASS

    def __post_init__(self) -> None:
        _check_range("skin_class", self.skin_class, MAX_CLASS)
        _check_range("board", self.board, MAX_BOARD)
        _check_range("triangle", self.triangle, TRIANGLES_PER_PATCH - 1)
        object.__setattr__(
            self, "taxels", _taxel_tuple(self.taxels, TAXELS_PER_TRIANGLE, "triangle sample")
        )
        _check_range("out_of_range", self.out_of_range, MAX_OUT_OF_RANGE)
        _check_range("error", self.error, MAX_ERROR)

    @property
    def arbitration_id(self) -> int:
        """The 11-bit identifier shared by both frames."""
        return skin_id(self.board, self.triangle, self.skin_class)

    def frames(self) -> tuple[SkinFrame, SkinFrame]:
        """The head and tail :class:`SkinFrame`, in transmit order."""
        head = SkinFrame(
            self.board,
            self.triangle,
            Part.HEAD,
            self.taxels[:HEAD_TAXELS],
            skin_class=self.skin_class,
        )
        tail = SkinFrame(
            self.board,
            self.triangle,
            Part.TAIL,
            self.taxels[HEAD_TAXELS:],
            self.out_of_range,
            self.error,
            self.skin_class,
        )
        return head, tail

    def can_frames(self) -> tuple[tuple[int, bytes], tuple[int, bytes]]:
        """``((id, head data), (id, tail data))``: the two DLC-8 frames on the bus."""
        ident = self.arbitration_id
        return (ident, _pack_head(self.taxels)), (
            ident,
            _pack_tail(self.taxels, self.out_of_range, self.error),
        )

    @classmethod
    def from_frames(cls, head: SkinFrame, tail: SkinFrame) -> TriangleSample:
        """Join a head and a tail of the same triangle.

        Raises:
            InvalidFieldError: the parts are not head then tail, or the identifiers differ.
        """
        if head.part is not Part.HEAD or tail.part is not Part.TAIL:
            raise InvalidFieldError(
                f"expected a head and a tail, got {head.part.name} and {tail.part.name}"
            )
        if head.arbitration_id != tail.arbitration_id:
            raise InvalidFieldError(
                f"head {head.arbitration_id:#05x} and tail {tail.arbitration_id:#05x} "
                "belong to different triangles",
                field="arbitration_id",
            )
        return cls(
            head.board,
            head.triangle,
            head.taxels + tail.taxels,
            tail.out_of_range,
            tail.error,
            head.skin_class,
        )

    @classmethod
    def from_can(
        cls,
        head: tuple[int, bytes],
        tail: tuple[int, bytes],
        *,
        skin_classes: Collection[int] = (3, 4),
    ) -> TriangleSample:
        """Decode the ``(id, data)`` pairs of a head and a tail (strict, see :meth:`SkinFrame.from_bytes`)."""
        return cls.from_frames(
            SkinFrame.from_bytes(*head, skin_classes=skin_classes),
            SkinFrame.from_bytes(*tail, skin_classes=skin_classes),
        )


def _pack_head(taxels: Sequence[int]) -> bytes:
    """Fast path of the head layout (equal to ``_head_schema``; tested with hypothesis)."""
    return bytes((HEAD_MARKER, *taxels[:HEAD_TAXELS]))


def _pack_tail(taxels: Sequence[int], out_of_range: int, error: int) -> bytes:
    """Fast path of the tail layout (equal to ``_tail_schema``)."""
    return bytes(
        (
            TAIL_MARKER,
            *taxels[HEAD_TAXELS:TAXELS_PER_TRIANGLE],
            out_of_range >> 4,
            (out_of_range & 0xF) << 4 | error,
        )
    )


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
            _check_range("skin_class", c, MAX_CLASS)
        for b in self._boards or ():
            _check_range("board", b, MAX_BOARD)
        self._pending: dict[int, tuple[int, tuple[int, ...]]] = {}
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
            self._pending[ident] = (frame.time_ns, tuple(data[1:]))
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
        sample = TriangleSample(
            (ident >> 4) & 0xF,
            ident & 0xF,
            head[1] + tuple(data[1 : 1 + TAIL_TAXELS]),
            data[6] << 4 | data[7] >> 4,
            data[7] & 0xF,
            ident >> 8,
        )
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


# --- a board's sample: (T, 12) taxels <-> 2T frames ------------------------------------------------
def encode_board(
    board: int,
    taxels: npt.ArrayLike,
    *,
    skin_class: int = SKIN_CLASS,
    out_of_range: Sequence[int] | None = None,
    errors: Sequence[int] | None = None,
) -> list[tuple[int, bytes]]:
    """The ``2 * T`` frames ``(id, data)`` of one board's sample, triangles 0..T-1 in order.

    Args:
        board: the board's CAN address.
        taxels: (T, 12) values 0..255, T <= 16 (a whole patch: (16, 12) -> 32 frames).
        skin_class: identifier class (4, or 3 for the legacy configuration).
        out_of_range: T 12-bit out-of-range words (default 0).
        errors: T error nibbles (default 0).

    Raises:
        FieldRangeError: wrong shape or a value that does not fit.
    """
    arr = _taxel_array(taxels)
    n = arr.shape[0]
    oor = [0] * n if out_of_range is None else list(out_of_range)
    err = [0] * n if errors is None else list(errors)
    if len(oor) != n or len(err) != n:
        raise FieldRangeError(f"out_of_range/errors: need {n} values, one per triangle")
    out: list[tuple[int, bytes]] = []
    for t in range(n):
        sample = TriangleSample(board, t, arr[t].tolist(), oor[t], err[t], skin_class)
        out.extend(sample.can_frames())
    return out


def decode_board(
    frames: Iterable[tuple[int, bytes]],
    *,
    board: int | None = None,
    skin_classes: Collection[int] = (3, 4),
) -> npt.NDArray[np.uint8]:
    """The (T, 12) taxels of one board's sample from its ``2 * T`` frames (any order of triangles,
    head before tail). Strict: every frame must be a valid skin frame of the same board and class,
    and triangles 0..T-1 must each appear exactly once.

    Raises:
        DecodeError: a frame is not skin data, boards/classes differ, a triangle is missing,
            repeated or incomplete.
    """
    heads: dict[int, SkinFrame] = {}
    samples: dict[int, TriangleSample] = {}
    skin_class: int | None = None
    for k, (ident, data) in enumerate(frames):
        f = SkinFrame.from_bytes(ident, bytes(data), skin_classes=skin_classes)
        if board is not None and f.board != board:
            raise InvalidFieldError(
                f"frame {k}: board {f.board}, expected {board}", field="arbitration_id"
            )
        if skin_class is not None and f.skin_class != skin_class:
            raise InvalidFieldError(
                f"frame {k}: class {f.skin_class}, expected {skin_class}", field="arbitration_id"
            )
        board, skin_class = f.board, f.skin_class
        if f.triangle in samples:
            raise InvalidFieldError(f"frame {k}: triangle {f.triangle} appears twice")
        if f.part is Part.HEAD:
            if f.triangle in heads:
                raise InvalidFieldError(f"frame {k}: second head for triangle {f.triangle}")
            heads[f.triangle] = f
        else:
            head = heads.pop(f.triangle, None)
            if head is None:
                raise InvalidFieldError(f"frame {k}: tail of triangle {f.triangle} without head")
            samples[f.triangle] = TriangleSample.from_frames(head, f)
    if heads:
        raise TruncatedError(f"triangles {sorted(heads)}: head without tail")
    if not samples:
        raise TruncatedError("no skin frames")
    if sorted(samples) != list(range(len(samples))):
        raise InvalidFieldError(
            f"triangles {sorted(samples)}: expected 0..{len(samples) - 1} without gaps"
        )
    return np.array([samples[t].taxels for t in range(len(samples))], dtype=np.uint8)


def _taxel_array(taxels: npt.ArrayLike) -> npt.NDArray[np.int64]:
    arr = np.asarray(taxels)
    if (
        arr.ndim != 2
        or arr.shape[1] != TAXELS_PER_TRIANGLE
        or not 1 <= arr.shape[0] <= TRIANGLES_PER_PATCH
    ):
        raise FieldRangeError(f"taxels: shape {arr.shape}, expected (T, 12) with 1 <= T <= 16")
    if not np.issubdtype(arr.dtype, np.integer):
        raise FieldRangeError(f"taxels: dtype {arr.dtype}, expected integers")
    if arr.min() < 0 or arr.max() > 0xFF:
        raise FieldRangeError("taxels: values must be 0..255")
    return arr.astype(np.int64)


# --- DBC (can.md 4) --------------------------------------------------------------------------------
_DBC_HEADER = """VERSION ""


NS_ :
\tCM_
\tBA_DEF_
\tBA_
\tVAL_

BS_:

"""


def dbc_text(
    boards: Iterable[int],
    skin_class: int = SKIN_CLASS,
    triangles: Iterable[int] = range(TRIANGLES_PER_PATCH),
) -> str:
    """A DBC database of the skin frames of ``boards``: one multiplexed message per triangle.

    Message ``SKIN_B<board>_T<triangle>`` (DLC 8, sender ``MTB<board>``), multiplexer ``PART``
    (byte 0; 64 head, 192 tail), ``P00..P06`` (m64, bytes 1-7), ``P07..P11`` (m192, bytes 1-5),
    ``OUTOFRANGE`` (m192, 12 bits from byte 6) and ``ERR`` (m192, low nibble of byte 7). All
    signals are big-endian (``@0``) with DBC's MSB start bits. cantools loads it; decoded values
    equal :class:`SkinFrame`'s.

    Raises:
        FieldRangeError: a board, triangle or class out of range; no boards.
    """
    board_list = sorted({int(b) for b in boards})
    tri_list = sorted({int(t) for t in triangles})
    if not board_list or not tri_list:
        raise FieldRangeError("dbc_text: need at least one board and one triangle")
    _check_range("skin_class", skin_class, MAX_CLASS)
    nodes = " ".join(["HOST", *(f"MTB{b:02d}" for b in board_list)])
    lines = [_DBC_HEADER + f"BU_: {nodes}\n\n"]
    comments: list[str] = []
    values: list[str] = []
    sig = ' (1,0) [0|{high}] "" HOST'
    for b in board_list:
        for t in tri_list:
            ident = skin_id(b, t, skin_class)
            lines.append(f"BO_ {ident} SKIN_B{b:02d}_T{t:02d}: 8 MTB{b:02d}\n")
            lines.append(" SG_ PART M : 7|8@0+" + sig.format(high=255) + "\n")
            for k in range(TAXELS_PER_TRIANGLE):
                mux = HEAD_MARKER if k < HEAD_TAXELS else TAIL_MARKER
                byte = 1 + (k if k < HEAD_TAXELS else k - HEAD_TAXELS)
                lines.append(f" SG_ P{k:02d} m{mux} : {8 * byte + 7}|8@0+" + sig.format(high=255))
                lines.append("\n")
            lines.append(f" SG_ OUTOFRANGE m{TAIL_MARKER} : 55|12@0+" + sig.format(high=4095))
            lines.append(f"\n SG_ ERR m{TAIL_MARKER} : 59|4@0+" + sig.format(high=15) + "\n\n")
            comments.append(
                f'CM_ BO_ {ident} "iCub skin, class {skin_class}, board {b}, triangle {t}: '
                f'head PART=0x40 taxels 0-6, tail PART=0xC0 taxels 7-11 and status";\n'
            )
            values.append(f'VAL_ {ident} PART 64 "HEAD" 192 "TAIL" ;\n')
            values.append(f'VAL_ {ident} ERR 0 "OK" 1 "NOACK" 2 "NOT_CONNECTED" ;\n')
    return "".join(lines) + "\n" + "".join(comments) + "".join(values)


# --- fast paths: numpy ---------------------------------------------------------------------------
def pack_frames(
    taxels: npt.ArrayLike,
    *,
    out_of_range: npt.ArrayLike = 0,
    error: npt.ArrayLike = 0,
) -> npt.NDArray[np.uint8]:
    """(n, T, 12) taxels -> (n, 2T, 8) frame data, head and tail per triangle (see :func:`board_ids`).

    The numpy path of :meth:`TriangleSample.can_frames` for long traces (byte-identical; tested).
    ``out_of_range`` and ``error`` broadcast to (n, T).

    Raises:
        FieldRangeError: wrong shape, or a value out of range (checked before casting).
    """
    arr = np.asarray(taxels)
    if arr.ndim != 3 or arr.shape[2] != TAXELS_PER_TRIANGLE or arr.shape[1] > TRIANGLES_PER_PATCH:
        raise FieldRangeError(f"taxels: shape {arr.shape}, expected (n, T<=16, 12)")
    if arr.size and (arr.min() < 0 or arr.max() > 0xFF):
        raise FieldRangeError("taxels: values must be 0..255")
    n, t = arr.shape[:2]
    oor = np.broadcast_to(np.asarray(out_of_range), (n, t)).astype(np.int64)
    err = np.broadcast_to(np.asarray(error), (n, t)).astype(np.int64)
    if oor.size and (oor.min() < 0 or oor.max() > MAX_OUT_OF_RANGE):
        raise FieldRangeError("out_of_range: values must be 0..4095")
    if err.size and (err.min() < 0 or err.max() > MAX_ERROR):
        raise FieldRangeError("error: values must be 0..15")
    out = np.empty((n, t, FRAMES_PER_TRIANGLE, SKIN_DLC), dtype=np.uint8)
    out[:, :, 0, 0] = HEAD_MARKER
    out[:, :, 0, 1:] = arr[:, :, :HEAD_TAXELS]
    out[:, :, 1, 0] = TAIL_MARKER
    out[:, :, 1, 1 : 1 + TAIL_TAXELS] = arr[:, :, HEAD_TAXELS:]
    out[:, :, 1, 6] = oor >> 4
    out[:, :, 1, 7] = (oor & 0xF) << 4 | err
    return out.reshape(n, t * FRAMES_PER_TRIANGLE, SKIN_DLC)


def unpack_frames(
    frames: npt.ArrayLike,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint16], npt.NDArray[np.uint8]]:
    """(n, 2T, 8) frame data (head, tail per triangle) -> taxels (n, T, 12), out-of-range (n, T)
    and error (n, T): the inverse of :func:`pack_frames` (returns copies).

    Raises:
        InvalidFieldError: a marker byte is not 0x40/0xC0 where a head/tail is expected.
        LengthMismatchError: wrong shape.
    """
    arr = np.asarray(frames, dtype=np.uint8)
    if arr.ndim != 3 or arr.shape[2] != SKIN_DLC or arr.shape[1] % FRAMES_PER_TRIANGLE:
        raise LengthMismatchError(f"frames: shape {arr.shape}, expected (n, 2T, 8)")
    n, f = arr.shape[:2]
    pairs = arr.reshape(n, f // FRAMES_PER_TRIANGLE, FRAMES_PER_TRIANGLE, SKIN_DLC)
    bad = (pairs[:, :, 0, 0] != HEAD_MARKER) | (pairs[:, :, 1, 0] != TAIL_MARKER)
    if bad.any():
        s, t = (int(v) for v in np.argwhere(bad)[0])
        raise InvalidFieldError(
            f"sample {s}, triangle {t}: markers {pairs[s, t, 0, 0]:#04x}/{pairs[s, t, 1, 0]:#04x}, "
            "expected 0x40/0xc0",
            field="marker",
        )
    taxels = np.concatenate([pairs[:, :, 0, 1:], pairs[:, :, 1, 1 : 1 + TAIL_TAXELS]], axis=2)
    oor = (pairs[:, :, 1, 6].astype(np.uint16) << 4) | (pairs[:, :, 1, 7] >> 4)
    err = pairs[:, :, 1, 7] & 0xF
    return np.ascontiguousarray(taxels), oor.astype(np.uint16), err.astype(np.uint8)


def idle_board(board: int, skin_class: int = SKIN_CLASS) -> list[tuple[int, bytes]]:
    """The 32 frames of an untouched board (every taxel at the no-load value 0xF0)."""
    return encode_board(
        board,
        np.full((TRIANGLES_PER_PATCH, TAXELS_PER_TRIANGLE), NO_LOAD, dtype=np.uint8),
        skin_class=skin_class,
    )
