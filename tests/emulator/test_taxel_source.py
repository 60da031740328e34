"""The driver's taxel source: seeded taxels made ahead by two producer threads (the generator's
words, then the taxels), cut anyhow, are the bytes of :func:`skinframes.taxel.sample_payloads`
(whose digests test_taxel.py pins)."""

from __future__ import annotations

import numpy as np
import pytest

from emulator.net import run as run_module
from emulator.net.run import TaxelSource
from skinframes import taxel
from skinframes.errors import FieldRangeError

NODES, BYTES, CYCLES, SEED = 3, 20, 50, 4


@pytest.fixture
def small_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Chunks of 4 cycles, so that takes start, end and span chunks anywhere."""
    monkeypatch.setattr(run_module, "PREFETCH_BYTES", 4 * NODES * taxel.PATCH_BYTES)


@pytest.mark.usefixtures("small_chunks")
def test_takes_cut_anyhow_are_the_seeded_payloads() -> None:
    whole = taxel.sample_payloads(NODES, CYCLES, BYTES, seed=SEED)
    source = TaxelSource(NODES, BYTES, CYCLES, seed=SEED)
    got = [source.take(1), source.take(7), source.take(4)]
    for count, multiple in ((10, 3), (3, 3), (9, 1), (2, 2)):
        some = source.take_some(count, multiple)
        assert len(some) <= max(count, multiple) and len(some) % multiple == 0
        got.append(some)
    got.append(source.take(CYCLES - sum(len(g) for g in got)))
    source.close()
    assert all(g.shape[1:] == (NODES, BYTES) for g in got)
    assert np.concatenate(got).tobytes() == whole.tobytes()


@pytest.mark.usefixtures("small_chunks")
def test_take_some_stays_inside_the_chunk() -> None:
    source = TaxelSource(NODES, BYTES, CYCLES, seed=SEED)
    source.take(1)
    assert len(source.take_some(100, 1)) == 3  # the rest of the first chunk of 4, no copy
    assert len(source.take_some(100, 3)) == 3  # 4 held: one period of 3
    assert len(source.take_some(100, 3)) == 3  # 1 held: less than a period, taken across chunks
    source.close()


def test_given_payloads_are_taken_as_they_are() -> None:
    given = np.arange(CYCLES * NODES * BYTES, dtype=np.int64).astype(np.uint8)
    given = given.reshape(CYCLES, NODES, BYTES)
    source = TaxelSource(NODES, BYTES, CYCLES, payloads=given)
    a, b = source.take(5), source.take_some(10, 4)
    assert len(b) == 8
    assert np.concatenate([a, b]).tobytes() == given[:13].tobytes()
    source.close()


@pytest.mark.usefixtures("small_chunks")
@pytest.mark.parametrize("stage", ["draw", "fill"])
def test_an_error_of_either_producer_thread_is_raised_by_take(
    stage: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(self: taxel.PayloadStream, *args: object) -> np.ndarray:
        raise FieldRangeError(f"broken {stage}")

    monkeypatch.setattr(taxel.PayloadStream, stage, broken)
    source = TaxelSource(NODES, BYTES, CYCLES, seed=SEED)
    with pytest.raises(FieldRangeError, match=f"broken {stage}"):
        source.take(1)
    source.close()


@pytest.mark.usefixtures("small_chunks")
def test_close_stops_producers_that_are_ahead() -> None:
    source = TaxelSource(NODES, BYTES, CYCLES, seed=SEED)
    threads = list(source._threads)
    assert len(threads) == 2
    source.take(1)  # the producers fill their queues and wait for room
    source.close()
    assert not any(thread.is_alive() for thread in threads)


@pytest.mark.usefixtures("small_chunks")
def test_closed_producers_draw_no_more_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    """After close, the words thread stops drawing: it does not go on to the last cycle (here
    2,500 chunks) while the run that closed it waits."""
    drawn: list[int] = []
    draw = taxel.PayloadStream.draw

    def counted(self: taxel.PayloadStream, m: int) -> np.ndarray:
        drawn.append(m)
        return draw(self, m)

    monkeypatch.setattr(taxel.PayloadStream, "draw", counted)
    source = TaxelSource(NODES, BYTES, 10_000, seed=SEED)
    source.take(1)
    source.close()
    assert len(drawn) < 20  # the chunks in the queues and in the threads' hands
