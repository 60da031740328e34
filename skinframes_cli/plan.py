"""``skinframes plan --nodes N --bytes B``: the fastest frame layout per protocol."""

from __future__ import annotations

import argparse
import json
from typing import Any

from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL, JSON_KEYS_HELP, TABLES
from emulator.model.params import PRESETS
from emulator.model.plan import LAYOUTS_IN_ALL, plan
from skinframes_cli.options import add_cn_response, bounded_int, timing
from skinframes_cli.progress import progress_bar

NAMES = {EPL: "EPL", ECAT: "EtherCAT open ring", ECAT_CLOSED_RING: "EtherCAT closed ring"}


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "plan",
        help="the frame/datagram layout that minimises cycle time, per protocol",
        description="For EPL and EtherCAT (open and closed ring), emulate each frame layout, "
        "pick the fastest and compare it with the physical limit: N x B bytes at 100 Mbit/s.",
    )
    p.add_argument("--nodes", type=bounded_int(1, 65535), required=True, help="nodes, 1..65535")
    p.add_argument(
        "--bytes", type=bounded_int(0, 65535), required=True, help="bytes per node, 0..65535"
    )
    p.add_argument(
        "--preset",
        choices=list(PRESETS),
        default="wire",
        help="timing constants (default: wire)",
    )
    add_cn_response(p)
    p.add_argument("--json", action="store_true", help=f"one JSON document; {JSON_KEYS_HELP}")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print the plan."""
    params = timing(args)
    with progress_bar(LAYOUTS_IN_ALL, "layouts") as step:
        result = plan(args.nodes, args.bytes, params, progress=step, skip_impossible=True)
    if args.json:
        print(json.dumps(result.to_json(), indent=2))
        return 0
    print(
        f"{args.nodes} nodes x {args.bytes} bytes, preset {params.label}: physical limit "
        f"{result.limit_us:.2f} us (N x B bytes at 100 Mbit/s)"
    )
    for table in TABLES:
        network = result.networks.get(table)
        if network is None:
            print(f"  {NAMES[table]:<22} n/a: {result.not_applicable[table]}")
            continue
        best = network.best
        others = ", ".join(f"{o.layout} {o.cycle_us:.2f} us" for o in network.alternatives)
        print(
            f"  {NAMES[table]:<22} best {best.layout:<9} {best.cycle_us:>10.2f} us "
            f"({best.frames_per_cycle} frame{'s' * (best.frames_per_cycle != 1)} per cycle, {100 * network.efficiency:.1f} % of the "
            f"limit)   [{others}; eqs. 3-19: {network.analytic_us:.2f} us]"
        )
    return 0
