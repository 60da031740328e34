"""The driver's taxel source: seeded taxels drawn ahead by a producer thread, cut anyhow, are the
bytes of :func:`skinframes.taxel.sample_payloads` (whose digests test_taxel.py pins)."""

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
def test_an_error_of_the_producer_is_raised_by_take(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(self: taxel.PayloadStream, m: int) -> np.ndarray:
        raise FieldRangeError("broken stream")

    monkeypatch.setattr(taxel.PayloadStream, "take", broken)
    source = TaxelSource(NODES, BYTES, CYCLES, seed=SEED)
    with pytest.raises(FieldRangeError, match="broken stream"):
        source.take(1)
    source.close()


@pytest.mark.usefixtures("small_chunks")
def test_close_stops_a_producer_that_is_ahead() -> None:
    source = TaxelSource(NODES, BYTES, CYCLES, seed=SEED)
    thread = source._thread
    assert thread is not None
    source.take(1)  # the producer fills the queue and waits for room
    source.close()
    assert not thread.is_alive()
