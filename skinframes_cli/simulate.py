"""``skinframes simulate {epl,ecat}``: run the virtual daisy chain with real frames."""

from __future__ import annotations

import argparse
import json
from typing import Any

from emulator.ecat_cycle import LAYOUTS
from emulator.params import PRESETS
from skinframes.errors import SkinframesError


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "simulate",
        help="emulate EPL or EtherCAT cycles with real frames (pcap optional)",
        description="Emulate a daisy chain of skin patches: EPL (MN + CNs behind hubs) or "
        "EtherCAT (master + ESC slaves, open or closed ring). Cycle time is measured from the "
        "emulated frames' timestamps at the master's port.",
    )
    p.add_argument("protocol", choices=["epl", "ecat"])
    p.add_argument("--nodes", type=int, required=True, help="CNs / slaves (patches)")
    p.add_argument("--bytes", type=int, required=True, help="taxel bytes per node (192 = a patch)")
    p.add_argument("--redundant", action="store_true", help="EtherCAT closed ring (Table III)")
    p.add_argument("--preset", choices=list(PRESETS), default="paper")
    p.add_argument(
        "--layout",
        choices=list(LAYOUTS),
        default="per-slave",
        help="EtherCAT: one LRD per slave (paper) or a contiguous logical image",
    )
    p.add_argument("--cycles", type=int, default=4, help="cycles to emulate (default 4)")
    p.add_argument(
        "--asnd",
        action="store_true",
        help="EPL: each SoA invites one CN in turn, which answers with an ASnd "
        "(StatusResponse); the paper assumes no asynchronous frames",
    )
    p.add_argument(
        "--pres-timeout-us",
        type=float,
        metavar="US",
        help="EPL: the MN's PRes timeout; rejected if a CN cannot meet it",
    )
    p.add_argument(
        "--pcap",
        help="write the frames at the master's port to this pcap "
        "(.pcapng: with direction flags, and marks on deliberately corrupted frames)",
    )
    p.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="SPEC",
        help="inject a fault ('--fault help' lists the kinds)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the taxel contact patterns")
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Emulate and report."""
    from emulator.faults import FAULT_HELP, parse_fault
    from emulator.model import simulate
    from emulator.params import preset

    if "help" in args.fault:
        print(FAULT_HELP)
        return 0
    faults = tuple(parse_fault(spec) for spec in args.fault)
    if args.protocol == "epl" and args.redundant:
        raise SkinframesError("--redundant applies to EtherCAT only")
    if args.protocol == "ecat" and (args.asnd or args.pres_timeout_us is not None):
        raise SkinframesError("--asnd and --pres-timeout-us apply to EPL only")
    if faults and args.asnd:
        raise SkinframesError("--asnd cannot be combined with --fault yet")
    params = preset(args.preset)
    timeout = None if args.pres_timeout_us is None else round(args.pres_timeout_us * 1e6)
    if args.protocol == "epl" and faults:
        from emulator.epl_faults import simulate_epl_faults

        result = simulate_epl_faults(
            args.nodes,
            args.bytes,
            params,
            faults,
            cycles=args.cycles,
            seed=args.seed,
            pres_timeout_ps=timeout,
        )
    elif args.protocol == "epl":
        from emulator.epl_cycle import simulate_epl

        result = simulate_epl(
            args.nodes,
            args.bytes,
            params,
            cycles=args.cycles,
            seed=args.seed,
            asnd=args.asnd,
            pres_timeout_ps=timeout,
        )
    elif faults:
        from emulator.ecat_faults import simulate_ecat_faults

        result = simulate_ecat_faults(
            args.nodes,
            args.bytes,
            params,
            faults,
            redundant=args.redundant,
            layout=args.layout,
            cycles=args.cycles,
            seed=args.seed,
        )
    else:
        table = "ecat_redundant" if args.redundant else "ecat"
        result = simulate(
            table,
            args.nodes,
            args.bytes,
            params,
            layout=args.layout,
            cycles=args.cycles,
            seed=args.seed,
        )
    result.trace.check_no_overlap()
    if args.pcap:
        result.trace.write_pcap(args.pcap)
        result.pcap = args.pcap
    if args.json:
        print(json.dumps(result.to_json(), indent=2))
        return 0
    c = result.cycle_us()
    print(
        f"{result.protocol} {result.topology}: {result.nodes} nodes x {result.bytes} bytes, "
        f"preset {result.preset}, layout {result.layout}"
    )
    print(f"  cycles {result.cycles}, frames {result.frames}")
    print(
        f"  cycle time: min {c['min']:.3f} us, median {c['median']:.3f} us, max {c['max']:.3f} us"
    )
    if faults:
        wkc = ", ".join(f"{d.wkc}/{d.expected_wkc}" for d in result.details)
        print(f"  working counter per cycle (got/expected): {wkc}")
        if result.recovery_us is not None:
            print(f"  recovery: {result.recovery_us:g} us")
        for line in result.diagnosis:
            print(f"  diagnosis: {line}")
    if result.pcap:
        print(f"  pcap: {result.pcap}")
    return 0
