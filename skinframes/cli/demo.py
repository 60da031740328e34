"""``skinframes demo [--out DIR]``: the main job on defaults."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from skinframes import golden
from skinframes.check import check_capture
from skinframes.pcap import read_capture, write_pcap


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "demo",
        help="the main job: write pcaps for a 160-patch skin and report",
        description="Write the reference captures under DIR and check them.",
    )
    p.add_argument("--out", default="out", help="output directory (default: ./out)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Write every golden scenario and decode it back."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"Reference frames ({out}/):")
    for name in golden.SCENARIOS:
        path = out / f"{name}.pcap"
        n = write_pcap(path, golden.build(name))
        report = check_capture(read_capture(path))
        status = (
            "ok"
            if not report.errors and not report.warnings
            else (f"{report.errors} errors, {report.warnings} warnings")
        )
        print(f"  {path}  {n:>3} frames  check: {status}")
    return 0
