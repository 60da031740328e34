"""analyze_capture keeps state per node and 8 bytes per measured value, not an object per frame.

tracemalloc counts the bytes Python allocates (not time, so the machine's load does not
matter): ten times the cycles may cost at most a few bytes more per frame, far less than any
Python object kept per frame (a list slot and an int alone take 36 bytes).
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Iterator

from skinframes import powerlink
from skinframes.analysis import analyze_capture
from skinframes.pcap import LINKTYPE_ETHERNET, Record

CYCLE_NS = 1_000_000
FRAMES_PER_CYCLE = 2 + 2 * 3  # SoC, SoA and a PReq and PRes for each of 3 CNs
MAX_BYTES_PER_FRAME = 16  # int64 arrays that double: 2 x 8 bytes per value at worst


def records(cycles: int) -> Iterator[Record]:
    soc = powerlink.frame(powerlink.SoC()).to_bytes()
    soa = powerlink.frame(powerlink.SoA()).to_bytes()
    preq = [powerlink.frame(powerlink.PReq(n)).to_bytes() for n in (1, 2, 3)]
    pres = [powerlink.frame(powerlink.PRes(n, bytes(16))).to_bytes() for n in (1, 2, 3)]
    index = 0
    for c in range(cycles):
        t = c * CYCLE_NS
        frames = [soc]
        for q, s in zip(preq, pres, strict=True):
            frames += [q, s]
        frames.append(soa)
        for k, data in enumerate(frames):
            yield Record(index, t + 10_000 * k + (c % 7), data, LINKTYPE_ETHERNET, len(data))
            index += 1


def peak_bytes(cycles: int) -> int:
    tracemalloc.start()
    try:
        analysis = analyze_capture(records(cycles))
        assert analysis.epl is not None and analysis.epl.soc_period.count == cycles - 1
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_memory_grows_by_bytes_per_frame_not_objects() -> None:
    small, large = 1_000, 8_000
    peak_bytes(small)  # warm up: imports, enum caches
    growth = peak_bytes(large) - peak_bytes(small)
    frames = (large - small) * FRAMES_PER_CYCLE
    assert growth < MAX_BYTES_PER_FRAME * frames, f"{growth / frames:.1f} bytes per frame"
