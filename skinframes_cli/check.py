"""``skinframes check PATH [--json] [--verbose]``: conformance findings; exit 1 when any is an error.

The text listing groups identical findings (same code, same EPL node) into one line with their
count and first and last frame (Wireshark's 1-based numbers), errors first, then warnings; info
findings only with ``--verbose``. ``--json`` keeps every instance.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from skinframes.check import CaptureReport, FrameFinding, check_capture, check_file
from skinframes.findings import Severity
from skinframes.text import escape
from skinframes_cli.live import add_live, capture_input, first_frames, is_live
from skinframes_cli.options import in_path
from skinframes_cli.progress import progress_bar


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "check",
        help="conformance findings for a capture (exit 1 on any error)",
        description="Check every frame of a capture against the EPL and EtherCAT frame rules: "
        "size and length fields, the datagram chain, padding, node ids, the EPL cycle order and "
        "frames of one sender overlapping on the wire. Identical findings are listed once, with "
        "their count and first and last frame; errors first. Exit status 1 when any finding is "
        "an error.",
    )
    p.add_argument(
        "path",
        nargs="?",
        type=in_path,
        metavar="PATH",
        help="capture file (pcap, pcapng, gzip); - for standard input",
    )
    p.add_argument("--json", action="store_true", help="one JSON document (every finding)")
    p.add_argument(
        "--verbose",
        "-v",
        action="store_true",
        help="list info findings too (by default only errors and warnings)",
    )
    p.add_argument(
        "--min-severity",
        choices=[str(s) for s in Severity],
        default=None,
        help="hide findings below this severity (default: warning in the listing, "
        "info with --verbose and in --json)",
    )
    add_live(p)
    p.set_defaults(run=run)


@dataclass
class Group:
    """Identical findings: one severity, code and EPL node."""

    severity: Severity
    code: str
    node: int | None
    message: str  # the first instance's
    count: int
    first: int  # record indexes
    last: int


def group(findings: Iterable[FrameFinding]) -> list[Group]:
    """Identical findings (severity, code, node) as groups, worst severity first, then by the
    first frame."""
    groups: dict[tuple[Severity, str, int | None], Group] = {}
    for f in findings:
        key = (f.finding.severity, f.finding.code, f.node)
        g = groups.get(key)
        if g is None:
            groups[key] = Group(*key, f.finding.message, 1, f.index, f.index)
        else:
            g.count += 1
            g.last = f.index
    return sorted(groups.values(), key=lambda g: (-g.severity, g.first))


def _frames(g: Group) -> str:
    # Wireshark numbers frames from 1; index -1 is the file itself
    if g.first < 0:
        return "file"
    if g.count == 1:
        return f"frame {g.first + 1}"
    return f"frames {g.first + 1}..{g.last + 1}"


def run(args: argparse.Namespace) -> int:
    """Check and report; the exit status survives a reader that leaves (``| head -1``)."""
    if is_live(args):
        with capture_input(args, args.count) as live:
            report = check_capture(live)
    else:
        report = _check_file(args)
    return _report(args, report)


def _check_file(args: argparse.Namespace) -> CaptureReport:
    with progress_bar(None, "frames") as advance:  # on a terminal only (no cost elsewhere)
        seen = advance if sys.stderr.isatty() else None
        if args.path == "-" or args.count is not None:
            report = check_capture(first_frames(args), progress=seen)
        else:
            report = check_file(args.path, progress=seen)
    return report


def _report(args: argparse.Namespace, report: CaptureReport) -> int:
    if args.min_severity is not None:
        floor = Severity[args.min_severity.upper()]
    else:
        floor = Severity.INFO if args.json or args.verbose else Severity.WARNING
    status = 1 if report.errors else 0
    try:
        if args.json:
            report.write_json(sys.stdout, floor)
            print()
        else:
            for g in group(report.findings.at_least(floor)):
                node = f"node {g.node}" if g.node is not None else ""
                line = f"{_frames(g)}  {g.severity!s:<7} {g.code:<22} x{g.count:<6} {node:<8} "
                print(f"{line}{escape(g.message)}".rstrip())
        sys.stdout.flush()
    except BrokenPipeError:
        from skinframes_cli import _quiet_stdout

        _quiet_stdout()
    if not args.json:
        counts = ", ".join(f"{k} {v}" for k, v in sorted(report.counts.items()))
        kinds = f" ({counts})" if counts else ""  # none for a capture without records
        hidden = len(report.findings) - report.findings.count_at_least(floor)
        more = f", {hidden} below {floor} not listed (--verbose lists them)" if hidden else ""
        print(
            f"{escape(report.path)}: {report.total} records{kinds}: "
            f"{report.errors} errors, {report.warnings} warnings{more}",
            file=sys.stderr,
        )
    return status
