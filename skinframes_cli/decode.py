"""``skinframes decode PATH [--json]``: every frame of a capture, as text or JSON Lines."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from skinframes.describe import describe_record
from skinframes.pcap import read_capture


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "decode",
        help="decode every frame of a pcap/pcapng (gzip too)",
        description="Decode every frame of a pcap or pcapng file (gzip too). "
        "Skipped records are reported on stderr with their reason.",
    )
    p.add_argument("path", help="capture file")
    p.add_argument("--json", action="store_true", help="JSON Lines: one object per frame")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Decode and print."""
    capture = read_capture(args.path)
    out = sys.stdout
    for rec in capture:
        obj, text = describe_record(rec)
        if args.json:
            out.write(json.dumps(obj) + "\n")
        else:
            sec, ns = divmod(rec.time_ns, 1_000_000_000)  # exact: a float has no room for ns
            out.write(f"{rec.index:>6} {f'{sec}.{ns:09d}':>20} {len(rec.data):>5}  {text}\n")
    for s in capture.skipped:
        print(f"skinframes: skipped record {s.index}: {s.reason}", file=sys.stderr)
    print(
        f"skinframes: {capture.total} records: {len(capture.records)} decoded, "
        f"{len(capture.skipped)} skipped",
        file=sys.stderr,
    )
    return 0
