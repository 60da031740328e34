"""Cycle-time tables in the layout of the paper's Tables I-III (``skinframes tables``).

One cell per network, node count and payload: EPL (Table I), EtherCAT open ring (Table II) and
closed ring (Table III), by the analytic model or the frame-level emulator. The rows come from
:mod:`emulator.model.sweep`; the documents are produced row by row (:func:`iter_json`,
:func:`iter_csv`), so a table of a million cells never sits in memory as text.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator, Sequence
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from emulator.model.params import TimingParams
from emulator.model.sweep import TABLES, Row, cell_reason, reasons, rows

__all__ = ["CSV_HEADER", "DECIMALS", "cycle_tables", "iter_csv", "iter_json", "not_applicable"]

DECIMALS: Final = 6  # cycle times in the document are rounded to a picosecond (1e-6 us)
CSV_HEADER: Final = "table,nodes,bytes,cycle_us,not_applicable\n"


def _values(row: npt.NDArray[np.float64]) -> list[float | None]:
    """A row rounded as the documents print it; None where not applicable."""
    rounded = np.round(row, DECIMALS).tolist()
    return [None if v != v else v for v in rounded]


def not_applicable(model: str, nodes: Sequence[int], sizes: Sequence[int]) -> dict[str, list[str]]:
    """Per table, why some of its cells are not applicable (tables without such cells left out)."""
    out = {t: reasons(t, nodes, sizes, model) for t in TABLES}
    return {t: r for t, r in out.items() if r}


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

    ``{"model", "preset", "unit": "us", "epl": {"<nodes>": {"<bytes>": us | None}}, "ecat": ...,
    "ecat_redundant": ...}``, keys as strings in the order given, and ``not_applicable`` (per
    table, the reasons) when some cells are outside a protocol's limits.

    Args:
        model: ``"analytic"`` or ``"emulated"``.
        jobs: emulated: processes (None: every core).
        progress: called with the number of cells done since the last call.

    Raises:
        TopologyError: nonsense values (fewer than 1 node, negative bytes), or an unknown model.
    """
    doc: dict[str, Any] = {"model": model, "preset": params.name, "unit": "us"}
    for table in TABLES:
        doc[table] = {}
    keys = [str(b) for b in sizes]
    for table, n, row in rows(model, params, nodes, sizes, jobs=jobs, progress=progress):
        doc[table][str(n)] = dict(zip(keys, _values(row), strict=True))
    na = not_applicable(model, nodes, sizes)
    if na:
        doc["not_applicable"] = na
    return doc


def iter_json(
    model: str,
    params: TimingParams,
    nodes: Sequence[int],
    sizes: Sequence[int],
    *,
    jobs: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> Iterator[str]:
    """The text of ``json.dumps(cycle_tables(...), indent=2)`` plus a newline, row by row."""
    na = not_applicable(model, nodes, sizes)  # refuses unknown tables before any output
    head = {"model": model, "preset": params.name, "unit": "us"}
    source = rows(model, params, nodes, sizes, jobs=jobs, progress=progress)
    yield json.dumps(head, indent=2)[:-2]
    prefixes = [f'      "{b}": ' for b in sizes]
    current: str | None = None
    for table, n, row in source:
        if table != current:
            yield ("\n  }" if current is not None else "") + f',\n  "{table}": {{\n'
            current = table
        else:
            yield ",\n"
        cells = ",\n".join(
            p + ("null" if v is None else repr(v))
            for p, v in zip(prefixes, _values(row), strict=True)
        )
        yield f'    "{n}": {{\n{cells}\n    }}' if cells else f'    "{n}": {{}}'
    yield "\n  }" if current is not None else ""
    for table in TABLES[TABLES.index(current) + 1 if current else 0 :]:
        yield f',\n  "{table}": {{}}'
    if na:
        text = json.dumps(na, indent=2).replace("\n", "\n  ")
        yield f',\n  "not_applicable": {text}'
    yield "\n}\n"


def _csv_rows(source: Iterator[Row], model: str, sizes: Sequence[int]) -> Iterator[str]:
    mids = [f",{b}," for b in sizes]
    for table, n, row in source:
        lead = f"{table},{n}"
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
    (``cycle_us`` empty and the reason in ``not_applicable`` where the cell cannot exist)."""
    source = rows(model, params, nodes, sizes, jobs=jobs, progress=progress)
    yield CSV_HEADER
    yield from _csv_rows(source, model, sizes)
