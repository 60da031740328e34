"""A board's sample as CAN frames: (T, 12) taxels <-> 2T frames, one board or n samples at once.

:func:`encode_board` and :func:`decode_board` go through :class:`TriangleSample` and
:class:`SkinFrame` frame by frame; :func:`pack_frames` and :func:`unpack_frames` are the numpy
path for long traces, byte-identical to them (tested with hypothesis).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence

import numpy as np
import numpy.typing as npt

from skinframes.canbus.codec import (
    FRAMES_PER_TRIANGLE,
    HEAD_MARKER,
    HEAD_TAXELS,
    MAX_ERROR,
    MAX_OUT_OF_RANGE,
    SKIN_CLASS,
    SKIN_DLC,
    TAIL_MARKER,
    TAIL_TAXELS,
    Part,
    SkinFrame,
    TriangleSample,
)
from skinframes.errors import (
    FieldRangeError,
    InvalidFieldError,
    LengthMismatchError,
    TruncatedError,
)
from skinframes.taxel import NO_LOAD, TAXELS_PER_TRIANGLE, TRIANGLES_PER_PATCH


# --- one board's sample, frame by frame ----------------------------------------------------------
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


def idle_board(board: int, skin_class: int = SKIN_CLASS) -> list[tuple[int, bytes]]:
    """The 32 frames of an untouched board (every taxel at the no-load value 0xF0)."""
    return encode_board(
        board,
        np.full((TRIANGLES_PER_PATCH, TAXELS_PER_TRIANGLE), NO_LOAD, dtype=np.uint8),
        skin_class=skin_class,
    )


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
