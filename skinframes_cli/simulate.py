"""``skinframes simulate {epl,ecat}``: run the virtual daisy chain with real frames."""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import math
import sys
from collections.abc import Callable, Iterator
from typing import Any, Final

from emulator.model.limits import MAX_SLAVES
from emulator.model.params import PRESETS
from emulator.net.ecat import LAYOUTS
from skinframes.errors import SkinframesError
from skinframes.protocols import PROTOCOLS
from skinframes.text import escape
from skinframes_cli.options import (
    add_cn_response,
    bounded_float,
    bounded_int,
    in_path,
    out_path,
    protocol_arg,
    timing,
)
from skinframes_cli.progress import progress_bar

MAX_CYCLES = 1_000_000  # --cycles: 1..MAX_CYCLES
MAX_SEED = 2**32 - 1  # numpy's legacy seed range
MAX_NODE_BYTES = 65535  # --bytes at parse level; the protocol's own limit is checked when run
MAX_TIMEOUT_US = 1e9  # --pres-timeout-us: 0..1e9 us
MAX_LATE_US = 1e9  # --fault late:N:US
MAX_FAULT_SPEC = 100  # characters


def fault_spec(text: str) -> str:
    """An argparse ``type`` for ``--fault``: a SPEC ``parse_fault`` accepts, with finite values."""
    from emulator.net.faults import parse_fault

    if text == "help":
        return text
    if len(text) > MAX_FAULT_SPEC:
        raise argparse.ArgumentTypeError(f"a fault SPEC of {len(text)} characters")
    try:
        fault = parse_fault(text)
    except (SkinframesError, ValueError, OverflowError) as exc:
        raise argparse.ArgumentTypeError(escape(exc)) from None
    if not math.isfinite(fault.value) or fault.value > MAX_LATE_US:
        raise argparse.ArgumentTypeError(
            f"fault {escape(text)!r}: {fault.value:g} is not a finite value up to {MAX_LATE_US:g}"
        )
    return text


STDOUT: Final = "-"  # --pcap -: the capture on standard output, as tshark -w - writes it
PORT_NAMES: Final = ("master port 0", "master port 1")  # emulator.net.api names them so too
LARGE_PCAP_BYTES: Final = 4_000_000_000  # a pcap file estimated larger needs --allow-large-pcap


def check_pcap_size(
    path: str | None, cycles: int, allow: bool, ports: int, one_cycle: Callable[..., Any]
) -> None:
    """Refuse (before anything is written) a pcap file estimated above
    :data:`LARGE_PCAP_BYTES` unless ``allow``: ``one_cycle(cycles=1, sink=...)`` runs the same
    network for one cycle into a byte counter (:func:`emulator.net.api.estimated_capture_bytes`),
    the estimate is that times ``cycles``. A stream (``-``) is the reader's to stop and is not
    checked."""
    from emulator.net.api import estimated_capture_bytes
    from skinframes.capture_writer import capture_format

    if path is None or path == STDOUT or allow or cycles <= 1:
        return
    fmt = capture_format(path)
    estimate, one = estimated_capture_bytes(one_cycle, cycles, fmt=fmt, ports=ports, name=path)
    if estimate > LARGE_PCAP_BYTES:
        raise SkinframesError(
            f"--pcap {escape(path)}: about {estimate / 1e9:.1f} GB ({cycles} cycles of "
            f"{one} bytes), more than {LARGE_PCAP_BYTES / 1e9:g} GB; "
            "--allow-large-pcap writes it"
        )


