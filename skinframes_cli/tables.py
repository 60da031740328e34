"""``skinframes tables``: cycle-time tables in the layout of the paper's Tables I-III."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable
from typing import IO, Any

import numpy as np

from emulator.model.cycle_time import MODELS
from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL, JSON_KEYS_HELP
from emulator.model.paper_tables import paper_value
from emulator.model.params import PAPER, PRESETS, TimingParams
from emulator.model.sweep import rows
from emulator.model.tables import DECIMALS, iter_csv, iter_json, not_applicable
from skinframes.atomic_file import atomic_output
from skinframes.errors import SkinframesError
from skinframes_cli.options import add_cn_response, bounded_int, int_list, int_list_in, timing
from skinframes_cli.progress import progress_bar

MAX_NODES = 65535  # the largest EtherCAT chain (16-bit position address); EPL stops at 239
MAX_BYTES = 65535
MAX_JOBS = 256

TITLES = {
    EPL: "Table I: Ethernet POWERLINK cycle time [us]",
    ECAT: "Table II: EtherCAT cycle time, open ring (the paper's non-redundant) [us]",
    ECAT_CLOSED_RING: "Table III: EtherCAT cycle time, closed ring (the paper's redundant) [us]",
}


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "tables",
        help="cycle-time tables (the paper's Tables I-III by default)",
        description="Cycle times of EPL and EtherCAT (open and closed ring) for each number of "
        "nodes and payload size. With --preset paper each table ends with how many of its "
        "cells the paper prints and the largest difference from them.",
    )
    p.add_argument(
        "--model",
        choices=list(MODELS),
        default="analytic",
        help="the paper's formulas, or the frame-level emulator (default: analytic)",
    )
    p.add_argument(
        "--preset",
        choices=list(PRESETS),
        default="paper",
        help="timing constants (default: paper)",
    )
    add_cn_response(p)
    p.add_argument(
        "--nodes",
        type=int_list_in(1, MAX_NODES),
        default=int_list("130:200:10"),
        help="start:stop:step (stop inclusive) or comma list (default: 130:200:10)",
    )
    p.add_argument(
        "--bytes",
        type=int_list_in(0, MAX_BYTES),
        default=int_list("2,32,128,256"),
        help="payload bytes per node, same syntax (default: 2,32,128,256)",
    )
    p.add_argument("--json", action="store_true", help=f"one JSON document; {JSON_KEYS_HELP}")
    p.add_argument(
        "--csv",
        nargs="?",
        const="-",
        metavar="FILE",
        help="one line per cell (table,nodes,bytes,cycle_us,not_applicable) on stdout, or "
        "written to FILE",
    )
    p.add_argument(
        "--jobs",
        type=bounded_int(1, MAX_JOBS),
        default=None,
        metavar="N",
        help=f"--model emulated: processes to spread the cells over, 1..{MAX_JOBS} "
        "(default: every core)",
    )
    p.set_defaults(run=run)


def _write(chunks: Iterable[str], out: IO[str]) -> None:
    for chunk in chunks:
        out.write(chunk)


def run(args: argparse.Namespace) -> int:
    """Print the tables (and write the CSV)."""
    if args.jobs is not None and args.jobs < 1:
        raise SkinframesError(f"--jobs {args.jobs}: at least 1")
    if args.json and args.csv == "-":
        raise SkinframesError("--json and --csv both on stdout: give --csv a FILE")
    if args.jobs is not None and args.model != "emulated":  # (information: scripts keep working)
        print("note: --jobs: with --model emulated only (the formulas run in one process); "
              "ignored", file=sys.stderr)  # fmt: skip
    params = timing(args)
    cells = 3 * len(args.nodes) * len(args.bytes)
    kw = {"jobs": args.jobs}
    if args.csv not in (None, "-"):
        with progress_bar(cells, "cells") as step, atomic_output(args.csv, "w") as f:
            _write(iter_csv(args.model, params, args.nodes, args.bytes, progress=step, **kw), f)
        if not args.json:
            print(f"wrote {args.csv}")
            return 0
    with progress_bar(cells, "cells") as step:
        if args.json:
            chunks = iter_json(args.model, params, args.nodes, args.bytes, progress=step, **kw)
            _write(chunks, sys.stdout)
            return 0
        if args.csv == "-":
            _write(
                iter_csv(args.model, params, args.nodes, args.bytes, progress=step, **kw),
                sys.stdout,
            )
            return 0
        _text(args, params, rows(args.model, params, args.nodes, args.bytes, progress=step, **kw))
    return 0


def _text(args: argparse.Namespace, params: TimingParams, source: Iterable[Any]) -> None:
    """The human-readable tables, with the paper's printed cells compared (not EPL's with a
    CN response time of its own: the paper's are for 1 us)."""
    print(f"model {args.model}, preset {params.label}")
    na = not_applicable(args.model, args.nodes, args.bytes)
    current = None
    deltas: list[float] = []

    def close(table: str | None) -> None:
        if table is None:
            return
        for reason in na.get(table, []):
            print(f"      n/a: {reason}")
        if deltas:
            print(
                f"      {len(deltas)} cell{'s' * (len(deltas) != 1)} printed in the paper; "
                f"largest difference "
                f"{max(deltas):.4f} us (the paper rounds to 0.01)"
            )
        deltas.clear()

    for table, n, row in source:
        if table != current:
            close(current)
            current = table
            print(f"\n{TITLES[table]}")
            print("nodes " + "".join(f"{b:>12}" for b in args.bytes))
        values = np.round(row, DECIMALS).tolist()
        print(
            f"{n:>5} " + "".join("         n/a" if math.isnan(v) else f"{v:>12.2f}" for v in values)
        )
        if params == PAPER or (params.name == "paper" and table != EPL):
            for b, v in zip(args.bytes, values, strict=True):
                printed = paper_value(table, n, b)
                if printed is not None and not math.isnan(v):
                    deltas.append(abs(v - printed))
    close(current)
