"""Board samples: the per-board report of the Reassembler, and the cycles convert/compare carry.

The expected values are counted by hand from the log of tests/can_hand_log.py (its docstring
lists the faults put in on purpose).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from can_hand_log import PERIOD_NS, TRIANGLES, hand_built_frames, hand_built_log, taxels_of

from emulator.compare import read_skin_samples, samples_of
from skinframes.canbus import IdCount, Reassembler, reassemble
from skinframes.canbus.log import read_can_log
from skinframes.taxel import NO_LOAD


def test_reassembly_reports_every_board_by_hand() -> None:
    r = reassemble(hand_built_frames())
    c = r.counts
    assert c.frames == 3 * 2 * TRIANGLES * 2 - 1 + 2 + 2 == 51
    assert (c.orphan_heads, c.orphan_tails, c.malformed, c.other) == (1, 0, 0, 0)
    assert c.sample_frames == 50 and c.accounted
    assert c.triangles == TRIANGLES
    by_board = {b.board: b for b in c.boards}
    assert sorted(by_board) == [10, 13, 14]
    assert (by_board[10].complete, by_board[10].incomplete, by_board[10].stray) == (0, 1, ())
    assert (by_board[13].complete, by_board[13].incomplete) == (2, 1)
    assert by_board[13].stray == (IdCount(0x4D2, False, 1),)
    assert (by_board[14].complete, by_board[14].incomplete) == (3, 0)
    assert by_board[14].stray == (IdCount(0x4E1, False, 2),)
    assert by_board[14].to_json() == {
        "board": 14,
        "skin_class": 4,
        "complete": 3,
        "incomplete": 0,
        "stray_frames": 2,
        "stray_ids": {"0x4e1": 2},
    }


def test_board_samples_come_out_as_they_close() -> None:
    closed = []
    r = Reassembler(on_board_sample=closed.append)
    for f in hand_built_frames():
        r.feed(f)
    assert len(closed) == 4  # board 13's and 14's samples of periods 0 and 1 (the next began)
    r.finish()
    assert len(closed) == 3 + 3 + 1
    assert [b.board for b in closed if b.board == 13 and not b.is_complete(TRIANGLES)] == [13]
    spans = sorted((b.board, [t.sample.triangle for t in b.triangles]) for b in closed)
    assert (13, [0, 1, 3]) in spans and (10, [0]) in spans


def test_every_complete_sample_is_kept_and_the_rest_said(tmp_path: Path) -> None:
    path = hand_built_log(tmp_path)
    for s in (read_skin_samples(path), samples_of(read_can_log(path))):
        assert s.boards == (13, 14)  # no phantom board 10
        assert s.samples == 3 and s.triangles == TRIANGLES
        assert abs(s.period_ps - PERIOD_NS * 1000) < 1_000_000_000  # within 1 ms: frames shift
        want = np.full((3, 2, TRIANGLES, 12), NO_LOAD, dtype=np.uint8)
        for period in range(3):
            for i, board in enumerate((13, 14)):
                if (period, board) == (1, 13):
                    continue  # incomplete: left out, the cycle carries no-load taxels
                for t in range(TRIANGLES):
                    want[period, i, t] = taxels_of(board, period, t)
        assert np.array_equal(s.taxels, want.reshape(3, 2, -1))
        lo = s.left_out
        assert (lo.incomplete_samples, lo.stray_frames) == (2, 3)
        assert lo.boards_without_sample == (10,)
        assert lo.missing == ((13, 1),)
        assert lo.to_json()["cycles_missing_board"] == {"13": 1}
        assert "2 incomplete board samples" in lo.text()
