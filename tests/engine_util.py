"""Helpers for the engine tests: run into memory, group records by cycle, check the link rules."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from emulator.model.params import TimingParams
from emulator.net.result import SimResult
from emulator.net.run import MemorySink

Rec = tuple[int, int, bool, bytes, str | None]  # time_ps, port, outbound, frame, comment


def records(fn: Callable[..., SimResult], *args: Any, **kw: Any) -> tuple[SimResult, list[Rec]]:
    """Run ``fn`` (simulate_ecat / simulate_epl) into memory: the result and every record."""
    sink = MemorySink()
    result = fn(*args, sink=sink, **kw)
    return result, sink.records


def by_cycle(result: SimResult, recs: list[Rec]) -> list[list[Rec]]:
    """Records cycle by cycle (fault-free runs: the same number of records every cycle)."""
    per = len(recs) // result.cycles
    assert per * result.cycles == len(recs)
    return [recs[c * per : (c + 1) * per] for c in range(result.cycles)]


def assert_gaps(recs: list[Rec], params: TimingParams, gap_ps: int) -> None:
    """Frames of one direction of one master port start ``gap_ps`` after the previous one ends."""
    end: dict[tuple[int, bool], int] = {}
    for t, port, out, frame, _ in recs:
        key = (port, out)
        assert t >= end.get(key, -(10**18)) + gap_ps, (t, key)
        end[key] = t + params.frame_ps(len(frame))
