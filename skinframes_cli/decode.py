"""``skinframes decode PATH [--json] [--taxels OUT.npy]``: every frame of a capture, as text or
JSON Lines; or the capture's taxels as a numpy array."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from skinframes.errors import PcapFormatError
from skinframes.pcap import Capture, read_capture
from skinframes.text import escape
from skinframes_cli.options import add_skin_layout


def open_capture(path: str) -> Capture:
    """The capture named on the command line, streamed; ``-`` is standard input."""
    if path == "-":
        return read_capture(sys.stdin.buffer)
    return read_capture(path)


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "decode",
        help="decode every frame of a pcap/pcapng (gzip too)",
        description="Decode every frame of a pcap or pcapng file (gzip too). "
        "Skipped records are reported on stderr with their reason. With --taxels, write the "
        "capture's skin taxels as a numpy array instead.",
    )
    p.add_argument("path", help="capture file; - for standard input")
    p.add_argument("--json", action="store_true", help="JSON Lines: one object per frame")
    p.add_argument(
        "--taxels",
        metavar="OUT",
        help="write the taxels (samples x nodes x 16 x 12, uint8) to OUT.npy; OUT.npz also "
        "holds time_ns and present",
    )
    add_skin_layout(p, "(with --taxels)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Decode and print, record by record as the capture is read."""
    if args.taxels:
        return _taxels(args)
    from skinframes.describe import JsonDescriber, describe_record  # here: check needs none

    capture = open_capture(args.path)
    out = sys.stdout
    decoded = 0
    if args.json:
        dumps = json.JSONEncoder(check_circular=False).encode
        describe = JsonDescriber()  # repeated frames: fields computed once
        for rec in capture:
            decoded += 1
            out.write(dumps(describe(rec)) + "\n")
    else:
        for rec in capture:
            decoded += 1
            _, text = describe_record(rec)
            sec, ns = divmod(rec.time_ns, 1_000_000_000)  # exact: a float has no room for ns
            out.write(
                f"frame {rec.frame:<6} {f'{sec}.{ns:09d}':>20} {len(rec.data):>5}  {escape(text)}\n"
            )
    for s in capture.skipped:
        print(f"skinframes: skipped frame {s.frame}: {escape(s.reason)}", file=sys.stderr)
    for f in capture.findings:
        where = f"frame {f.frame}" if f.index >= 0 else "file"
        print(f"skinframes: {where}: {escape(f.finding.message)}", file=sys.stderr)
    print(
        f"skinframes: {capture.total} records: {decoded} decoded, {len(capture.skipped)} skipped",
        file=sys.stderr,
    )
    return 0


def _taxels(args: argparse.Namespace) -> int:
    """``--taxels``: the array, streamed to a file written atomically; a one-line summary on
    stderr."""
    from skinframes.capture_taxels import TaxelStream, save_taxels

    if args.path == "-":
        raise PcapFormatError("decode --taxels reads a capture file, not standard input")
    stream = TaxelStream(args.path, nodes=args.nodes, bytes_per_node=args.bytes, layout=args.layout)
    done = save_taxels(stream, args.taxels)
    print(
        f"skinframes: {escape(args.taxels)}: {done.samples} samples x {done.nodes} nodes x 16 x "
        f"12 taxels ({done.missing} node samples missing)",
        file=sys.stderr,
    )
    return 0
