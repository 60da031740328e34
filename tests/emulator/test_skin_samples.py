"""A CAN log's skin samples, grouped into cycles in two passes: the second streams the cycles
while the log is read, whatever the chunk size, and a log must not change between the passes."""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable, Iterable, Iterator

import numpy as np
import pytest

from emulator.model.params import WIRE
from emulator.net import simulate_epl
from emulator.net.can_bus import skin_bus
from emulator.net.run import MemorySink
from emulator.skin_samples import Batch, SkinLog
from skinframes import taxel
from skinframes.canbus import CanFrame
from skinframes.canbus.log import CanLogFormatError, RecordCounts
from skinframes.errors import SkinframesError

BOARDS = [8, 9, 10]
SAMPLES = 40
PERIOD_PS = 50_000_000_000  # 50 ms, the firmware default
PS_PER_NS = 1000


@pytest.fixture(scope="module")
def bus() -> tuple[np.ndarray, list[CanFrame]]:
    taxels = taxel.contact_pattern(len(BOARDS), SAMPLES, seed=5)
    frames, _ = skin_bus(BOARDS, taxels, PERIOD_PS)
    return taxels, frames


class Batches:
    """An opener over ``frames`` in batches of ``size`` that counts the batches handed out."""

    def __init__(self, frames: list[CanFrame], size: int = 50) -> None:
        self.frames, self.size, self.handed = frames, size, 0
        self.batches = -(-len(frames) // size)

    def __call__(self) -> tuple[Iterable[Batch], Callable[[], RecordCounts | None]]:
        self.handed = 0

        def batches() -> Iterator[Batch]:
            for lo in range(0, len(self.frames), self.size):
                self.handed += 1
                yield list(self.frames[lo : lo + self.size])

        return batches(), lambda: None


def test_cycles_come_while_the_log_is_read_and_carry_every_taxel(
    bus: tuple[np.ndarray, list[CanFrame]],
) -> None:
    taxels, frames = bus
    source = Batches(frames)
    log = SkinLog("bus", source)
    assert (log.boards, log.triangles, log.samples) == (tuple(BOARDS), 16, SAMPLES)
    assert log.period_ps == PERIOD_PS
    chunks = log.cycles(chunk=4)
    first = next(chunks)
    assert source.handed < source.batches // 2  # streamed: the log is far from read
    got = [first, *chunks]
    assert [c.first for c in got] == list(range(0, SAMPLES, 4))
    # the taxels as the boards sent them; each cycle starts with its period (skin_bus releases
    # every board's frames at k * P, and the first one takes the idle bus at once)
    assert np.concatenate([c.taxels for c in got]).tobytes() == taxels.tobytes()
    starts = np.concatenate([c.start_ns for c in got])
    assert starts.tolist() == [k * PERIOD_PS // PS_PER_NS for k in range(SAMPLES)]
    per_period = [
        tuple(f for f in frames if k * PERIOD_PS <= f.time_ns * PS_PER_NS < (k + 1) * PERIOD_PS)
        for k in range(SAMPLES)
    ]
    assert [f for c in got for f in c.frames] == per_period


def perturbed(frames: list[CanFrame], seed: int) -> list[CanFrame]:
    """Frames lost, repeated, re-addressed and swapped, and board 10 silent after 60 %."""
    rng = random.Random(seed)
    out: list[CanFrame] = []
    for f in frames:
        r = rng.random()
        if r < 0.01:
            continue
        if r < 0.02:
            out.append(f)
        if r < 0.03:
            f = CanFrame(f.arbitration_id ^ 1, f.data, time_ns=f.time_ns)
        out.append(f)
    for _ in range(20):
        i = rng.randrange(len(out) - 2)
        out[i], out[i + 2] = out[i + 2], out[i]
    cut = out[len(out) * 6 // 10].time_ns
    return [f for f in out if not (f.time_ns > cut and f.arbitration_id >> 4 & 0xF == 10)]


def test_chunks_of_any_size_give_the_same_cycles(bus: tuple[np.ndarray, list[CanFrame]]) -> None:
    log = SkinLog("perturbed", Batches(perturbed(bus[1], seed=3), size=37))
    assert log.left_out.anything and log.left_out.missing  # something to get wrong
    whole = log.whole()
    assert whole.samples == log.samples and len(whole.frames) == log.samples
    for chunk in (1, 7, 10_000):
        got = list(log.cycles(chunk=chunk))
        assert all(len(c.taxels) <= chunk for c in got)
        assert np.concatenate([c.taxels for c in got]).tobytes() == whole.taxels.tobytes()
        assert [fr for c in got for fr in c.frames] == list(whole.frames)
    # board 10 went silent: its later cycles carry no-load taxels, counted in left_out.missing
    column = log.boards.index(10)
    silent = (whole.taxels[:, column] == taxel.NO_LOAD).all(axis=1)
    assert dict(log.left_out.missing)[10] == int(silent.sum()) > 0


def test_a_log_that_changes_between_the_passes_is_an_error(
    bus: tuple[np.ndarray, list[CanFrame]],
) -> None:
    frames = bus[1]
    opened = 0

    def opener() -> tuple[Iterable[Batch], Callable[[], RecordCounts | None]]:
        nonlocal opened
        opened += 1
        batch: Batch = list(frames if opened == 1 else frames[: len(frames) // 2])
        return [batch], lambda: None

    log = SkinLog("changing", opener)
    with pytest.raises(CanLogFormatError, match="changed while it was read"):
        list(log.cycles())


def test_taxels_given_in_chunks_are_carried_as_one_array(
    bus: tuple[np.ndarray, list[CanFrame]],
) -> None:
    taxels = bus[0].reshape(SAMPLES, len(BOARDS), -1)
    nodes, size = len(BOARDS), taxels.shape[2]

    def records(payloads: object) -> list[tuple[int, int, bool, bytes, str | None]]:
        sink = MemorySink()
        simulate_epl(nodes, size, WIRE, cycles=SAMPLES, payloads=payloads, sink=sink)  # type: ignore[arg-type]
        return sink.records

    whole = records(taxels)
    assert records(list(taxels)) == whole  # a list of per-cycle rows is one array, as before
    cuts = [0, 1, 4, 5, 17, 30, SAMPLES]
    assert records(iter([taxels[a:b] for a, b in itertools.pairwise(cuts)])) == whole
    with pytest.raises(SkinframesError, match="hold 39 cycles, 40 expected"):
        records(iter([taxels[:39]]))
    with pytest.raises(SkinframesError, match="hold 41 cycles, 40 expected"):
        records(iter([taxels, taxels[:1]]))
    with pytest.raises(SkinframesError, match="expected uint8"):
        records(iter([taxels[:, :2]]))


def test_progress_counts_every_frame_and_every_cycle_once(
    bus: tuple[np.ndarray, list[CanFrame]],
) -> None:
    from emulator.compare import compare

    frames: list[int] = []
    log = SkinLog("bus", Batches(bus[1], size=64), progress=frames.append)
    assert sum(frames) == len(bus[1]) and len(frames) == -(-len(bus[1]) // 64)
    cycles: list[int] = []
    compare(log, WIRE, progress=cycles.append)
    assert sum(cycles) == SAMPLES


def test_times_beyond_146_years_are_one_clear_error(bus: tuple[np.ndarray, list[CanFrame]]) -> None:
    """A log dated 10**13 s (year 318,000) would overflow the int64 ns times: refused, named."""
    late = [CanFrame(f.arbitration_id, f.data, time_ns=f.time_ns + 10**22) for f in bus[1]]
    with pytest.raises(CanLogFormatError, match="146 years"):
        SkinLog("late", Batches(late))
