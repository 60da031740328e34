"""A hand-built skin CAN log with known faults (tests of board samples, convert and compare).

4 triangles per board, boards 13 and 14, three 50 ms periods, with three faults put in on purpose:

- period 1, board 13: the tail of triangle 2 is lost, so its head is an orphan (replaced by the
  head of period 2) and board 13's sample of period 1 is {0, 1, 3}: incomplete;
- period 1: a stray pair of board 10, triangle 0 (0x4A0) between the boards: board 10's only
  sample is {0}, incomplete (T = 4), and board 10 has no complete sample;
- period 2, board 14: triangle 1 twice in a row: a stray pair (0x4E1, 2 frames).
"""

from __future__ import annotations

from pathlib import Path

from skinframes.canbus import CanFrame, TriangleSample
from skinframes.canbus.log import write_can_log

PERIOD_NS = 50_000_000
SLOT_NS = 130_000
TRIANGLES = 4


def taxels_of(board: int, period: int, triangle: int) -> list[int]:
    return [(board * 16 + period * 4 + triangle + k) % 200 for k in range(12)]


def hand_built_frames() -> list[CanFrame]:
    """The log of the module docstring, in time order."""
    out: list[tuple[int, bytes]] = []

    def pair(board: int, period: int, triangle: int) -> list[tuple[int, bytes]]:
        s = TriangleSample(board, triangle, taxels_of(board, period, triangle))
        return list(s.can_frames())

    for period in range(3):
        frames: list[tuple[int, bytes]] = []
        for board in (13, 14):
            for t in range(TRIANGLES):
                head, tail = pair(board, period, t)
                if (period, board, t) == (1, 13, 2):
                    frames.append(head)  # the tail is lost
                    continue
                frames += [head, tail]
                if (period, board, t) == (2, 14, 1):
                    frames += [head, tail]  # the same triangle again
            if (period, board) == (1, 13):
                frames += pair(10, period, 0)  # a stray pair of a board that is not there
        out += [(period * PERIOD_NS + k * SLOT_NS, f) for k, f in enumerate(frames)]
    return [CanFrame(ident, data, time_ns=t) for t, (ident, data) in out]


def hand_built_log(folder: Path, suffix: str = ".log") -> Path:
    path = folder / f"hand_built{suffix}"
    write_can_log(path, hand_built_frames())
    return path
