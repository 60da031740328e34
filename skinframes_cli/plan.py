"""``skinframes plan --nodes N --bytes B``: the fastest frame layout per protocol."""

from __future__ import annotations

import argparse
import json
from typing import Any


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "plan",
        help="the frame/datagram layout that minimises cycle time, per protocol",
        description="For EPL and EtherCAT (open and closed ring), emulate each frame layout, "
        "pick the fastest and compare it with the physical limit: N x B bytes at 100 Mbit/s.",
    )
    p.add_argument("--nodes", type=int, required=True)
    p.add_argument("--bytes", type=int, required=True)
    p.add_argument(
        "--preset",
        choices=["paper", "wire"],
        default="wire",
        help="timing constants (default: wire)",
    )
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.set_defaults(run=run)


def plan(nodes: int, data_bytes: int, preset_name: str) -> dict[str, Any]:
    """The plan document (also the JSON output)."""
    from emulator.model import simulate, validate
    from emulator.params import preset
    from emulator.trace import CycleTrace

    params = preset(preset_name)
    limit_us = nodes * data_bytes * params.byte_ps / 1e6
    doc: dict[str, Any] = {
        "nodes": nodes,
        "bytes": data_bytes,
        "preset": preset_name,
        "limit_us": limit_us,
    }
    for table, layouts in (
        ("epl", ("per-slave",)),
        ("ecat", ("per-slave", "logical")),
        ("ecat_redundant", ("per-slave", "logical")),
    ):
        validate(table, nodes, data_bytes)
        options: list[dict[str, Any]] = []
        for layout in layouts:
            r = simulate(table, nodes, data_bytes, params, layout=layout, cycles=1)
            assert isinstance(r.trace, CycleTrace)  # fault-free runs keep the per-cycle layout
            options.append(
                {
                    "layout": layout,
                    "cycle_us": r.cycle_us()["median"],
                    "frames_per_cycle": r.trace.frames_sent_per_cycle
                    if table != "epl"
                    else r.frames // r.cycles,
                }
            )
        best = min(options, key=lambda o: float(o["cycle_us"]))
        doc[table] = {
            **best,
            "overhead_us": best["cycle_us"] - limit_us,
            "efficiency": limit_us / best["cycle_us"],
            "alternatives": options,
        }
    return doc


def run(args: argparse.Namespace) -> int:
    """Print the plan."""
    doc = plan(args.nodes, args.bytes, args.preset)
    if args.json:
        print(json.dumps(doc, indent=2))
        return 0
    print(
        f"{args.nodes} nodes x {args.bytes} bytes, preset {args.preset}: physical limit "
        f"{doc['limit_us']:.2f} us (N x B bytes at 100 Mbit/s)"
    )
    names = {"epl": "EPL", "ecat": "EtherCAT open ring", "ecat_redundant": "EtherCAT closed ring"}
    for table, name in names.items():
        d = doc[table]
        others = ", ".join(f"{o['layout']} {o['cycle_us']:.2f} us" for o in d["alternatives"])
        print(
            f"  {name:<22} best {d['layout']:<9} {d['cycle_us']:>10.2f} us "
            f"({d['frames_per_cycle']} frames per cycle, {100 * d['efficiency']:.1f} % of the limit)"
            f"   [{others}]"
        )
    return 0
