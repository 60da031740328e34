"""``skinframes check PATH [--json]``: conformance findings; exit 1 when any is an error."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from skinframes.check import check_capture
from skinframes.findings import Severity
from skinframes.text import escape
from skinframes_cli.decode import open_capture


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "check",
        help="conformance findings for a capture (exit 1 on any error)",
        description="Check every frame of a capture against the EPL and EtherCAT frame rules: "
        "size and length fields, the datagram chain, padding, node ids and the EPL cycle order. "
        "Exit status 1 when any finding is an error.",
    )
    p.add_argument("path", help="capture file (pcap, pcapng, gzip); - for standard input")
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.add_argument(
        "--min-severity",
        choices=[str(s) for s in Severity],
        default="info",
        help="hide findings below this severity in the listing (default: info)",
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check and report; the exit status survives a reader that leaves (``| head -1``)."""
    report = check_capture(open_capture(args.path))
    floor = Severity[args.min_severity.upper()]
    status = 1 if report.errors else 0
    try:
        if args.json:
            print(json.dumps(report.to_json(floor), indent=2))
        else:
            for f in report.at_least(floor):
                where = f"frame {f.frame:>6}" if f.index >= 0 else "file        "
                print(
                    f"{where}  {f.finding.severity!s:<7} {f.finding.code:<22} "
                    f"{escape(f.finding.message)}"
                )
        sys.stdout.flush()
    except BrokenPipeError:
        from skinframes_cli import _quiet_stdout

        _quiet_stdout()
    if not args.json:
        counts = ", ".join(f"{k} {v}" for k, v in sorted(report.counts.items()))
        print(
            f"{escape(report.path)}: {report.total} records ({counts}): "
            f"{report.errors} errors, {report.warnings} warnings",
            file=sys.stderr,
        )
    return status
