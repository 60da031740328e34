"""The driver: runs an engine cycle by cycle and streams what it produces.

Every cycle comes from the engine's walk (:meth:`cycle`), faults or not. When the network is in
a steady state -- no chance faults, no transition under way, no fault scheduled before cycle
``e`` -- a later cycle is an earlier one shifted in time, with only its taxels (and the EPL SoC
time) changed: the periodic fast path repeats the last walked period up to ``e`` and fills those
parts with numpy, block by block, instead of walking again (``fast=False`` walks every cycle; a
test proves both give the same bytes). Frames go to a sink as they come (a capture writer, or a
list in tests); statistics are kept online (a histogram of cycle durations in integer ps), so
memory does not grow with the number of cycles.
"""

from __future__ import annotations

import queue
import threading
from collections import Counter, deque
from collections.abc import Callable, Iterable, Iterator
from typing import Final, Protocol, TypeAlias, TypeVar

import numpy as np
import numpy.typing as npt

from emulator.errors import PayloadError, ScheduleError
from emulator.model.limits import check_cycles
from emulator.net.cycle import FILL_FRAME, FILL_TAXELS, Cycle, Record
from emulator.net.result import CycleDetail, SimResult
from skinframes import ethernet, taxel

__all__ = [
    "BLOCK_BYTES",
    "MAX_LISTED",
    "Engine",
    "MemorySink",
    "Payloads",
    "Sink",
    "TaxelSource",
    "run",
]

BLOCK_BYTES: Final = 32 << 20  # frame bytes per block of repeated cycles (taxels drawn at once)
MAX_LISTED: Final = 10_000  # cycles_detail entries at most (the rest are counted)
PREFETCH_BYTES: Final = 8 << 20  # taxel bytes per chunk the producer thread draws ahead
PREFETCH_CHUNKS: Final = 2  # chunks waiting at most (memory: about 3 chunks)
_T = TypeVar("_T")
# taxels to carry: (cycles, nodes, data_bytes) uint8, or such chunks in order (TaxelSource)
Payloads: TypeAlias = npt.NDArray[np.uint8] | Iterable[npt.NDArray[np.uint8]]


class Engine(Protocol):
    """What the driver needs from a protocol engine (EtherCAT, EPL)."""

    @property
    def protocol(self) -> str: ...
    @property
    def topology(self) -> str: ...
    @property
    def layout(self) -> str: ...
    @property
    def nodes(self) -> int: ...
    @property
    def patches(self) -> int: ...  # the nodes that carry taxels (all but ESI slaves)
    @property
    def data_bytes(self) -> int: ...
    @property
    def period(self) -> int: ...

    def event_at(self, cycle: int) -> bool: ...
    def next_event(self, cycle: int) -> int | None: ...
    def cycle(self, c: int, start_ps: int, taxels: npt.NDArray[np.uint8] | None) -> Cycle: ...
    def image(
        self, cycles: npt.NDArray[np.int64], taxels: npt.NDArray[np.uint8]
    ) -> npt.NDArray[np.uint8]: ...
    def account(self, cyc: Cycle, times: int) -> None: ...
    def rebuild(
        self, record: Record, starts_ps: npt.NDArray[np.int64], taxels: npt.NDArray[np.uint8]
    ) -> npt.NDArray[np.uint8]: ...


class Sink(Protocol):
    """Where frames go: one by one (walked cycles) or as blocks of repeated cycles."""

    def write(
        self, time_ps: int, frame: bytes, *, port: int, outbound: bool, comment: str | None
    ) -> None: ...

    def write_repeated(
        self,
        times_ps: npt.NDArray[np.int64],
        lengths: npt.NDArray[np.int64],
        template: npt.NDArray[np.uint8],
        *,
        ports: npt.NDArray[np.int64],
        outbound: npt.NDArray[np.bool_],
        fills: list[tuple[int, npt.NDArray[np.uint8]]],
    ) -> None: ...


