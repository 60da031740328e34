"""``skinframes serve ecat|epl``: emulated skin patches on a live interface, for a real master.

``ecat``: the emulated ESC chain, for any EtherCAT master. ``epl``: the patches as POWERLINK
CNs (NMT, SDO server, object dictionary, PRes), for a real EPL MN such as openPOWERLINK's;
``epl --mn``: an emulated MN that boots and polls real CNs as a CDC says.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import sys
import threading
import traceback
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from emulator.esc import compiled
from emulator.esc.dc import DEFAULT_DRIFT_PPM, MAX_DRIFT_PPM
from emulator.model.limits import MAX_SERVED_SLAVES, check_served_ecat, check_served_epl
from skinframes.capture_writer import CaptureWriter
from skinframes.errors import CaptureError, SkinframesError
from skinframes.ethercat import MAX_DATAGRAM_DATA_BYTES
from skinframes.helper_threads import leave_signals_to_main
from skinframes.powerlink import MAX_CN_NODE_ID, MAX_PDO_PAYLOAD_BYTES, MIN_CN_NODE_ID
from skinframes.powerlink.cdc import MN_PDO_CHANNELS
from skinframes.text import escape
from skinframes_cli.options import (
    bounded_float,
    bounded_int,
    in_path,
    int_list_in,
    int_up_to,
    positive_float,
    protocol_arg,
)
from skinframes_cli.signals import first_stops

STDOUT = "-"  # --pcap -: the capture on standard output
CLOSE_NOTE_S = 1.0  # a capture still being written this long after serving stopped: a line
MAX_SAMPLES = 1024  # --samples: distinct taxel samples held in memory
MAX_INT_ARG = 1 << 31  # --nodes/--bytes: larger is refused at parse; the range is checked in run
MAX_U32 = (1 << 32) - 1  # --cycle-us: 0x1006 is an UNSIGNED32 of us
MN_ONLY = ("--cdc", "--cycle-us", "--cycles")


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "serve",
        help="serve emulated EtherCAT slaves or EPL CNs on a network interface until "
        "SIGINT/SIGTERM",
        description="ecat: answer EtherCAT frames on IFACE as a line of emulated skin patches "
        "(ESCs with SII, AL state machine, SyncManagers, FMMUs and a CoE mailbox), followed by "
        "the slaves ESI files describe (--esi). epl: answer as POWERLINK CNs (NMT state "
        "machine, IdentResponse, StatusResponse, SDO server, object dictionary, PRes with the "
        "taxels at 0x6100/1) for a real MN. Point the master at the other end of the link, e.g. "
        "a veth pair in a network namespace (see the README). epl --mn: be the MN instead, "
        "booting the real CNs a CDC names (--cdc, as openCONFIGURATOR writes it) or the skin "
        "of --nodes and --bytes, then polling them every cycle. Needs root or CAP_NET_RAW. Runs "
        "until SIGINT or SIGTERM (or --cycles), then prints what it served; a second signal "
        "stops it at once, dropping what --pcap has not written yet.",
    )
    protocol_arg(p, "protocol", choices=("ecat", "epl"))
    p.add_argument("--iface", required=True, help="network interface the master is wired to")
    p.add_argument(
        "--nodes",
        type=int_up_to(MAX_INT_ARG),
        help=f"slaves (patches), 1..{MAX_SERVED_SLAVES}; 0 with --esi; epl: CNs, "
        f"1..{MAX_CN_NODE_ID}; epl --mn: the CNs to boot, 1..{MN_PDO_CHANNELS} (or --cdc)",
    )
    p.add_argument(
        "--node-ids",
        type=int_list_in(MIN_CN_NODE_ID, MAX_CN_NODE_ID),
        help="epl: the CNs' node ids, a comma list or start:stop:step, one per node (default 1..N)",
    )
    p.add_argument(
        "--bytes",
        type=int_up_to(MAX_INT_ARG),
        help=f"taxel bytes per slave, 1..{MAX_DATAGRAM_DATA_BYTES} (needed unless --nodes 0); "
        f"epl: per CN, 1..{MAX_PDO_PAYLOAD_BYTES} (0x6100/1)",
    )
    p.add_argument(
        "--esi",
        action="append",
        type=in_path,
        default=[],
        metavar="ESI.xml[#TYPE]",
        help="after the patches, a slave as the ESI file describes it (device TYPE, by Type "
        "or product code, @REVISION among revisions, when the file has several): its SII image, "
        "CoE dictionary, PDO assignment and mapping, DC; inputs count up at each --period-ms; "
        "repeatable (ecat)",
    )
    p.add_argument(
        "--esi-inputs",
        action="append",
        type=in_path,
        default=[],
        metavar="FILE",
        help="input values for the n-th --esi slave from the n-th such CSV file (header "
        "INDEX:SUBINDEX,...; a row per --period-ms, repeated); its other entries count; "
        "repeatable (ecat)",
    )
    p.add_argument(
        "--esi-modules",
        action="append",
        default=[],
        metavar="LIST",
        help="the modules in the slots of the n-th --esi slave, a modular device: its n-th "
        "comma-separated LIST of module Type texts or ModuleIdents, in slot order ('' for "
        "none); repeatable (ecat)",
    )
    p.add_argument(
        "--seed",
        type=bounded_int(0, 2**32 - 1),
        default=0,
        help="seed of the taxel contact patterns",
    )
    p.add_argument(
        "--samples",
        type=bounded_int(1, MAX_SAMPLES),
        default=64,
        help=f"distinct taxel samples, cycled, 1..{MAX_SAMPLES} (default 64)",
    )
    p.add_argument(
        "--period-ms",
        type=positive_float(60_000),
        default=1.0,
        help="time between two taxel samples in ms, above 0, up to 60000 (default 1)",
    )
    p.add_argument(
        "--no-mailbox",
        action="store_true",
        help="ecat: patches without a mailbox (no CoE; PDOs from the SII only), as before CoE "
        "existed",
    )
    p.add_argument(
        "--drift-ppm",
        type=bounded_float(0, MAX_DRIFT_PPM),
        default=None,
        help="ecat: largest clock drift of a patch's distributed clock in ppm, each patch's "
        f"drawn with --seed (0..{MAX_DRIFT_PPM:g}, default {DEFAULT_DRIFT_PPM:g})",
    )
    p.add_argument(
        "--pcap",
        metavar="FILE",
        help="record every frame received and sent, with this host's timestamps (pcapng for a "
        ".pcapng name: direction per frame; else classic pcap); the file appears complete "
        "when serving stops; - streams a pcapng to stdout (the summary goes to stderr)",
    )
    p.add_argument(
        "--rt-priority",
        type=bounded_int(1, 99),
        help="epl: run under SCHED_FIFO with this priority (1..99; needs root or CAP_SYS_NICE), "
        "as openPOWERLINK's own demos do, so that a busy host delays the PRes less",
    )
    p.add_argument(
        "--mn",
        action="store_true",
        help="epl: be the MN: boot the real CNs on IFACE (NMTResetNode, IdentRequest, "
        "StatusRequest, the SDO writes of each CN's 0x1F22 block, NMTResetConfiguration, "
        "EnableReadyToOperate, StartNode), then poll them each cycle; report each CN's state, "
        "PReq -> PRes times and losses",
    )
    p.add_argument(
        "--cdc",
        type=in_path,
        metavar="FILE",
        help="epl --mn: the concise device configuration (mnobd.cdc, as openCONFIGURATOR or "
        "`skinframes epl-config` writes it) naming the CNs, the cycle and what to write to each",
    )
    p.add_argument(
        "--cycle-us",
        type=bounded_int(1, MAX_U32),
        help="epl --mn: the cycle length in us (default: the CDC's 0x1006; with --nodes the "
        "model's, as epl-config chooses it)",
    )
    p.add_argument(
        "--cycles",
        type=bounded_int(1, MAX_INT_ARG),
        help="epl --mn: stop after this many cycles with every CN OPERATIONAL (default: run "
        "until SIGINT/SIGTERM)",
    )
    p.add_argument("--json", action="store_true", help="print the summary as one JSON document")
    p.set_defaults(run=run)


@contextlib.contextmanager
def _capture(path: str) -> Iterator[CaptureWriter]:
    """``--pcap FILE``, atomically; ``-``: a pcapng (directions) streamed to stdout. Written
    behind (a thread of its own): a busy disk or a slow reader of the pipe does not hold up the
    answers. When serving has stopped and the capture is still being written after
    :data:`CLOSE_NOTE_S`, a line on stderr says why serve waits, and how not to."""
    if path != STDOUT:
        writer = CaptureWriter(path, write_behind=True)
    elif sys.stdout.isatty():
        raise CaptureError("--pcap -: standard output is a terminal; pipe it or redirect it")
    else:
        writer = CaptureWriter(sys.stdout.buffer, fmt="pcapng", write_behind=True)
    with writer:
        yield writer
        closed = threading.Event()
        note = threading.Thread(target=_note_unless, args=(closed, path), daemon=True)
        note.start()
        try:
            writer.close()
        finally:
            closed.set()


def _note_unless(closed: threading.Event, path: str) -> None:
    """The line of :func:`_capture` unless ``closed`` is set within :data:`CLOSE_NOTE_S`."""
    leave_signals_to_main()
    if not closed.wait(CLOSE_NOTE_S):
        what = "its reader" if path == STDOUT else "the disk"
        print(
            f"stopping: the capture is not all written yet, waiting for {what}; "
            "SIGINT/SIGTERM again drops the rest and stops at once",
            file=sys.stderr,
            flush=True,
        )


def run(args: argparse.Namespace) -> int:
    """Serve until a signal arrives."""
    mn_only = (args.cdc, args.cycle_us, args.cycles)
    if not args.mn and any(v is not None for v in mn_only):
        raise SkinframesError(f"{', '.join(MN_ONLY)} apply to serve epl --mn only")
    if args.protocol == "epl":
        return run_epl_mn(args) if args.mn else run_epl(args)
    if args.mn:
        raise SkinframesError("--mn applies to serve epl only")
    if args.nodes is None:
        raise SkinframesError("serve ecat: --nodes is required")
    from emulator.errors import TopologyError
    from emulator.esc.dc import seed_clocks
    from emulator.live import RawSocket, TaxelFeed, mixed_chain, serve
    from emulator.slave.esi_slave import check_esi_slaves, esi_device

    given = [o for o, v in (("--node-ids", args.node_ids), ("--rt-priority", args.rt_priority))
             if v is not None]  # fmt: skip
    if given:
        verb = "apply" if len(given) > 1 else "applies"
        raise SkinframesError(f"{' and '.join(given)} {verb} to serve epl only")
    if args.drift_ppm is None:
        args.drift_ppm = DEFAULT_DRIFT_PPM
    period_s = args.period_ms / 1000.0
    esi = check_esi_slaves(args.esi, args.esi_inputs, args.esi_modules)
    total = args.nodes + len(esi)  # the count first: --bytes cannot mend it
    if total > MAX_SERVED_SLAVES:
        raise TopologyError(f"served EtherCAT chain: {total} slaves (1..{MAX_SERVED_SLAVES})")
    if args.nodes or not esi:
        if args.bytes is None and args.nodes:
            raise TopologyError("serve ecat: --bytes is required with --nodes > 0")
        check_served_ecat(args.nodes, args.bytes or 1, args.samples, period_s)
    else:
        check_served_ecat(1, 1, args.samples, period_s)  # the feed's limits; no patch
    size = args.bytes or 0
    chain = mixed_chain(
        args.nodes,
        size,
        [functools.partial(esi_device, slave) for slave in esi],
        mailbox=not args.no_mailbox,
    )
    seed_clocks([dev.dc for dev in chain.devices], args.drift_ppm, args.seed)
    feed = TaxelFeed(
        args.nodes,
        size,
        samples=args.samples,
        seed=args.seed,
        period_s=period_s,
    )
    stop = threading.Event()
    if args.pcap == "":
        raise CaptureError("--pcap: an empty file name")

    with _until_signal(stop), contextlib.ExitStack() as stack:
        sock = stack.enter_context(RawSocket(args.iface))
        capture = None if args.pcap is None else stack.enter_context(_capture(args.pcap))
        how = "compiled" if compiled.in_use() else "as Python (make compiles them)"
        what = f"{args.nodes} EtherCAT slaves x {size} bytes"
        if esi:
            what += " and " + ", ".join(s.device.type_name for s in esi)
        print(
            f"serving {what} on {args.iface}, the ESCs {how}; SIGINT/SIGTERM to stop",
            file=sys.stderr,
            flush=True,
        )
        stats = serve(chain, sock, stop, feed=feed, capture=capture, on_error=_on_error(args.debug))
    summary: dict[str, Any] = {
        "protocol": "ecat",
        "iface": args.iface,
        "nodes": args.nodes,
        "bytes": size,
        "mailbox": not args.no_mailbox,
        "esi": [s.summary() for s in esi],
        **stats.summary(),
        "compiled": compiled.in_use(),
        "error_messages": stats.error_messages,
    }
    out = _report(args, summary)
    if out is not None:
        print(
            f"served {summary['frames_out']} of {summary['frames_in']} frames "
            f"({summary['dropped']} dropped, {summary['errors']} not processed), "
            f"{summary['publications']} taxel samples; "
            f"processing median {summary['process_us_median']} us, "
            f"p99 {summary['process_us_p99']} us, max {summary['process_us_max']} us; "
            f"CPU median {summary['cpu_us_median']} us, p99 {summary['cpu_us_p99']} us, "
            f"max {summary['cpu_us_max']} us per frame, "
            f"then the firmware max {summary['firmware_us_max']} us; "
            f"the ESCs {'compiled' if summary['compiled'] else 'as Python'}",
            file=out,
        )
        for message in stats.error_messages:
            print(f"  not processed: {message}", file=out)
    return 0


def _report(args: argparse.Namespace, summary: dict[str, Any]) -> TextIO | None:
    """Print ``summary`` as JSON with ``--json`` (``"pcap"`` added with ``--pcap``) and return
    None; else the stream for the text summary. Either goes to stdout, or to stderr when the
    capture streams to stdout (``--pcap -``)."""
    if args.pcap is not None:
        summary["pcap"] = args.pcap
    out = sys.stderr if args.pcap == STDOUT else sys.stdout  # stdout carries the capture
    if args.json:
        print(json.dumps(summary), file=out)
        return None
    return out


def _on_error(debug: bool) -> Callable[[BaseException, bytes], None]:
    """What serve does with a frame it could not process: counted in the summary, and with
    ``--debug`` the frame and its traceback shown as it happens."""

    def on_error(exc: BaseException, frame: bytes) -> None:
        if debug:
            print(f"frame {frame.hex()}:", file=sys.stderr)
            traceback.print_exception(exc, file=sys.stderr)

    return on_error


def _until_signal(stop: threading.Event) -> contextlib.AbstractContextManager[None]:
    """Inside, the first SIGINT or SIGTERM sets ``stop`` (serve ends its loop, then finishes
    its capture), a second one ends serve at once (:func:`first_stops`: a capture's reader that
    does not read cannot hold it); the handlers before are back afterwards."""
    return first_stops(stop.set)


def run_epl(args: argparse.Namespace) -> int:
    """``serve epl``: the patches as EPL CNs until a signal arrives."""
    from emulator.epl.live import serve_epl
    from emulator.epl.skin import EplSkin, node_ids
    from emulator.live import ETH_P_EPL, RawSocket, TaxelFeed, realtime

    if args.no_mailbox or args.drift_ppm is not None or args.esi:
        raise SkinframesError("--no-mailbox, --drift-ppm and --esi apply to serve ecat only")
    if args.esi_inputs:
        raise SkinframesError("--esi-inputs applies to serve ecat only")
    if args.esi_modules:
        raise SkinframesError("--esi-modules applies to serve ecat only")
    if args.nodes is None:
        raise SkinframesError("serve epl: --nodes is required")
    if args.bytes is None:
        raise SkinframesError("serve epl: --bytes is required")
    period_s = args.period_ms / 1000.0
    check_served_epl(args.nodes, args.bytes, args.samples, period_s)
    ids = node_ids(args.nodes, args.node_ids)
    if args.pcap == "":
        raise CaptureError("--pcap: an empty file name")
    skin = EplSkin(ids, args.bytes)
    if args.rt_priority is not None:
        realtime(args.rt_priority)
    feed = TaxelFeed(
        args.nodes, args.bytes, samples=args.samples, seed=args.seed, period_s=period_s
    )
    stop = threading.Event()

    with _until_signal(stop), contextlib.ExitStack() as stack:
        sock = stack.enter_context(RawSocket(args.iface, ETH_P_EPL, promiscuous=True))
        capture = None if args.pcap is None else stack.enter_context(_capture(args.pcap))
        print(
            f"serving {args.nodes} EPL CNs (node ids {','.join(map(str, ids))}) x "
            f"{args.bytes} taxel bytes on {args.iface}; SIGINT/SIGTERM to stop",
            file=sys.stderr,
            flush=True,
        )
        stats = serve_epl(
            skin, sock, stop, feed=feed, capture=capture, on_error=_on_error(args.debug)
        )
    report = skin.report()
    summary: dict[str, Any] = {
        "protocol": "epl",
        "iface": args.iface,
        "nodes": args.nodes,
        "bytes": args.bytes,
        "node_ids": ids,
        **stats.summary(),
        "error_messages": stats.error_messages,
        "counts": report["counts"],
        "cns": report["cns"],
    }
    out = _report(args, summary)
    if out is None:
        return 0
    print(
        f"served {summary['frames_out']} answers to {summary['frames_in']} frames "
        f"({summary['errors']} not processed), {summary['publications']} taxel samples; "
        f"answer median {summary['answer_us_median']} us, p99 {summary['answer_us_p99']} us, "
        f"max {summary['answer_us_max']} us",
        file=out,
    )
    for cn in report["cns"]:  # type: ignore[attr-defined]
        counted = ", ".join(f"{k} {v}" for k, v in cn["counts"].items()) or "nothing wrong"
        print(f"  CN {cn['node_id']}: {cn['state']}; {counted}", file=out)
    if report["counts"]:
        counted = ", ".join(f"{k} {v}" for k, v in report["counts"].items())  # type: ignore[attr-defined]
        print(f"  frames for no CN here or unreadable: {counted}", file=out)
    for message in stats.error_messages:
        print(f"  not processed: {message}", file=out)
    return 0


def _mn_config(args: argparse.Namespace) -> Any:
    """The MN's configuration: the CDC's (``--cdc``), or the skin of ``--nodes`` CNs of
    ``--bytes`` taxel bytes as ``epl-config`` writes it."""
    from emulator.epl.mn_config import mn_config
    from emulator.epl.skin import node_ids
    from emulator.model.epl_config import skin_config
    from skinframes.powerlink.cdc import decode_cdc, skin_cdc

    if args.cdc is not None:
        if args.nodes is not None or args.bytes is not None or args.node_ids is not None:
            raise SkinframesError("serve epl --mn: --cdc or --nodes/--bytes/--node-ids, not both")
        try:
            with open(args.cdc, "rb") as f:
                data = f.read()
        except OSError as exc:
            raise SkinframesError(f"--cdc {escape(args.cdc)}: {exc.strerror or exc}") from exc
        try:
            entries = decode_cdc(data)
        except SkinframesError as exc:
            raise SkinframesError(f"--cdc {escape(args.cdc)}: {exc}") from exc
        return mn_config(entries, args.cycle_us)
    if args.nodes is None or args.bytes is None:
        raise SkinframesError("serve epl --mn: --cdc FILE, or --nodes N and --bytes B")
    if args.nodes > MN_PDO_CHANNELS:
        raise SkinframesError(
            f"serve epl --mn: --nodes {args.nodes}: the CDC's MN has {MN_PDO_CHANNELS} PDO "
            f"channels of each direction, one per CN (1..{MN_PDO_CHANNELS}); a CDC (--cdc) "
            "names CNs without that limit"
        )
    ids = tuple(node_ids(args.nodes, args.node_ids))
    return mn_config(skin_cdc(skin_config(ids, args.bytes, args.cycle_us)))


def run_epl_mn(args: argparse.Namespace) -> int:
    """``serve epl --mn``: boot and poll real CNs until a signal arrives or ``--cycles``."""
    import time

    from emulator.epl.mn import EplMn
    from emulator.epl.mn_live import SocketLink, run_mn
    from emulator.live import ETH_P_EPL, RawSocket, realtime

    if args.no_mailbox or args.drift_ppm is not None or args.esi:
        raise SkinframesError("--no-mailbox, --drift-ppm and --esi apply to serve ecat only")
    if args.esi_inputs:
        raise SkinframesError("--esi-inputs applies to serve ecat only")
    if args.esi_modules:
        raise SkinframesError("--esi-modules applies to serve ecat only")
    if args.pcap == "":
        raise CaptureError("--pcap: an empty file name")
    config = _mn_config(args)
    mn = EplMn(config)
    if args.rt_priority is not None:
        realtime(args.rt_priority)
    stop = threading.Event()
    with _until_signal(stop), contextlib.ExitStack() as stack:
        sock = stack.enter_context(RawSocket(args.iface, ETH_P_EPL, promiscuous=True))
        capture = None if args.pcap is None else stack.enter_context(_capture(args.pcap))
        link = SocketLink(sock, capture)
        print(
            f"MN for EPL CNs {','.join(map(str, config.node_ids))} on {args.iface}, cycle "
            f"{config.cycle_us} us; SIGINT/SIGTERM to stop",
            file=sys.stderr,
            flush=True,
        )
        stats = run_mn(
            mn,
            link,
            stop,
            cycles=args.cycles,
            net_time_offset_ns=time.time_ns() - time.monotonic_ns(),
            on_error=_on_error(args.debug),
        )
        link.record_sent()
    report = mn.report(stats.started_ns)
    all_op = stats.all_operational_ns
    summary: dict[str, Any] = {
        "protocol": "epl",
        "role": "mn",
        "iface": args.iface,
        "cdc": args.cdc,
        "cycle_us": config.cycle_us,
        "node_ids": config.node_ids,
        "cycles": stats.cycles,
        "operational_cycles": stats.operational_cycles,
        "all_operational_s": None
        if all_op is None
        else round((all_op - stats.started_ns) / 1e9, 3),
        "overruns": stats.overruns,
        "frames_in": link.frames_in,
        "frames_out": link.frames_out,
        "errors": stats.errors,
        "error_messages": stats.error_messages,
        "counts": report["counts"],
        "cns": report["cns"],
    }
    out = _report(args, summary)
    if out is None:
        return 0
    when = summary["all_operational_s"]
    print(
        f"MN: {len(config.node_ids)} CNs, cycle {config.cycle_us} us: "
        + ("not all OPERATIONAL" if when is None else f"all OPERATIONAL after {when} s")
        + f"; {stats.cycles} cycles ({stats.operational_cycles} with all OPERATIONAL, "
        f"{stats.overruns} overrun); {link.frames_out} frames sent, {link.frames_in} received "
        f"({stats.errors} not processed)",
        file=out,
    )
    for cn in summary["cns"]:
        reached = "" if cn["operational_s"] is None else f" after {cn['operational_s']} s"
        counted = ", ".join(f"{k} {v}" for k, v in cn["counts"].items()) or "nothing else"
        print(
            f"  CN {cn['node_id']}: {cn['state']}{reached}; PReq -> PRes median "
            f"{cn['response_us_median']} us, p99 {cn['response_us_p99']} us, worst "
            f"{cn['response_us_worst']} us; {cn['losses']} lost of {cn['polls']} "
            f"({cn['late']} late); {counted}",
            file=out,
        )
    if summary["counts"]:
        counted = ", ".join(f"{k} {v}" for k, v in summary["counts"].items())
        print(f"  frames for no CN here or unreadable: {counted}", file=out)
    for message in stats.error_messages:
        print(f"  not processed: {message}", file=out)
    return 0
