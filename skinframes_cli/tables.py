"""``skinframes tables``: cycle-time tables in the layout of the paper's Tables I-III."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterable
from typing import Any

from emulator.model.cycle_time import MODELS
from emulator.model.paper_tables import paper_value
from emulator.model.params import PRESETS, preset
from emulator.model.tables import Cell, cycle_tables
from skinframes_cli.options import int_list, int_list_in

MAX_NODES = 65535  # the largest EtherCAT chain (16-bit position address); EPL stops at 239
MAX_BYTES = 65535

TITLES = {
    "epl": "Table I: Ethernet POWERLINK cycle time [us]",
    "ecat": "Table II: EtherCAT cycle time, non-redundant (open ring) [us]",
    "ecat_redundant": "Table III: EtherCAT cycle time, redundant (closed ring) [us]",
}


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "tables",
        help="cycle-time tables (the paper's Tables I-III by default)",
        description="Cycle times of EPL and EtherCAT (open and closed ring) for each number of "
        "nodes and payload size. With --preset paper the printed paper value and the difference "
        "are shown where the paper has that cell.",
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
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.set_defaults(run=run)


def _progress(model: str) -> Callable[[list[Cell]], Iterable[Cell]]:
    """A progress bar on a terminal when emulating many cells."""

    def wrap(cells: list[Cell]) -> Iterable[Cell]:
        from tqdm import tqdm

        show = model == "emulated" and len(cells) > 50 and sys.stderr.isatty()
        return tqdm(cells, desc="cycles", unit="cell", disable=not show)

    return wrap


def run(args: argparse.Namespace) -> int:
    """Print the tables."""
    doc = cycle_tables(
        args.model, preset(args.preset), args.nodes, args.bytes, progress=_progress(args.model)
    )
    if args.json:
        print(json.dumps(doc, indent=2))
        return 0
    print(f"model {doc['model']}, preset {doc['preset']}")
    for table, title in TITLES.items():
        print(f"\n{title}")
        print("nodes " + "".join(f"{b:>12}" for b in args.bytes))
        deltas = []
        for n in args.nodes:
            row = doc[table][str(n)]
            print(f"{n:>5} " + "".join(f"{row[str(b)]:>12.2f}" for b in args.bytes))
            if args.preset == "paper":
                for b in args.bytes:
                    printed = paper_value(table, n, b)
                    if printed is not None:
                        deltas.append(abs(row[str(b)] - printed))
        if deltas:
            print(
                f"      {len(deltas)} cells printed in the paper; largest difference "
                f"{max(deltas):.4f} us (the paper rounds to 0.01)"
            )
    return 0
