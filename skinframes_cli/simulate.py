"""``skinframes simulate {epl,ecat}``: run the virtual daisy chain with real frames."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from emulator.model.params import PRESETS
from emulator.net.ecat import LAYOUTS
from skinframes.errors import SkinframesError
from skinframes_cli.progress import progress_bar


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
    p.add_argument(
        "--closed-ring",
        "--redundant",
        dest="redundant",
        action="store_true",
        help="EtherCAT closed ring, Table III (--redundant: its old name)",
    )
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
    p.add_argument(
        "--startup",
        action="store_true",
        help="EtherCAT: begin with the master's start-up (scan, SII, mailbox, CoE reads, "
        "INIT->PREOP->SAFEOP->OP) on patches with a CoE mailbox",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the taxel contact patterns")
    p.add_argument(
        "--vlan",
        type=int,
        metavar="ID",
        help="tag every frame with this 802.1Q VLAN id (0..4094); the 4 bytes count on the wire",
    )
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Emulate and report."""
    from emulator.model.params import preset
    from emulator.net import simulate_ecat, simulate_epl
    from emulator.net.faults import FAULT_HELP, parse_fault

    if "help" in args.fault:
        print(FAULT_HELP)
        return 0
    faults = tuple(parse_fault(spec) for spec in args.fault)
    if args.protocol == "epl" and args.redundant:
        raise SkinframesError("--closed-ring (--redundant) applies to EtherCAT only")
    if args.startup and (args.protocol != "ecat" or args.redundant or faults):
        raise SkinframesError("--startup: EtherCAT on an open ring without --fault only")
    if args.protocol == "ecat" and (args.asnd or args.pres_timeout_us is not None):
        raise SkinframesError("--asnd and --pres-timeout-us apply to EPL only")
    params = preset(args.preset)
    timeout = None
    if args.pres_timeout_us is not None:
        if not math.isfinite(args.pres_timeout_us) or not 0 <= args.pres_timeout_us <= 1e9:
            raise SkinframesError(f"--pres-timeout-us {args.pres_timeout_us}: 0..1e9 us")
        timeout = round(args.pres_timeout_us * 1e6)
    if args.pcap == "":
        raise SkinframesError("--pcap: an empty file name")
    with progress_bar(args.cycles, "cycles") as bar:
        if args.protocol == "epl":
            result = simulate_epl(
                args.nodes,
                args.bytes,
                params,
                cycles=args.cycles,
                seed=args.seed,
                asnd=args.asnd,
                pres_timeout_ps=timeout,
                faults=faults,
                pcap=args.pcap,
                progress=bar,
                vlan=args.vlan,
            )
        else:
            result = simulate_ecat(
                args.nodes,
                args.bytes,
                params,
                closed_ring=args.redundant,
                layout=args.layout,
                cycles=args.cycles,
                seed=args.seed,
                faults=faults,
                pcap=args.pcap,
                progress=bar,
                startup=args.startup,
                vlan=args.vlan,
            )
    if args.json:
        print(json.dumps(result.to_json(), indent=2))
        return 0
    c = result.cycle_us()
    print(
        f"{result.protocol} {result.topology}: {result.nodes} nodes x {result.bytes} bytes, "
        f"preset {result.preset}, layout {result.layout}"
    )
    print(f"  cycles {result.cycles}, frames {result.frames}")
    if result.startup_us is not None:
        print(f"  start-up: {result.startup_frames} frames, {result.startup_us:.3f} us")
    print(
        f"  cycle time: min {c['min']:.3f} us, median {c['median']:.3f} us, max {c['max']:.3f} us"
    )
    if faults:
        wkc = ", ".join(f"{d.cycle}: {d.wkc}/{d.expected_wkc}" for d in result.details)
        print(f"  working counter (got/expected) from cycle on: {wkc}")
        if result.recovery_us is not None:
            print(f"  recovery: {result.recovery_us:g} us")
        for line in result.diagnosis:
            print(f"  diagnosis: {line}")
    if result.pcap:
        print(f"  pcap: {result.pcap}")
    return 0
