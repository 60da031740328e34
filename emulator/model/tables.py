"""Cycle-time tables in the layout of the paper's Tables I-III (``skinframes tables``).

One cell per network, node count and payload: EPL (Table I), EtherCAT open ring (Table II) and
closed ring (Table III), by the analytic model or the frame-level emulator. The rows come from
:mod:`emulator.model.sweep`; the documents are produced row by row (:func:`iter_json`,
:func:`iter_csv`), so a table of a million cells never sits in memory as text.
"""

from __future__ import annotations

import contextlib
import json
import tempfile
from collections.abc import Callable, Iterator, Sequence
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from emulator.model.names import TABLES, old_name, with_old_keys
from emulator.model.params import TimingParams
from emulator.model.sweep import Row, cell_reason, reasons, rows

__all__ = ["CSV_HEADER", "DECIMALS", "cycle_tables", "iter_csv", "iter_json", "not_applicable"]

DECIMALS: Final = 6  # cycle times in the document are rounded to a picosecond (1e-6 us)
CSV_HEADER: Final = "table,nodes,bytes,cycle_us,not_applicable\n"
SPOOL_BYTES: Final = 16 * 2**20  # iter_json: an old name's copy of a table in memory up to this
COPY_BLOCK_CHARS: Final = 2**16  # ... and read back in blocks of this many characters


def _values(row: npt.NDArray[np.float64]) -> list[float | None]:
    """A row rounded as the documents print it; None where not applicable."""
    rounded = np.round(row, DECIMALS).tolist()
    return [None if v != v else v for v in rounded]


def not_applicable(model: str, nodes: Sequence[int], sizes: Sequence[int]) -> dict[str, list[str]]:
    """Per table, why some of its cells are not applicable (tables without such cells left out;
    old names beside the new, as in the document)."""
    out = {t: reasons(t, nodes, sizes, model) for t in TABLES}
    return with_old_keys({t: r for t, r in out.items() if r})


def cycle_tables(
    model: str,
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    *,
    jobs: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """The ``skinframes tables --json`` document as a dict (for small tables; see
    :func:`iter_json` for large ones).

    ``{"model", "preset", "unit": "us", "epl_cn_response_us" (D_CN), "epl": {"<nodes>":
    {"<bytes>": us | None}}, "ecat": ...,
    "ecat_closed_ring": ..., "ecat_redundant": ...}`` (the last the old name of the closed ring,
    the same value), keys as strings in the order given, and ``not_applicable`` (per table, the
    reasons) when some cells are outside a protocol's limits.

    Args:
        model: ``"analytic"`` or ``"emulated"``.
        jobs: emulated: processes (None: every core).
        progress: called with the number of cells done since the last call.

    Raises:
        TopologyError: nonsense values (fewer than 1 node, negative bytes), or an unknown model.
    """
    doc: dict[str, Any] = {"model": model, "preset": params.name, "unit": "us"}
    doc["epl_cn_response_us"] = params.epl_cn_response_us
    for table in TABLES:
        doc[table] = {}
    keys = [str(b) for b in sizes]
    for table, n, row in rows(model, params, nodes, sizes, jobs=jobs, progress=progress):
        doc[table][str(n)] = dict(zip(keys, _values(row), strict=True))
    na = not_applicable(model, nodes, sizes)
    if na:
        doc["not_applicable"] = na
    return with_old_keys(doc)


def _row_text(row: Row, prefixes: Sequence[str]) -> str:
    """One row of a table as ``json.dumps(..., indent=2)`` prints it inside the document."""
    _, n, values = row
    cells = ",\n".join(
        p + ("null" if v is None else repr(v))
        for p, v in zip(prefixes, _values(values), strict=True)
    )
    return f'    "{n}": {{\n{cells}\n    }}' if cells else f'    "{n}": {{}}'


def iter_json(
    model: str,
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    *,
    jobs: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> Iterator[str]:
    """The text of ``json.dumps(cycle_tables(...), indent=2)`` plus a newline, row by row.

    A table with an old name is written a second time under it from a copy kept in a spooled
    temporary file (memory up to :data:`SPOOL_BYTES`), so that no cell is computed twice.
    """
    na = not_applicable(model, nodes, sizes)  # refuses unknown tables before any output
    head: dict[str, Any] = {"model": model, "preset": params.name, "unit": "us"}
    head["epl_cn_response_us"] = params.epl_cn_response_us
    source = rows(model, params, nodes, sizes, jobs=jobs, progress=progress)
    yield json.dumps(head, indent=2)[:-2]
    prefixes = [f'      "{b}": ' for b in sizes]
    row = next(source, None)
    for table in TABLES:
        alias = old_name(table)
        with contextlib.ExitStack() as stack:
            copy = (
                stack.enter_context(
                    tempfile.SpooledTemporaryFile(SPOOL_BYTES, "w+", encoding="utf-8")
                )
                if alias != table
                else None
            )
            yield f',\n  "{table}": {{'
            sep = "\n"
            while row is not None and row[0] == table:
                chunk = sep + _row_text(row, prefixes)
                if copy is not None:
                    copy.write(chunk)
                yield chunk
                sep = ",\n"
                row = next(source, None)
            end = "}" if sep == "\n" else "\n  }"
            yield end
            if copy is not None:
                yield f',\n  "{alias}": {{'
                copy.seek(0)
                while block := copy.read(COPY_BLOCK_CHARS):
                    yield block
                yield end
    if na:
        text = json.dumps(na, indent=2).replace("\n", "\n  ")
        yield f',\n  "not_applicable": {text}'
    yield "\n}\n"


def _csv_rows(source: Iterator[Row], model: str, sizes: Sequence[int]) -> Iterator[str]:
    mids = [f",{b}," for b in sizes]
    for table, n, row in source:
        lead = f"{old_name(table)},{n}"  # one name per line: the one scripts already match
        yield "".join(
            f"{lead}{m}{v!r},\n"
            if v is not None
            else f"{lead}{m},{cell_reason(table, n, b, model)}\n"
            for m, b, v in zip(mids, sizes, _values(row), strict=True)
        )


def iter_csv(
    model: str,
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    *,
    jobs: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> Iterator[str]:
    """The tables as CSV, one line per cell: ``table,nodes,bytes,cycle_us,not_applicable``
    (``cycle_us`` empty and the reason in ``not_applicable`` where the cell cannot exist). The
    ``table`` column keeps the closed ring's old name ``ecat_redundant`` (:func:`old_name`)."""
    source = rows(model, params, nodes, sizes, jobs=jobs, progress=progress)
    yield CSV_HEADER
    yield from _csv_rows(source, model, sizes)
