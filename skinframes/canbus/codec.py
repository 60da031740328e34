"""The skin's CAN messages: identifiers, the head and tail frames of a triangle, their codec.

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

The construct schemas are the layout of record; :class:`SkinFrame` builds and parses with them.
:class:`TriangleSample` writes and reads both frames on a ``bytes`` fast path (``can_frames``,
``_from_data``), which tests prove equal to the schemas.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass
from enum import IntEnum, IntFlag
from typing import Final

import construct as cs
import numpy as np
import numpy.typing as npt

from skinframes.canbus.wire import MAX_SFF_ID, check_range
from skinframes.errors import (
    FieldRangeError,
    InvalidFieldError,
    LengthMismatchError,
    decoding,
    encoding,
)
from skinframes.taxel import TAXELS_PER_TRIANGLE, TRIANGLES_PER_PATCH

# --- skin protocol constants (can.md 1.1-1.5) ----------------------------------------------------
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


# --- construct schemas: the reference layout -----------------------------------------------------
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


# --- identifiers ---------------------------------------------------------------------------------
def skin_id(board: int, triangle: int, skin_class: int = SKIN_CLASS) -> int:
    """The 11-bit identifier ``class << 8 | board << 4 | triangle`` (board 1, triangle 0 -> 0x410).

    Raises:
        FieldRangeError: a field does not fit its width (class 3 bits, board and triangle 4 bits).
    """
    _check_address(skin_class, board, triangle)
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
    check_range("triangles", triangles, TRIANGLES_PER_PATCH)
    base = skin_id(board, 0, skin_class)
    return np.repeat(np.arange(base, base + triangles, dtype=np.uint16), FRAMES_PER_TRIANGLE)


def _check_address(skin_class: int, board: int, triangle: int) -> None:
    """The three identifier fields fit their widths (class 3 bits, board and triangle 4 bits)."""
    check_range("skin_class", skin_class, MAX_CLASS)
    check_range("board", board, MAX_BOARD)
    check_range("triangle", triangle, TRIANGLES_PER_PATCH - 1)


def _taxel_tuple(values: Iterable[int], count: int, what: str) -> tuple[int, ...]:
    out = tuple(int(v) for v in values)
    if len(out) != count:
        raise FieldRangeError(f"{what}: {len(out)} taxels, expected {count}", field="taxels")
    for k, v in enumerate(out):
        if not 0 <= v <= 0xFF:
            raise FieldRangeError(f"{what}: taxel {k} = {v} is outside 0..255", field="taxels")
    return out


# --- messages ------------------------------------------------------------------------------------
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
        _check_address(self.skin_class, self.board, self.triangle)
        try:
            part = Part(self.part)
        except ValueError:
            raise FieldRangeError(
                f"part {self.part!r}: expected 0x40 (head) or 0xC0 (tail)", field="part"
            ) from None
        object.__setattr__(self, "part", part)
        count = HEAD_TAXELS if part is Part.HEAD else TAIL_TAXELS
        object.__setattr__(self, "taxels", _taxel_tuple(self.taxels, count, f"skin {part.name}"))
        check_range("out_of_range", self.out_of_range, MAX_OUT_OF_RANGE)
        check_range("error", self.error, MAX_ERROR)
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
        _check_address(self.skin_class, self.board, self.triangle)
        object.__setattr__(
            self, "taxels", _taxel_tuple(self.taxels, TAXELS_PER_TRIANGLE, "triangle sample")
        )
        check_range("out_of_range", self.out_of_range, MAX_OUT_OF_RANGE)
        check_range("error", self.error, MAX_ERROR)

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

    @classmethod
    def _from_data(cls, arbitration_id: int, head: bytes, tail: bytes) -> TriangleSample:
        """The sample in the data of a head and a tail whose DLC and markers are checked (the
        fast path of :meth:`from_can` for :class:`~skinframes.canbus.Reassembler`)."""
        if not 0 <= arbitration_id <= MAX_SFF_ID:
            parse_skin_id(arbitration_id)  # raises
        # every field comes from a bit field of its width or a byte: the checks of __init__ hold
        sample = object.__new__(cls)
        set_field = object.__setattr__
        set_field(sample, "board", arbitration_id >> 4 & 0xF)
        set_field(sample, "triangle", arbitration_id & 0xF)
        set_field(sample, "taxels", tuple(head[1 : 1 + HEAD_TAXELS] + tail[1 : 1 + TAIL_TAXELS]))
        set_field(sample, "out_of_range", tail[6] << 4 | tail[7] >> 4)
        set_field(sample, "error", tail[7] & 0xF)
        set_field(sample, "skin_class", arbitration_id >> 8)
        return sample


# --- fast path: the two frames as bytes, equal to the schemas (tested with hypothesis) -----------
def _pack_head(taxels: Sequence[int]) -> bytes:
    """The head's data (``_head_schema``)."""
    return bytes((HEAD_MARKER, *taxels[:HEAD_TAXELS]))


def _pack_tail(taxels: Sequence[int], out_of_range: int, error: int) -> bytes:
    """The tail's data (``_tail_schema``)."""
    return bytes(
        (
            TAIL_MARKER,
            *taxels[HEAD_TAXELS:TAXELS_PER_TRIANGLE],
            out_of_range >> 4,
            (out_of_range & 0xF) << 4 | error,
        )
    )


def _unpack(head: bytes, tail: bytes) -> tuple[tuple[int, ...], int, int]:
    """Taxels, out-of-range bits and error nibble of a head and a tail (markers not checked)."""
    taxels = tuple(head[1 : 1 + HEAD_TAXELS] + tail[1 : 1 + TAIL_TAXELS])
    return taxels, tail[6] << 4 | tail[7] >> 4, tail[7] & 0xF
