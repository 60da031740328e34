"""``skinframes can SUBCOMMAND``: legacy CAN skin traces.

A nested command: each subcommand is one ``add_<name>(sub)`` function (it registers its parser
and ``set_defaults(run=...)``), listed explicitly in :data:`SUBCOMMANDS`, as the top-level
``COMMANDS`` lists modules. A subcommand may live in its own module and be added to the tuple.

``skinframes can decode TRACE [--json]``: JSON Lines, one object per (board, triangle) sample
``{"time_ns", "board", "triangle", "taxels", "error", "out_of_range"}``; frames that are not skin
data are counted on stderr (docs/interface.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from typing import Any, Final

from skinframes.canbus import LEGACY_SKIN_CLASS, SKIN_CLASS, FrameCounts
from skinframes.canbus.log import PCAP_SUFFIXES, PYTHON_CAN_SUFFIXES, CanLog, read_can_log
from skinframes_cli.can_convert import add_convert
from skinframes_cli.options import int_list

__all__ = ["SUBCOMMANDS", "add_decode", "add_parser"]

MAX_LISTED: Final = 10  # ids / malformed frames listed on stderr before "... N more"


def add_parser(sub: Any) -> None:
    """Register ``can`` and its subcommands."""
    p = sub.add_parser(
        "can",
        help="legacy CAN skin traces (decode, convert)",
        description="Legacy iCub skin CAN traces: any python-can format "
        f"({' '.join(PYTHON_CAN_SUFFIXES)}) or a SocketCAN pcap ({' '.join(PCAP_SUFFIXES)}).",
    )
    can_sub = p.add_subparsers(dest="can_command", required=True, metavar="CAN_COMMAND")
    for add in SUBCOMMANDS:
        add(can_sub)


def add_decode(sub: Any) -> None:
    """Register ``can decode``."""
    p = sub.add_parser(
        "decode",
        help="the skin samples of a CAN trace",
        description="Reassemble the skin samples (head + tail frame per triangle) of a CAN trace. "
        "Frames that are not skin data are counted on stderr, not errors.",
    )
    p.add_argument("trace", help="CAN trace (.log .asc .blf .trc .csv .db, .pcap; text .gz too)")
    p.add_argument(
        "--json", action="store_true", help="JSON Lines: one object per (board, triangle) sample"
    )
    p.add_argument(
        "--skin-class",
        type=int,
        choices=(SKIN_CLASS, LEGACY_SKIN_CLASS),
        default=SKIN_CLASS,
        help="identifier class of the skin frames: 4 (default), 3 for the legacy configuration",
    )
    p.add_argument(
        "--boards",
        type=int_list,
        default=None,
        help="board addresses to accept, e.g. 8:14 or 7,8,9,10 (default: any)",
    )
    p.set_defaults(run=run_decode)


def run_decode(args: argparse.Namespace) -> int:
    """Decode and print the samples; the accounting goes to stderr."""
    can_log = read_can_log(args.trace, boards=args.boards, skin_classes=(args.skin_class,))
    out = sys.stdout
    for s in can_log.samples:
        if args.json:
            out.write(json.dumps(s.to_json()) + "\n")
        else:
            t = s.sample
            taxels = " ".join(f"{v:02x}" for v in t.taxels)
            out.write(
                f"{s.time_ns / 1e9:>18.9f}  board {t.board:>2} triangle {t.triangle:>2}  {taxels}"
                f"  error {t.error} out_of_range {t.out_of_range:#05x}\n"
            )
    _report(can_log)
    return 0


def _report(can_log: CanLog) -> None:
    c: FrameCounts = can_log.counts
    err = sys.stderr
    print(
        f"skinframes: {can_log.total} frames: {c.samples} skin samples ({c.sample_frames} frames), "
        f"{c.other} not skin data, {c.error_frames} error frames, {c.orphan_heads} orphan heads, "
        f"{c.orphan_tails} orphan tails, {c.malformed} malformed, {len(can_log.skipped)} skipped",
        file=err,
    )
    if c.other_ids:
        shown = ", ".join(
            f"{i.arbitration_id:#x}{'x' if i.extended else ''}: {i.count}"
            for i in c.other_ids[:MAX_LISTED]
        )
        more = len(c.other_ids) - MAX_LISTED
        print(
            f"skinframes: not skin data by id: {shown}"
            + (f", ... {more} more" if more > 0 else ""),
            file=err,
        )
    for m in can_log.malformed[:MAX_LISTED]:
        print(
            f"skinframes: malformed skin frame {m.index} ({m.arbitration_id:#05x}): {m.reason}",
            file=err,
        )
    if len(can_log.malformed) > MAX_LISTED:
        print(f"skinframes: ... {len(can_log.malformed) - MAX_LISTED} more malformed", file=err)
    for s in can_log.skipped:
        print(f"skinframes: skipped record {s.index}: {s.reason}", file=err)


SUBCOMMANDS: Final[tuple[Callable[[Any], None], ...]] = (add_decode, add_convert)
