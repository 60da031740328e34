"""``skinframes vectors --out DIR``: the conformance vector set (a pcap and its JSON Lines)."""

from __future__ import annotations

import argparse
from typing import Any

from skinframes import vectors
from skinframes.atomic_file import output_folder
from skinframes_cli.options import file_output


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
    p.add_argument(
        "--out",
        type=file_output,
        required=True,
        help="output directory; created if its parent exists",
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Write and report."""
    out = output_folder(args.out)  # created if its parent exists
    for path in vectors.write(out):
        print(path)
    return 0
