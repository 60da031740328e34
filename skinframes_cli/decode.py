"""``skinframes decode PATH [--json] [--taxels OUT.npy]``: every frame of a capture, as text or
JSON Lines; or the capture's taxels as a numpy array."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from skinframes.errors import SkinframesError
from skinframes.pcap import Capture
from skinframes.selection import FrameSelection
from skinframes.text import escape
from skinframes_cli.live import add_live, capture_input, file_input, is_live, report_records
from skinframes_cli.options import (
    add_skin_layout,
    bounded_int,
    file_output,
    frame_ranges,
    in_path,
    protocol_arg,
)
from skinframes_cli.streams import input_path


def open_capture(path: str) -> Capture:
    """The capture named on the command line, streamed; ``-`` is standard input."""
    return file_input(path)


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "decode",
        help="decode every frame of a pcap/pcapng (gzip too)",
        description="Decode every frame of a pcap or pcapng file (gzip too). "
        "Skipped records are reported on stderr with their reason. With --taxels, write the "
        "capture's skin taxels as a numpy array instead.",
    )
    p.add_argument(
        "path",
        nargs="?",
        type=in_path,
        metavar="PATH",
        help="capture file; - for standard input (or --iface)",
    )
    p.add_argument("--json", action="store_true", help="JSON Lines: one object per frame")
    p.add_argument(
        "--taxels",
        type=file_output,
        metavar="OUT",
        help="write the taxels (samples x nodes x 16 x 12, uint8) to OUT.npy; OUT.npz also "
        "holds time_ns and present",
    )
    add_skin_layout(p, "(with --taxels)")
    sel = p.add_argument_group("selection (as a display filter; not with --taxels)")
    protocol_arg(
        sel,
        "--protocol",
        choices=("epl", "ecat", "can", "other"),
        action="append",
        help="only frames of this protocol (repeat for several)",
    )
    sel.add_argument(
        "--node",
        type=bounded_int(0, 65535),
        action="append",
        metavar="N",
        help="only frames of node N (repeat for several): EPL src or dest N; EtherCAT a "
        "datagram addressed by position to slave N (0: next to the master)",
    )
    sel.add_argument(
        "--frames",
        type=frame_ranges,
        metavar="LIST",
        help="only these frame numbers (from 1, as Wireshark counts): N, A:B, A:, comma list",
    )
    sel.add_argument(
        "-c",
        "--count",
        type=bounded_int(1, 2**62),
        metavar="N",
        help="stop after N frames shown",
    )
    add_live(p, count=False)  # -c above: frames shown, captured live or read
    p.set_defaults(run=run)


def selection(args: argparse.Namespace) -> FrameSelection:
    """The display filter of ``--protocol``, ``--node`` and ``--frames``."""
    return FrameSelection(
        protocols=None if not args.protocol else frozenset(args.protocol),
        nodes=None if not args.node else frozenset(args.node),
        frames=args.frames,
    )


def run(args: argparse.Namespace) -> int:
    """Decode and print, record by record as the capture is read."""
    chosen = selection(args)
    if is_live(args):
        if args.taxels:
            raise SkinframesError(
                "--taxels reads a capture file twice; capture to a file first (--iface: "
                "decode, check, analyze)"
            )
        with capture_input(args, count=None) as live:
            return _listing(args, chosen, live, flush=True)
    if args.taxels:
        if chosen.active or args.count is not None:
            raise SkinframesError("--taxels: every frame is read; --protocol, --node, "
                                  "--frames and -c select frames to show")  # fmt: skip
        return _taxels(args)
    return _listing(args, chosen, open_capture(args.path), flush=False)


def _listing(args: argparse.Namespace, chosen: FrameSelection, capture: Any, *, flush: bool) -> int:
    """Print the selected frames of ``capture`` (a file's or a live one; ``flush``: each line
    as it comes, for a live capture read through a pipe)."""
    from skinframes.describe import JsonDescriber, describe_record  # here: check needs none

    out = sys.stdout
    decoded = shown = 0
    limit = args.count
    dumps = json.JSONEncoder(check_circular=False).encode
    describe = JsonDescriber()  # repeated frames: fields computed once
    records = iter(capture)
    for rec in records:
        decoded += 1
        if chosen.frames is not None:
            if chosen.past_last(rec.frame):
                break
            if not chosen.frame_wanted(rec.frame):
                continue
        if args.json:
            obj = describe(rec)
            if chosen.active and not chosen.matches(obj):
                continue
            out.write(dumps(obj) + "\n")
        else:
            obj, text = describe_record(rec)
            if chosen.active and not chosen.matches(obj):
                continue
            sec, ns = divmod(rec.time_ns, 1_000_000_000)  # exact: a float has no room for ns
            out.write(
                f"frame {rec.frame:<6} {f'{sec}.{ns:09d}':>20} {len(rec.data):>5}  {escape(text)}\n"
            )
        shown += 1
        if flush:
            out.flush()
        if limit is not None and shown >= limit:
            break
    close = getattr(records, "close", None)
    if close is not None:  # a stop before the end: the counts are of the records read
        close()
    report_records(
        capture.total,
        decoded,
        capture.skipped,
        capture.findings,
        where="capture" if flush else "file",
        suffix=f"; {shown} shown" if chosen.active or limit is not None else "",
    )
    return 0


def _taxels(args: argparse.Namespace) -> int:
    """``--taxels``: the array, streamed to a file written atomically; a one-line summary on
    stderr."""
    from skinframes.capture_taxels import TaxelStream, save_taxels

    with input_path(args.path) as path:  # read twice: standard input is copied to a file first
        stream = TaxelStream(path, nodes=args.nodes, bytes_per_node=args.bytes, layout=args.layout)
        done = save_taxels(stream, args.taxels)
    print(
        f"{escape(args.taxels)}: {done.samples} samples x {done.nodes} nodes x 16 x "
        f"12 taxels ({done.missing} node samples missing)",
        file=sys.stderr,
    )
    return 0
