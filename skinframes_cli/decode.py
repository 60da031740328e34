"""``skinframes decode PATH [--json]``: every frame of a capture, as text or JSON Lines."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from skinframes.describe import describe_record
from skinframes.pcap import Capture, read_capture
from skinframes.text import escape


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
        "Skipped records are reported on stderr with their reason.",
    )
    p.add_argument("path", help="capture file; - for standard input")
    p.add_argument("--json", action="store_true", help="JSON Lines: one object per frame")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Decode and print, record by record as the capture is read."""
    capture = open_capture(args.path)
    out = sys.stdout
    decoded = 0
    for rec in capture:
        decoded += 1
        obj, text = describe_record(rec)
        if args.json:
            obj.setdefault("frame", rec.frame)
            out.write(json.dumps(obj) + "\n")
        else:
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
