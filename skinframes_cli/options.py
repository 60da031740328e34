"""Option parsers shared by several subcommands."""

from __future__ import annotations

import argparse


def int_list(text: str) -> list[int]:
    """``start:stop:step`` (stop inclusive) or a comma list, e.g. ``130:200:10`` or ``2,32``."""
    try:
        if ":" in text:
            parts = [int(p) for p in text.split(":")]
            if len(parts) not in (2, 3) or (len(parts) == 3 and parts[2] <= 0):
                raise ValueError
            start, stop = parts[0], parts[1]
            step = parts[2] if len(parts) == 3 else 1
            values = list(range(start, stop + 1, step))
        else:
            values = [int(p) for p in text.split(",") if p.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected start:stop:step (stop inclusive) or a comma list of integers"
        ) from None
    if not values:
        raise argparse.ArgumentTypeError(f"{text!r} selects no values")
    return values


def add_skin_layout(p: argparse.ArgumentParser, what: str) -> None:
    """``--nodes N --bytes B --layout L``: where a capture's taxels sit (default: inferred)."""
    p.add_argument(
        "--nodes", type=int, help=f"EPL CNs / EtherCAT slaves {what} (default: inferred)"
    )
    p.add_argument(
        "--bytes", type=int, help=f"taxel bytes per node {what} (default: inferred; 192 = a patch)"
    )
    p.add_argument(
        "--layout",
        choices=["per-slave", "logical"],
        help=f"EtherCAT process image {what}: one LRD per slave, or one contiguous logical image "
        "(default: inferred)",
    )
