"""``skinframes can SUBCOMMAND``: legacy CAN skin logs.

A nested command: each subcommand is one ``add_<name>(sub)`` function (it registers its parser
and ``set_defaults(run=...)``), listed explicitly in :data:`SUBCOMMANDS`, as the top-level
``COMMANDS`` lists modules. A subcommand may live in its own module and be added to the tuple.

``skinframes can decode LOG [--json]``: JSON Lines, one object per (board, triangle) sample
``{"time_ns", "board", "triangle", "taxels", "error", "out_of_range"}``; frames that are not skin
data are counted on stderr (docs/interface.md).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import Any, Final

from skinframes.canbus import (
    LEGACY_SKIN_CLASS,
    SKIN_CLASS,
    BoardCounts,
    FrameCounts,
    Malformed,
    Reassembler,
    TimedSample,
)
from skinframes.canbus.log import (
    PCAP_SUFFIXES,
    PYTHON_CAN_SUFFIXES,
    STREAM_SUFFIXES,
    CanLogReader,
    RecordCounts,
)
from skinframes.errors import CanLogFormatError
from skinframes.pcap import Skipped
from skinframes_cli.can_convert import add_convert
from skinframes_cli.options import add_can_log, can_log_suffix, int_list
from skinframes_cli.streams import STDIO, input_path

__all__ = ["SUBCOMMANDS", "add_decode", "add_parser", "board_text", "damage_report", "report"]

MAX_LISTED: Final = 10  # ids / malformed frames listed on stderr before "... N more"


def add_parser(sub: Any) -> None:
    """Register ``can`` and its subcommands."""
    p = sub.add_parser(
        "can",
        help="legacy CAN skin logs (decode, convert)",
        description="Legacy iCub skin CAN logs: any python-can format "
        f"({' '.join(PYTHON_CAN_SUFFIXES)}) or a SocketCAN pcap ({' '.join(PCAP_SUFFIXES)}).",
    )
    can_sub = p.add_subparsers(dest="can_command", required=True, metavar="CAN_COMMAND")
    for add in SUBCOMMANDS:
        add(can_sub)


def add_decode(sub: Any) -> None:
    """Register ``can decode``."""
    p = sub.add_parser(
        "decode",
        help="the skin samples of a CAN log",
        description="Reassemble the skin samples (head + tail frame per triangle) of a CAN log. "
        "Frames that are not skin data are counted on stderr, not errors.",
    )
    add_can_log(p, "CAN log (.log .asc .blf .trc .csv .db, .pcap; text .gz too)")
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
    """Decode and print the samples as the log is read; the accounting goes to stderr.

    Raises:
        CanLogFormatError: the log holds no CAN frame at all (exit 2).
    """
    suffix = can_log_suffix(args)
    if args.trace == STDIO and suffix.removesuffix(".gz") in STREAM_SUFFIXES:
        # read as it comes, each batch's samples printed at once: a pipe from a live logger
        reader = CanLogReader(STDIO, stream=sys.stdin.buffer, log_format=suffix)
        return _decode(args, reader, flush=True)
    with input_path(args.trace, suffix) as path:  # BLF, SQLite: a copy (they need a file)
        return _decode(args, CanLogReader(path))


def _decode(args: argparse.Namespace, reader: CanLogReader, *, flush: bool = False) -> int:
    r = Reassembler(boards=args.boards, skin_classes=(args.skin_class,))
    line = sample_json if args.json else sample_text
    write = sys.stdout.write
    feed, feed_data = r.feed, r.feed_data
    for batch in reader.batches():
        lines = []
        for item in batch:
            s = feed_data(item[0], item[1], item[2]) if isinstance(item, tuple) else feed(item)
            if s is not None:
                lines.append(line(s))
        write("".join(lines))
        if flush:
            sys.stdout.flush()
    counts = r.finish()
    records = reader.record_counts
    if records.decoded == 0:
        raise CanLogFormatError(f"{args.trace}: no CAN frames in {_records_text(records)}")
    report(counts, records, r.malformed, reader.damaged)
    return 0


def sample_text(s: TimedSample) -> str:
    """One text line of ``can decode``."""
    t = s.sample
    return (
        f"{s.time_ns / 1e9:>18.9f}  board {t.board:>2} triangle {t.triangle:>2}  "
        f"{bytes(t.taxels).hex(' ')}  error {t.error} out_of_range {t.out_of_range:#05x}\n"
    )


def sample_json(s: TimedSample) -> str:
    """One JSON line of ``can decode --json``: ``json.dumps(s.to_json())``, formatted directly."""
    t = s.sample
    return (
        f'{{"time_ns": {s.time_ns}, "board": {t.board}, "triangle": {t.triangle}, '
        f'"taxels": [{", ".join(map(str, t.taxels))}], "error": {t.error}, '
        f'"out_of_range": {t.out_of_range}}}\n'
    )


def _records_text(records: RecordCounts) -> str:
    reasons = "; ".join(f"{reason}: {n}" for reason, n in records.skipped_by_reason[:MAX_LISTED])
    more = len(records.skipped_by_reason) - MAX_LISTED
    return f"{records.records} records: {records.decoded} decoded, {records.skipped} skipped" + (
        f" ({reasons}{f'; ... {more} more reasons' if more > 0 else ''})" if reasons else ""
    )


def report(
    c: FrameCounts,
    records: RecordCounts,
    malformed: Sequence[Malformed],
    damaged: Sequence[Skipped],
) -> None:
    """The accounting of a decoded CAN log on stderr: frames, records, boards."""
    err = sys.stderr
    print(
        f"{c.frames + records.damaged} frames: {c.samples} skin samples "
        f"({c.sample_frames} frames), {c.other} not skin data, {c.error_frames} error frames, "
        f"{c.orphan_heads} orphan heads, {c.orphan_tails} orphan tails, {c.malformed} "
        f"malformed, {records.damaged} skipped",
        file=err,
    )
    if c.other_ids:
        shown = ", ".join(
            f"{i.arbitration_id:#x}{'x' if i.extended else ''}: {i.count}"
            for i in c.other_ids[:MAX_LISTED]
        )
        more = len(c.other_ids) - MAX_LISTED
        print(
            f"not skin data by id: {shown}" + (f", ... {more} more" if more > 0 else ""),
            file=err,
        )
    for m in malformed[:MAX_LISTED]:
        print(
            f"malformed skin frame {m.index} ({m.arbitration_id:#05x}): {m.reason}",
            file=err,
        )
    if c.malformed > MAX_LISTED:
        print(f"... {c.malformed - MAX_LISTED} more malformed", file=err)
    damage_report(damaged, records.damaged)
    print(f"{_records_text(records)}", file=err)
    for b in c.boards:
        print(f"{board_text(b, c.triangles)}", file=err)


def damage_report(damaged: Sequence[Skipped], count: int) -> None:
    """The damaged records of a CAN log on stderr (a truncated log: where its reader stopped),
    the first :data:`MAX_LISTED` with their index and reason; ``count``: all of them."""
    for s in damaged[:MAX_LISTED]:
        print(f"skipped record {s.index}: {s.reason}", file=sys.stderr)
    if count > MAX_LISTED:
        print(f"... {count - MAX_LISTED} more skipped records", file=sys.stderr)


def board_text(b: BoardCounts, triangles: int) -> str:
    """``board 14: 3 complete samples (16 triangles), 1 incomplete, 2 stray frames (0x4e0: 2)``."""
    stray = ", ".join(f"{i.arbitration_id:#05x}: {i.count}" for i in b.stray[:MAX_LISTED])
    more = len(b.stray) - MAX_LISTED
    return (
        f"board {b.board}{'' if b.skin_class == SKIN_CLASS else f' (class {b.skin_class})'}: "
        f"{b.complete} complete samples ({triangles} triangles), {b.incomplete} incomplete, "
        f"{b.stray_frames} stray frames"
        + (f" ({stray}{f', ... {more} more' if more > 0 else ''})" if stray else "")
    )


SUBCOMMANDS: Final[tuple[Callable[[Any], None], ...]] = (add_decode, add_convert)
