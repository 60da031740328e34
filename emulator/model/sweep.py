"""Sweeps: every nodes x bytes cell of the three networks, row by row.

The analytic model evaluates eqs. (3)-(19) over the whole grid at once (numpy broadcasting of a
column of node counts against a row of payload sizes); the emulated model asks the timing-only
engine (:mod:`emulator.net.sweep`) for one steady-state cycle per cell. Cells a protocol cannot
have (241 EPL CNs, 1487 bytes in one EtherCAT datagram) are NaN, and :func:`reasons` says why;
values that are no network at all (fewer than one node, negative bytes) are refused.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.pool
import os
import signal
from collections.abc import Callable, Iterator, Sequence
from multiprocessing import resource_tracker
from types import FrameType
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import PresetError, TopologyError
from emulator.model import analytic
from emulator.model.limits import ECAT_RANGE, MAX_EMULATED_SLAVES, RANGES, Range
from emulator.model.names import EPL, TABLES, is_closed_ring, table_name
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_US
from skinframes.helper_threads import HANDLED_IN_MAIN, signals_held

__all__ = [
    "TABLES",
    "Row",
    "analytic_grid",
    "applicable",
    "cell_reason",
    "check_values",
    "domain",
    "reasons",
    "rows",
]

Row = tuple[str, int, npt.NDArray[np.float64]]  # (table, nodes, cycle_us per size; NaN = n/a)
# An emulated EtherCAT chain ends where ``simulate`` ends it (emulator.model.limits).
EMULATED_ECAT_RANGE: Final = Range(
    "EtherCAT (emulated)",
    1,
    MAX_EMULATED_SLAVES,
    "slaves",
    ECAT_RANGE.min_bytes,
    ECAT_RANGE.max_bytes,
    "bytes per slave",
)


def _ints(values: Sequence[int] | npt.ArrayLike) -> npt.NDArray[np.int64]:
    return np.asarray(values, dtype=np.int64).reshape(-1)


def check_values(nodes: Sequence[int], sizes: Sequence[int]) -> None:
    """Refuse values that describe no network at all: fewer than 1 node, negative bytes."""
    if len(nodes) and min(nodes) < 1:
        raise TopologyError(f"{min(nodes)} nodes: a network has at least 1 node")
    if len(sizes) and min(sizes) < 0:
        raise TopologyError(f"{min(sizes)} bytes per node: a payload has at least 0 bytes")


def domain(table: str, model: str = "analytic") -> Range:
    """What ``table`` (either name) allows under ``model`` (the emulated EtherCAT chain ends at
    1024 slaves). Raises PresetError for an unknown table."""
    table = table_name(table)
    if model == "emulated" and table != EPL:
        return EMULATED_ECAT_RANGE
    return RANGES[table]


def applicable(
    table: str, nodes: Sequence[int], sizes: Sequence[int], model: str = "analytic"
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    """(rows, columns): which node counts and which sizes ``table`` allows."""
    r = domain(table, model)
    n, b = _ints(nodes), _ints(sizes)
    return (
        (n >= r.min_nodes) & (n <= r.max_nodes),
        (b >= r.min_bytes) & (b <= r.max_bytes),
    )


def cell_reason(table: str, nodes: int, data_bytes: int, model: str = "analytic") -> str | None:
    """Why one cell is not applicable (the message the scalar check raises), or None."""
    r = domain(table, model)
    if not r.min_nodes <= nodes <= r.max_nodes:
        return r.nodes_text(str(nodes))
    if not r.min_bytes <= data_bytes <= r.max_bytes:
        return r.bytes_text(str(data_bytes))
    return None


def _span(values: npt.NDArray[np.int64]) -> str:
    lo, hi = int(values.min()), int(values.max())
    return str(lo) if lo == hi else f"{lo}..{hi}"


def reasons(
    table: str, nodes: Sequence[int], sizes: Sequence[int], model: str = "analytic"
) -> list[str]:
    """Why cells of ``table`` are not applicable, one line per cause (empty: all applicable)."""
    r = domain(table, model)
    ok_n, ok_b = applicable(table, nodes, sizes, model)
    n, b = _ints(nodes), _ints(sizes)
    out = []
    for low, ok, values, text in (
        (True, ok_n, n, r.nodes_text),
        (False, ok_n, n, r.nodes_text),
        (True, ok_b, b, r.bytes_text),
        (False, ok_b, b, r.bytes_text),
    ):
        limit = r.min_nodes if text == r.nodes_text else r.min_bytes
        bad = values[~ok & ((values < limit) if low else (values >= limit))]
        if bad.size:
            out.append(text(_span(bad)))
    return out


def analytic_grid(
    table: str, nodes: Sequence[int], sizes: Sequence[int], params: TimingParams
) -> npt.NDArray[np.float64]:
    """(len(nodes), len(sizes)) cycle times in us by eqs. (3)-(19), NaN where not applicable."""
    r = domain(table)
    ok_n, ok_b = applicable(table, nodes, sizes)
    n = np.clip(_ints(nodes), r.min_nodes, r.max_nodes)[:, None]
    b = np.clip(_ints(sizes), r.min_bytes, r.max_bytes)[None, :]
    if table_name(table) == EPL:
        grid = analytic.epl_cycle_us(n, b, params)
    else:
        grid = analytic.ecat_cycle_us(n, b, params, closed_ring=is_closed_ring(table))
    grid = np.broadcast_to(grid, (n.shape[0], b.shape[1])).copy()
    grid[~(ok_n[:, None] & ok_b[None, :])] = np.nan
    return grid


def rows(
    model: str,
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    *,
    jobs: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> Iterator[Row]:
    """Every row of the three tables, in order: (table, nodes, cycle_us per size).

    Args:
        model: ``analytic`` or ``emulated``.
        jobs: emulated: processes to spread the rows over (None: every core).
        progress: called with the number of cells done since the last call.

    Raises:
        TopologyError: nonsense values (:func:`check_values`); PresetError (a TopologyError):
            an unknown model.
    """
    check_values(nodes, sizes)
    if model == "analytic":
        return _analytic_rows(params, nodes, sizes, progress)
    if model == "emulated":
        return _emulated_rows(params, nodes, sizes, jobs, progress)
    raise PresetError(f"unknown model {model!r}; choose from ['analytic', 'emulated']")


def _analytic_rows(
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    progress: Callable[[int], None] | None,
) -> Iterator[Row]:
    for table in TABLES:
        grid = analytic_grid(table, nodes, sizes, params)
        for n, row in zip(nodes, grid, strict=True):
            yield table, n, row
            if progress is not None:
                progress(len(sizes))


_Task = tuple[str, int, tuple[int, ...], TimingParams]


def _emulate_row(task: _Task) -> npt.NDArray[np.int64]:
    """One row's cycle times in ps (run in a worker process)."""
    from emulator.net.sweep import cycle_ps_row

    table, n, sizes, params = task
    return cycle_ps_row(table, n, np.asarray(sizes, dtype=np.int64), params)