@contextlib.contextmanager
def pcap_target(path: str | None, ports: int, if_speed_bps: int) -> Iterator[dict[str, Any]]:
    """The ``pcap``/``sink`` arguments of ``simulate_epl``/``simulate_ecat`` for ``--pcap``:
    a file name as it is, ``-`` a pcapng streamed to standard output (the same bytes the
    file would hold; a test compares them), refused on a terminal as tshark refuses it."""
    if path != STDOUT:
        yield {"pcap": path}
        return
    from emulator.net.api import CaptureSink
    from skinframes.capture_writer import CaptureWriter

    if sys.stdout.isatty():
        raise SkinframesError("--pcap -: standard output is a terminal; pipe it or redirect it")
    sys.stdout.flush()
    with CaptureWriter(
        sys.stdout.buffer,
        fmt="pcapng",
        ports=ports,
        port_names=PORT_NAMES[:ports],
        if_speed_bps=if_speed_bps,
    ) as writer:
        yield {"pcap": None, "sink": CaptureSink(writer)}


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "simulate",
        help="emulate EPL or EtherCAT cycles with real frames (pcap optional)",
        description="Emulate a daisy chain of skin patches: EPL (MN + CNs behind hubs) or "
        "EtherCAT (master + ESC slaves, open or closed ring). Cycle time is measured from the "
        "emulated frames' timestamps at the master's port.",
    )
    protocol_arg(p, "protocol", choices=PROTOCOLS)
    p.add_argument(
        "--nodes",
        type=bounded_int(0, MAX_SLAVES),
        required=True,
        help="CNs / slaves (patches): EPL 1..239, EtherCAT 1..1024; 0 with --esi",
    )
    p.add_argument(
        "--bytes",
        type=bounded_int(0, MAX_NODE_BYTES),
        required=True,
        help="taxel bytes per node (192 = a patch)",
    )
    p.add_argument(
        "--closed-ring",
        "--redundant",
        dest="redundant",
        action="store_true",
        help="EtherCAT closed ring, Table III (--redundant: its old name)",
    )
    p.add_argument(
        "--preset", choices=list(PRESETS), default="paper", help="timing constants (default: paper)"
    )
    add_cn_response(p)
    p.add_argument(
        "--layout",
        choices=list(LAYOUTS),
        default="per-slave",
        help="EtherCAT: one LRD per slave (paper; the default) or a contiguous logical image",
    )
    p.add_argument(
        "--cycles",
        type=bounded_int(1, MAX_CYCLES),
        default=4,
        help=f"cycles to emulate, 1..{MAX_CYCLES} (default 4)",
    )
    p.add_argument(
        "--asnd",
        action="store_true",
        help="EPL: each SoA invites one CN in turn, which answers with an ASnd "
        "(StatusResponse); the paper assumes no asynchronous frames",
    )
    p.add_argument(
        "--pres-timeout-us",
        type=bounded_float(0, MAX_TIMEOUT_US),
        metavar="US",
        help="EPL: the MN's PRes timeout (default: each CN's round trip + 25 us); a CN that "
        "cannot meet it loses its PRes, counted in the working counter and the diagnosis",
    )
    p.add_argument(
        "--pcap",
        type=out_path,
        help="write the frames at the master's port to this pcap "
        "(.pcapng: with direction flags, and marks on deliberately corrupted frames); "
        "- streams a pcapng to stdout (the report goes to stderr)",
    )
    p.add_argument(
        "--allow-large-pcap",
        action="store_true",
        help=f"write a --pcap file estimated above {LARGE_PCAP_BYTES / 1e9:g} GB "
        "(refused without it, before anything is written)",
    )
    p.add_argument(
        "--fault",
        type=fault_spec,
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
    p.add_argument(
        "--esi",
        action="append",
        type=in_path,
        default=[],
        metavar="ESI.xml[#TYPE]",
        help="EtherCAT: after the patches, a slave as the ESI file describes it (device TYPE, "
        "by Type or product code, @REVISION among revisions, when the file has several), read "
        "each cycle by the master; "
        "its inputs count the cycles; repeatable",
    )
    p.add_argument(
        "--esi-inputs",
        action="append",
        type=in_path,
        default=[],
        metavar="FILE",
        help="EtherCAT: input values for the n-th --esi slave from the n-th such CSV file "
        "(header INDEX:SUBINDEX,...; a row per cycle, repeated; as serve ecat --esi-inputs); "
        "its other entries count the cycles; repeatable",
    )
    p.add_argument(
        "--esi-modules",
        action="append",
        default=[],
        metavar="LIST",
        help="EtherCAT: the modules in the slots of the n-th --esi slave, a modular device: its "
        "n-th comma-separated LIST of module Type texts or ModuleIdents, in slot order ('' for "
        "none; as serve ecat --esi-modules); repeatable",
    )
    p.add_argument(
        "--seed",
        type=bounded_int(0, MAX_SEED),
        default=0,
        help="seed of the taxel contact patterns",
    )
    p.add_argument(
        "--vlan",
        type=bounded_int(0, 4094),
        metavar="ID",
        help="tag every frame with this 802.1Q VLAN id (0..4094); the 4 bytes count on the wire",
    )
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.set_defaults(run=run)


def _esi_slaves(args: argparse.Namespace) -> list[Any]:
    """The ``--esi`` slaves, loaded and checked, with their ``--esi-inputs`` files (one error
    line for a bad one); ``--nodes 0`` only with them, EtherCAT only."""
    from emulator.slave.esi_slave import check_esi_slaves

    if (args.esi or args.esi_inputs or args.esi_modules) and args.protocol != "ecat":
        raise SkinframesError("--esi, --esi-inputs and --esi-modules apply to EtherCAT only")
    if args.nodes == 0 and not args.esi:
        raise SkinframesError("--nodes 0: only with --esi (EPL: 1..239, EtherCAT: 1..1024)")
    slaves = check_esi_slaves(args.esi, args.esi_inputs, args.esi_modules)
    if args.nodes + len(slaves) > MAX_SLAVES:
        raise SkinframesError(
            f"--nodes {args.nodes} and {len(slaves)} --esi: {args.nodes + len(slaves)} slaves "
            f"(1..{MAX_SLAVES})"
        )
    return slaves


def run(args: argparse.Namespace) -> int:
    """Emulate and report."""
    from emulator.net import simulate_ecat, simulate_epl
    from emulator.net.faults import FAULT_HELP, check_fault_cycles, parse_fault

    if "help" in args.fault:
        print(FAULT_HELP)
        return 0
    faults = tuple(parse_fault(spec) for spec in args.fault)
    check_fault_cycles(faults, args.cycles)
    if args.protocol == "epl" and args.redundant:
        raise SkinframesError("--closed-ring (--redundant) applies to EtherCAT only")
    if args.startup and (args.protocol != "ecat" or args.redundant or faults):
        raise SkinframesError("--startup: EtherCAT on an open ring without --fault only")
    if args.protocol == "ecat" and (
        args.asnd or args.pres_timeout_us is not None or args.cn_response_ps is not None
    ):
        raise SkinframesError("--asnd, --pres-timeout-us and --cn-response-us apply to EPL only")
    esi = _esi_slaves(args)
    params = timing(args)
    timeout = None
    if args.pres_timeout_us is not None:
        if not math.isfinite(args.pres_timeout_us) or not 0 <= args.pres_timeout_us <= 1e9:
            raise SkinframesError(f"--pres-timeout-us {args.pres_timeout_us}: 0..1e9 us")
        timeout = round(args.pres_timeout_us * 1e6)
    if args.pcap == "":
        raise SkinframesError("--pcap: an empty file name")
    ports = 2 if args.protocol == "ecat" and args.redundant else 1
    if args.protocol == "epl":
        run_one: Callable[..., Any] = functools.partial(
            simulate_epl, args.nodes, args.bytes, params, seed=args.seed, asnd=args.asnd,
            pres_timeout_ps=timeout, faults=faults, vlan=args.vlan,
        )  # fmt: skip
    else:
        run_one = functools.partial(
            simulate_ecat, args.nodes, args.bytes, params, closed_ring=args.redundant,
            layout=args.layout, seed=args.seed, faults=faults, startup=args.startup,
            vlan=args.vlan, esi=esi,
        )  # fmt: skip
    check_pcap_size(args.pcap, args.cycles, args.allow_large_pcap, ports, run_one)
    with (
        progress_bar(args.cycles, "cycles") as bar,
        pcap_target(args.pcap, ports, params.link_rate_bps) as target,
    ):
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
                progress=bar,
                vlan=args.vlan,
                **target,
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
                progress=bar,
                startup=args.startup,
                vlan=args.vlan,
                esi=esi,
                **target,
            )
    if args.pcap == STDOUT:
        result.pcap = STDOUT
    out = sys.stderr if args.pcap == STDOUT else sys.stdout  # stdout carries the capture
    if args.json:
        doc = result.to_json()
        doc["epl_cn_response_us"] = params.epl_cn_response_us
        if args.protocol == "ecat":
            doc["esi"] = [slave.summary() for slave in esi]
        print(json.dumps(doc, indent=2), file=out)
        return 0
    c = result.cycle_us()
    with_esi = "".join(f" and {slave.device.type_name}" for slave in esi)
    lines = [
        f"{result.protocol} {result.topology}: {result.nodes} nodes x {result.bytes} bytes"
        f"{with_esi}, preset {params.label}, layout {result.layout}",
        f"  cycles {result.cycles}, frames {result.frames}",
    ]
    if result.startup_us is not None:
        lines.append(f"  start-up: {result.startup_frames} frames, {result.startup_us:.3f} us")
    lines.append(
        f"  cycle time: min {c['min']:.3f} us, median {c['median']:.3f} us, max {c['max']:.3f} us"
    )
    if faults or result.degraded:
        wkc = ", ".join(f"{d.cycle}: {d.wkc}/{d.expected_wkc}" for d in result.details)
        lines.append(f"  working counter (got/expected) from cycle on: {wkc}")
        if result.recovery_us is not None:
            lines.append(f"  recovery: {result.recovery_us:g} us")
        lines += [f"  diagnosis: {line}" for line in result.diagnosis]
    if result.pcap:
        lines.append(f"  pcap: {escape(result.pcap)}")
    print("\n".join(lines), file=out)
    return 0
