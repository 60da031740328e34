"""``skinframes can convert LOG --to epl|ecat --pcap OUT``: a CAN log's samples on Ethernet."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from emulator.model.params import PRESETS
from skinframes.protocols import PROTOCOLS
from skinframes_cli.options import add_can_log, can_log_suffix, protocol_arg
from skinframes_cli.simulate import LARGE_PCAP_BYTES


def add_convert(sub: Any) -> None:
    """Register ``can convert``."""
    p = sub.add_parser(
        "convert",
        help="carry a CAN log's skin samples over EPL or EtherCAT (pcap)",
        description="Every complete skin sample of the log, in order, becomes one emulated cycle "
        "(a cycle: one complete sample of each board; incomplete samples and stray frames are "
        "left out and counted on stderr) "
        "on EPL (one CN per board, the board's taxels as PRes payload) or EtherCAT (one slave per "
        "board, its taxels in its datagram); the frames are timed by the emulator and written "
        "as a pcap. Boards are numbered in ascending address order (CN 1 / slave 0 = the lowest).",
    )
    add_can_log(p, "CAN log (.log .asc .blf .trc .csv, or a SocketCAN pcap)")
    protocol_arg(p, "--to", choices=PROTOCOLS, required=True, dest="target")
    p.add_argument(
        "--pcap", required=True, help="output pcap; - streams a pcapng to stdout (report: stderr)"
    )
    p.add_argument(
        "--allow-large-pcap",
        action="store_true",
        help=f"write a --pcap file estimated above {LARGE_PCAP_BYTES / 1e9:g} GB (refused "
        "without it, before anything is written; as simulate)",
    )
    p.add_argument(
        "--preset", choices=list(PRESETS), default="wire", help="timing constants (default: wire)"
    )
    p.add_argument(
        "--closed-ring",
        "--redundant",
        dest="redundant",
        action="store_true",
        help="EtherCAT closed ring (--redundant: its old name)",
    )
    p.set_defaults(run=run_convert)


def run_convert(args: argparse.Namespace) -> int:
    """Convert and report."""
    from skinframes.errors import SkinframesError
    from skinframes_cli.streams import input_path

    if args.target == "epl" and args.redundant:
        raise SkinframesError("--closed-ring (--redundant) applies to EtherCAT only")
    with input_path(args.trace, can_log_suffix(args)) as path:
        return _convert(args, path)


def _convert(args: argparse.Namespace, trace: str) -> int:
    import functools

    from emulator.model.params import preset
    from emulator.net import simulate_ecat, simulate_epl
    from emulator.skin_samples import SkinLog
    from skinframes_cli.can import damage_report  # can imports this module
    from skinframes_cli.progress import progress_bar
    from skinframes_cli.simulate import STDOUT, check_pcap_size, pcap_target

    with progress_bar(None, "frames") as seen:  # the first pass: the cycle of each sample
        log = SkinLog.open(trace, progress=seen)
    params = preset(args.preset)
    n, size, cycles = len(log.boards), log.data_bytes, log.samples
    ports = 2 if args.target == "ecat" and args.redundant else 1
    one_cycle = (  # the same network's cycle, its taxels aside: they do not change its bytes
        functools.partial(simulate_epl, n, size, params)
        if args.target == "epl"
        else functools.partial(simulate_ecat, n, size, params, closed_ring=args.redundant)
    )
    check_pcap_size(args.pcap, cycles, args.allow_large_pcap, ports, one_cycle)
    with (
        progress_bar(cycles, "cycles") as bar,
        pcap_target(args.pcap, ports, params.link_rate_bps) as target,
    ):
        payloads = log.taxel_chunks()  # the second pass, as the cycles need them
        if args.target == "epl":
            r = simulate_epl(
                n, size, params, cycles=cycles, payloads=payloads, progress=bar, **target
            )
        else:
            r = simulate_ecat(
                n,
                size,
                params,
                closed_ring=args.redundant,
                cycles=cycles,
                payloads=payloads,
                progress=bar,
                **target,
            )
    print(
        f"{cycles} samples of {n} boards ({', '.join(map(str, log.boards))}) x {size} bytes -> "
        f"{r.frames} frames, {r.protocol} {r.topology}, cycle {r.cycle_us()['median']:.2f} us "
        f"({args.preset} preset): {args.pcap}",
        file=sys.stderr if args.pcap == STDOUT else sys.stdout,  # stdout carries the capture
    )
    if log.left_out.anything:
        print(log.left_out.text(), file=sys.stderr)
    damage_report(log.left_out.damaged, log.left_out.damaged_records)
    return 0
