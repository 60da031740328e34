"""``skinframes vectors --out DIR``: the conformance vector set (a pcap and its JSON Lines)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from skinframes import vectors
from skinframes.errors import SkinframesError


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "vectors",
        help="write the conformance vector set (pcap + JSON Lines) for other implementations",
        description="Write vectors.pcap and vectors.jsonl into DIR: every EPL message type and "
        "ASnd service, every EtherCAT command and frame type, VLAN and UDP forms, size edges and "
        "the malformed cases check knows; line N of the JSON Lines states frame N's expected "
        "fields (Wireshark's names) and findings.",
    )
    p.add_argument("--out", required=True, help="an existing directory")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Write and report."""
    out = Path(args.out)
    if not out.is_dir():
        raise SkinframesError(f"--out {args.out}: not an existing directory")
    for path in vectors.write(out):
        print(path)
    return 0