@contextlib.contextmanager
def _pool(workers: int) -> Iterator[multiprocessing.pool.Pool]:
    """A pool whose workers leave SIGINT and SIGTERM to the command, terminated when the block
    ends: a Ctrl-C reaches the terminal's whole process group, and a worker that took it would
    print its own traceback. The workers start with both blocked, then ignore SIGINT
    (:func:`_worker_started`); one that came meanwhile is raised once the pool is in the block.
    """
    resource_tracker.ensure_running()  # (started inside, it would unblock both as it began)
    with contextlib.ExitStack() as stack:
        with signals_held():
            pool = stack.enter_context(
                multiprocessing.get_context("spawn").Pool(workers, _worker_started)
            )
        yield pool


def _worker_started() -> None:
    """A worker's first call: SIGINT ignored, and SIGTERM (the pool's terminate(), or the one
    the whole group got) ends the worker quietly by SystemExit, which on the way out releases
    the pool's queue locks it may hold: a worker killed while it waits for a task keeps the lock
    the pool's terminate() then waits for, for good."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_quietly)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HANDLED_IN_MAIN)


def _exit_quietly(signum: int, frame: FrameType | None) -> None:
    signal.signal(signum, signal.SIG_DFL)  # a second one (the pool's, after the group's) kills
    raise SystemExit(128 + signum)


def _emulated_rows(
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    jobs: int | None,
    progress: Callable[[int], None] | None,
) -> Iterator[Row]:
    """The rows from the timing-only engine, spread over ``jobs`` processes, in order."""
    plan: list[tuple[str, int, npt.NDArray[np.bool_]]] = []
    tasks: list[_Task] = []
    size_arr = _ints(sizes)
    for table in TABLES:
        ok_n, ok_b = applicable(table, nodes, sizes, "emulated")
        for n, row_ok in zip(nodes, ok_n.tolist(), strict=True):
            cols = ok_b if row_ok else np.zeros_like(ok_b)
            plan.append((table, n, cols))
            if cols.any():
                tasks.append((table, n, tuple(size_arr[cols].tolist()), params))
    workers = max(1, min(jobs or os.cpu_count() or 1, len(tasks)))
    with contextlib.ExitStack() as stack:
        if workers > 1:
            pool = stack.enter_context(_pool(workers))
            done: Iterator[npt.NDArray[np.int64]] = pool.imap(_emulate_row, tasks, chunksize=1)
        else:
            done = map(_emulate_row, tasks)
        for table, n, cols in plan:
            row = np.full(len(sizes), np.nan)
            if cols.any():
                row[cols] = next(done) / PS_PER_US
            yield table, n, row
            if progress is not None:
                progress(len(sizes))