class MemorySink:
    """Keeps every record (for tests and small runs): (time_ps, port, outbound, bytes, comment)."""

    def __init__(self) -> None:
        self.records: list[tuple[int, int, bool, bytes, str | None]] = []

    def write(
        self, time_ps: int, frame: bytes, *, port: int, outbound: bool, comment: str | None
    ) -> None:
        self.records.append((time_ps, port, outbound, frame, comment))

    def write_repeated(
        self,
        times_ps: npt.NDArray[np.int64],
        lengths: npt.NDArray[np.int64],
        template: npt.NDArray[np.uint8],
        *,
        ports: npt.NDArray[np.int64],
        outbound: npt.NDArray[np.bool_],
        fills: list[tuple[int, npt.NDArray[np.uint8]]],
    ) -> None:
        ends = np.cumsum(lengths).tolist()
        for row in range(times_ps.shape[0]):
            data = template.copy()
            for offset, values in fills:
                data[offset : offset + values.shape[1]] = values[row]
            raw = data.tobytes()
            for r, end in enumerate(ends):
                start = end - int(lengths[r])
                self.records.append(
                    (int(times_ps[row, r]), int(ports[r]), bool(outbound[r]), raw[start:end], None)
                )


class TaxelSource:
    """The taxel bytes of consecutive cycles: given (e.g. a CAN log's samples) or seeded.

    Given taxels are one (cycles, nodes, data_bytes) array (or nested lists), or consecutive
    (m, nodes, data_bytes) chunks from an iterator that yields them as they are needed (a CAN
    log read as the cycles go, :class:`emulator.skin_samples.SkinLog`), whose lengths add up
    to ``cycles``.
    Seeded taxels are made ahead, chunk by chunk (``PREFETCH_BYTES`` each, at most
    ``PREFETCH_CHUNKS`` waiting), while the driver assembles and writes the cycles before them,
    by two threads in a pipeline: one draws the generator's words of a chunk
    (:meth:`skinframes.taxel.PayloadStream.draw`), the other turns the words of the chunk
    before into taxels (:meth:`~skinframes.taxel.PayloadStream.fill`: noise and contacts). The
    generator releases the GIL, and so do numpy's arithmetic, its copies and the file writes.
    Each thread takes the chunks in order, so the bytes are those of one stream however they
    are cut; :meth:`close` stops both.
    """

    def __init__(
        self,
        nodes: int,
        data_bytes: int,
        cycles: int,
        *,
        seed: int = 0,
        payloads: Payloads | None = None,
    ) -> None:
        self.shape = (nodes, data_bytes)
        self._cycles = cycles
        self._given: npt.NDArray[np.uint8] | None = None
        self._given_chunks: Iterator[npt.NDArray[np.uint8]] | None = None
        self._delivered = 0  # cycles the given chunks have yielded so far
        self._taken = 0
        self._chunks: queue.Queue[npt.NDArray[np.uint8] | BaseException] = queue.Queue(
            PREFETCH_CHUNKS
        )
        self._ahead: npt.NDArray[np.uint8] | None = None  # the rest of the chunk being taken
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        if nodes == 0 and payloads is None:  # a line of ESI slaves only: no taxels
            self._given = np.zeros((cycles, 0, data_bytes), np.uint8)
            return
        if isinstance(payloads, np.ndarray | list | tuple):  # one array (nested lists too)
            self._given = self._checked(np.asarray(payloads), cycles)
            return
        if payloads is not None:  # an iterator or generator of chunks
            self._given_chunks = iter(payloads)
            return
        stream = taxel.PayloadStream(nodes, cycles, data_bytes, seed=seed)
        chunk = max(1, PREFETCH_BYTES // (nodes * max(data_bytes, taxel.PATCH_BYTES)))
        words: queue.Queue[tuple[npt.NDArray[np.uint32], int] | BaseException] = queue.Queue(1)
        self._threads = [
            threading.Thread(target=target, args=args, name=name, daemon=True)
            for target, args, name in (
                (self._draw, (stream, cycles, chunk, words), "taxel-words"),
                (self._fill, (stream, cycles, words), "taxels"),
            )
        ]
        for thread in self._threads:
            thread.start()

    def _checked(self, arr: npt.NDArray[np.uint8], cycles: int) -> npt.NDArray[np.uint8]:
        """``arr`` if it is uint8 (cycles, nodes, data_bytes), else PayloadError."""
        if arr.dtype != np.uint8 or arr.shape != (cycles, *self.shape):
            raise PayloadError(
                f"payloads: {arr.dtype} {arr.shape}, expected uint8 {(cycles, *self.shape)}"
            )
        return arr

    def _draw(
        self,
        stream: taxel.PayloadStream,
        cycles: int,
        chunk: int,
        words: queue.Queue[tuple[npt.NDArray[np.uint32], int] | BaseException],
    ) -> None:
        """The first thread: the generator's words of every chunk, in order."""
        try:
            for first in range(0, cycles, chunk):
                if self._stop.is_set():
                    return
                m = min(chunk, cycles - first)
                self._put(words, (stream.draw(m), m))
        except BaseException as e:  # handed on to the consumer, raised there
            self._put(words, e)

    def _fill(
        self,
        stream: taxel.PayloadStream,
        cycles: int,
        words: queue.Queue[tuple[npt.NDArray[np.uint32], int] | BaseException],
    ) -> None:
        """The second thread: every chunk's taxels from its words, into the consumer's queue."""
        try:
            done = 0
            while done < cycles:
                item = self._get(words)
                if item is None:
                    return  # stopped
                if isinstance(item, BaseException):
                    raise item
                self._put(self._chunks, stream.fill(*item))
                done += item[1]
        except BaseException as e:  # handed to the consumer, raised there
            self._put(self._chunks, e)

    def _put(self, into: queue.Queue[_T], item: _T) -> None:
        while not self._stop.is_set():
            try:
                into.put(item, timeout=0.1)
                return
            except queue.Full:
                continue

    def _get(self, source: queue.Queue[_T]) -> _T | None:
        """The next item, or None once stopped."""
        while not self._stop.is_set():
            try:
                return source.get(timeout=0.1)
            except queue.Empty:
                continue
        return None

    def take(self, count: int) -> npt.NDArray[np.uint8]:
        """The next ``count`` cycles' taxels, (count, nodes, data_bytes)."""
        first, self._taken = self._taken, self._taken + count
        if self._given is not None:
            return self._given[first : first + count]
        parts: list[npt.NDArray[np.uint8]] = []
        need = count
        while need:
            ahead = self._held()
            parts.append(ahead[:need])
            self._ahead = ahead[need:]
            need -= len(parts[-1])
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    def take_some(self, count: int, multiple: int) -> npt.NDArray[np.uint8]:
        """The next cycles' taxels, at most ``count`` of them and a multiple of ``multiple``:
        what the current chunk holds, without a copy, unless that is less than ``multiple``."""
        held = count if self._given is not None else len(self._held())
        return self.take(min(count, max(multiple, held // multiple * multiple)))

    def _held(self) -> npt.NDArray[np.uint8]:
        """The rest of the current chunk (the next one from the producer, or from the given
        chunks, when it is used up)."""
        if self._ahead is None or not len(self._ahead):
            if self._given_chunks is not None:
                self._ahead = self._next_given()
                return self._ahead
            item = self._chunks.get()
            if isinstance(item, BaseException):
                raise item
            self._ahead = item
        return self._ahead

    def _next_given(self) -> npt.NDArray[np.uint8]:
        """The next given chunk: PayloadError if it is not uint8 (m, nodes, data_bytes), or
        when the chunks end before ``cycles``."""
        assert self._given_chunks is not None
        chunk = next(self._given_chunks, None)
        if chunk is None:
            raise PayloadError(
                f"payloads: the chunks hold {self._delivered} cycles, {self._cycles} expected"
            )
        arr = np.asarray(chunk)
        m = arr.shape[0] if arr.ndim == 3 and arr.shape[0] else 1
        self._checked(arr, m)
        self._delivered += m
        return arr

    def finish(self) -> None:
        """After the last cycle: PayloadError if the given chunks hold more cycles."""
        if self._given_chunks is None:
            return
        total = self._delivered + sum(len(np.asarray(chunk)) for chunk in self._given_chunks)
        if total != self._cycles:
            raise PayloadError(f"payloads: the chunks hold {total} cycles, {self._cycles} expected")

    def close(self) -> None:
        """Stop the producer threads (they end within their current chunk)."""
        self._stop.set()
        for thread in self._threads:
            thread.join()
        self._threads = []


class _Overlap:
    """No two frames on one direction of one master port may overlap (ScheduleError)."""

    def __init__(self) -> None:
        self.end: dict[tuple[int, bool], int] = {}

    def see(self, t_ps: int, rec: Record) -> None:
        key = (rec.port, rec.outbound)
        if t_ps < self.end.get(key, -1):
            direction = "outbound" if rec.outbound else "inbound"
            raise ScheduleError(f"two {direction} frames overlap at port {rec.port} at {t_ps} ps")
        self.end[key] = t_ps + rec.wire_ps


def run(
    engine: Engine,
    cycles: int,
    *,
    params_name: str,
    sink: Sink | None = None,
    seed: int = 0,
    payloads: Payloads | None = None,
    progress: Callable[[int], None] | None = None,
    fast: bool = True,
    every_cycle: bool = False,
    start_ps: int = 0,
) -> tuple[SimResult, Counter[tuple[object, ...]]]:
    """Run ``cycles`` cycles of ``engine``; frames to ``sink`` (None: timing only).

    The first cycle starts at ``start_ps`` (after a start-up the caller wrote, for example).

    ``every_cycle`` lists every cycle in the result's details (and walks every cycle), not only
    those that differ from the cycle one period earlier.

    Returns:
        The result and the events the engine counted over the run.
    """
    check_cycles(cycles)
    source = (
        TaxelSource(engine.patches, engine.data_bytes, cycles, seed=seed, payloads=payloads)
        if sink is not None
        else None
    )
    try:
        period_len = engine.period
        result = SimResult(
            engine.protocol,
            engine.topology,
            engine.patches,
            engine.data_bytes,
            params_name,
            engine.layout,
        )
        events: Counter[tuple[object, ...]] = Counter()
        history: deque[Cycle] = deque(maxlen=period_len)
        last: deque[tuple[int, int, int]] = deque(
            maxlen=period_len
        )  # (cycle_ps, wkc, expected) of the last P
        overlap = _Overlap()
        c, start = 0, start_ps

        def note(cyc: Cycle, c: int, start: int) -> None:
            key = (cyc.cycle_ps, cyc.wkc, cyc.expected_wkc)
            if c < period_len or last[0] != key or every_cycle:
                result.list_detail(
                    CycleDetail(c, start, cyc.cycle_ps, cyc.wkc, cyc.expected_wkc), MAX_LISTED
                )
            last.append(key)

        while c < cycles:
            if engine.event_at(c):
                history.clear()
            taxels = source.take(1)[0] if source is not None else None
            cyc = engine.cycle(c, start, taxels)
            for rec in cyc.records:
                overlap.see(start + rec.rel_ps, rec)
                if sink is not None:
                    assert rec.frame is not None
                    sink.write(
                        start + rec.rel_ps,
                        rec.frame,
                        port=rec.port,
                        outbound=rec.outbound,
                        comment=rec.mark,
                    )
            if c == 0:
                _first_cycle(result, cyc)
            note(cyc, c, start)
            result.add_cycles(cyc.cycle_ps, len(cyc.records), 1)
            events.update(cyc.events)
            engine.account(cyc, 1)
            start += cyc.cycle_ps
            c += 1
            if progress is not None:
                progress(1)
            if not (fast and cyc.steady and not every_cycle):
                history.clear()
                continue
            history.append(cyc)
            if len(history) < period_len:
                continue
            nxt = engine.next_event(c - 1)
            stop = min(cycles, nxt) if nxt is not None else cycles
            q = (stop - c) // period_len
            if q <= 0:
                continue
            period = list(history)
            period_ps = sum(h.cycle_ps for h in period)
            if sink is not None and source is not None:
                _repeat(engine, period, c, start, q, sink, source, overlap, progress)
            for h in period:
                result.add_cycles(h.cycle_ps, len(h.records), q)
                for key, n in h.events.items():
                    events[key] += n * q
                engine.account(h, q)
            if sink is None and progress is not None:
                progress(q * period_len)
            start += q * period_ps
            c += q * period_len
        if source is not None:
            source.finish()
        return result, events
    finally:
        if source is not None:
            source.close()


def _first_cycle(result: SimResult, cyc: Cycle) -> None:
    """What one cycle puts on the wire (for plans and comparisons)."""
    sent = [r for r in cyc.records if r.outbound]
    result.frames_sent_per_cycle = sum(r.port == 0 for r in sent)
    result.wire_bytes_per_cycle = sum(ethernet.wire_bytes(r.length) for r in cyc.records)
    result.wire_bytes_sent_per_cycle = sum(ethernet.wire_bytes(r.length) for r in sent)


def _repeat(
    engine: Engine,
    period: list[Cycle],
    first: int,
    start: int,
    q: int,
    sink: Sink,
    source: TaxelSource,
    overlap: _Overlap,
    progress: Callable[[int], None] | None,
) -> None:
    """Write ``q`` repetitions of ``period`` (walked cycles) from cycle ``first`` at ``start``
    (the fast path)."""
    period_len = len(period)
    offsets = np.concatenate(([0], np.cumsum([h.cycle_ps for h in period])))
    period_ps = int(offsets[-1])
    cols: list[tuple[int, Record]] = [(i, r) for i, h in enumerate(period) for r in h.records]
    rel = np.array([int(offsets[i]) + r.rel_ps for i, r in cols], dtype=np.int64)
    lengths = np.array([r.length for _, r in cols], dtype=np.int64)
    ports = np.array([r.port for _, r in cols], dtype=np.int64)
    outbound = np.array([r.outbound for _, r in cols], dtype=bool)
    at = np.concatenate(([0], np.cumsum(lengths)))
    row_bytes = int(at[-1])
    template = np.frombuffer(b"".join(r.frame or b"" for _, r in cols), np.uint8)
    for rep in (0, 1):  # two periods in a row obey the link rules, so all of them do
        for (_, r), t in zip(cols, rel.tolist(), strict=True):
            overlap.see(start + rep * period_ps + t, r)
    seen = {(r.port, r.outbound) for _, r in cols}  # the directions the period uses move on
    overlap.end = {k: v + (q - 2) * period_ps if k in seen else v for k, v in overlap.end.items()}
    per_block = max(1, BLOCK_BYTES // max(1, row_bytes))
    done = 0
    while done < q:
        drawn = source.take_some(min(per_block, q - done) * period_len, period_len)
        k = len(drawn) // period_len
        starts = start + (done + np.arange(k, dtype=np.int64)) * period_ps
        taxels = drawn.reshape(k, period_len, *source.shape)
        fills: list[tuple[int, npt.NDArray[np.uint8]]] = []
        images: dict[int, npt.NDArray[np.uint8]] = {}
        for col, (i, r) in enumerate(cols):
            lo = int(at[col])
            if r.fill == FILL_TAXELS:
                if i not in images:
                    numbers = first + (done + np.arange(k, dtype=np.int64)) * period_len + i
                    images[i] = engine.image(numbers, taxels[:, i])
                image = images[i]
                fills.extend((lo + dst, image[:, src : src + n]) for dst, src, n in r.runs)
            elif r.fill == FILL_FRAME:
                fills.append((lo, engine.rebuild(r, starts + int(offsets[i]), taxels[:, i])))
        sink.write_repeated(
            starts[:, None] + rel[None, :],
            lengths,
            template,
            ports=ports,
            outbound=outbound,
            fills=fills,
        )
        done += k
        if progress is not None:
            progress(k * period_len)
