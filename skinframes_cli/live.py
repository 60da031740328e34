"""``--iface IF [--duration S] [-c N]``: ``decode``, ``check`` and ``analyze`` read a live
interface instead of a file (:class:`skinframes.live_capture.LiveCapture`: an AF_PACKET socket
with a capture filter in the kernel; docs/interface.md says why not libpcap).

One line of information when the capture starts (as tshark's ``Capturing on 'IF'``) and one
when it ends, on stderr; Ctrl-C ends the capture and the command reports what it saw.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Final

from skinframes.errors import SkinframesError
from skinframes.findings import FrameFinding
from skinframes.pcap import Capture, FirstRecords, RecordSource, Skipped
from skinframes.text import escape
from skinframes_cli.options import bounded_float, bounded_int

if TYPE_CHECKING:
    from skinframes.live_capture import LiveCapture

__all__ = [
    "add_live",
    "capture_input",
    "file_input",
    "first_frames",
    "is_live",
    "report_records",
]

MAX_DURATION_S: Final = 1e7  # about 116 days


def add_live(p: argparse.ArgumentParser, *, count: bool = True) -> None:
    """``PATH`` made optional, ``--iface IF``, ``--duration S`` and (``count``) ``-c N``."""
    g = p.add_argument_group("live capture (instead of PATH; Linux, root or CAP_NET_RAW)")
    g.add_argument(
        "--iface",
        metavar="IF",
        help="capture on this network interface: EtherCAT, EPL and their UDP/IPv4 and VLAN "
        "forms, both directions (a kernel capture filter keeps other traffic out); Ctrl-C "
        "stops and reports",
    )
    g.add_argument(
        "--duration",
        type=bounded_float(0.001, MAX_DURATION_S),
        metavar="S",
        help="with --iface: stop after S seconds",
    )
    if count:
        g.add_argument(
            "-c",
            "--count",
            type=bounded_int(1, 2**62),
            metavar="N",
            help="stop after N frames (a file: its first N frames, as tshark -c)",
        )
    p.set_defaults(live_count=count)  # -c is the live capture's (decode's -c is its own)


def _check(args: argparse.Namespace) -> None:
    if args.iface is None:
        if args.path is None:
            raise SkinframesError("a capture file (PATH, - for standard input) or --iface IF")
        if args.duration is not None:
            raise SkinframesError("--duration: for a live capture (--iface IF)")
        return
    if args.path is not None:
        raise SkinframesError(f"{escape(args.path)} and --iface {escape(args.iface)}: one input")
    if not args.iface.strip():
        raise SkinframesError("--iface: an empty interface name")


def is_live(args: argparse.Namespace) -> bool:
    """Whether the command reads ``--iface`` (after checking PATH and --iface agree)."""
    _check(args)
    return args.iface is not None


@contextlib.contextmanager
def capture_input(args: argparse.Namespace, count: int | None) -> Iterator[LiveCapture]:
    """The live capture of ``--iface``, with its lines on stderr around the block; ``count``:
    the frames to capture (None: no limit). Imported only here: ``check`` of a file starts
    without the socket code."""
    from skinframes.live_capture import LiveCapture

    live = LiveCapture(args.iface, duration_s=args.duration, count=count)
    limits = [f"{args.duration:g} s" if args.duration is not None else "",
              f"{count} frames" if count is not None else ""]  # fmt: skip
    until = " or ".join(x for x in limits if x)
    with live.sigint_stops():  # from the line on: Ctrl-C ends the capture, never the command
        print(
            f"Capturing on {escape(args.iface)!r} (EtherCAT, EPL; also over UDP and VLAN)"
            + (f" for {until}" if until else "")
            + "; Ctrl-C stops",
            file=sys.stderr,
            flush=True,
        )
        try:
            yield live
        finally:
            live.stop()
    print(summary(live), file=sys.stderr)


def summary(live: LiveCapture) -> str:
    """``m0: 1234 frames in 4.00 s, 0 dropped by the kernel (stopped by Ctrl-C)``."""
    how = " (stopped by Ctrl-C)" if live.interrupted else ""
    return (
        f"{escape(live.iface)}: {live.frames} frames in {live.seconds:.2f} s, {live.dropped} "
        f"dropped by the kernel{how}"
    )


def file_input(path: str) -> Capture:
    """The capture file named on the command line; ``-`` is standard input."""
    from skinframes.pcap import read_capture

    if path == "-":
        return read_capture(sys.stdin.buffer)
    return read_capture(path)


def first_frames(args: argparse.Namespace) -> RecordSource:
    """The capture file of ``args.path`` (``-``: standard input), its first ``args.count``
    records when ``-c N`` is given (as ``tshark -c``)."""
    capture = file_input(args.path)
    return capture if args.count is None else FirstRecords(capture, args.count)


def report_records(
    total: int,
    decoded: int,
    skipped: Sequence[Skipped],
    findings: Sequence[FrameFinding] = (),
    *,
    where: str = "file",
    suffix: str = "",
) -> None:
    """On stderr, what reading a capture found: each skipped record with its reason, what is
    wrong but readable (``frame N: ...``, ``where``: the capture's own), then ``N records: D
    decoded, S skipped`` and ``suffix``."""
    for s in skipped:
        print(f"skipped frame {s.frame}: {escape(s.reason)}", file=sys.stderr)
    for f in findings:
        print(f"{f'frame {f.frame}' if f.index >= 0 else where}: {escape(f.finding.message)}",
              file=sys.stderr)  # fmt: skip
    print(f"{total} records: {decoded} decoded, {len(skipped)} skipped{suffix}", file=sys.stderr)
