"""``skinframes analyze`` against ``tshark -T fields`` extracting the fields analyze needs.

Builds one EPL and one EtherCAT capture with the emulator (wire preset), then per round runs,
back to back and in alternating order, ``skinframes analyze F --json`` (the whole command:
interpreter start, reading, analysis, JSON) and ``tshark -r F -T fields -e ...`` with the
fields a tshark user needs to compute the same statistics (frame number and time, EPL message
type, source, destination, NMT status, ASnd service; EtherCAT interface, source MAC, command,
index, addresses, length, working counter). Both write to /dev/null. Prints the time of each
and the ratio tshark / analyze (median of the per-round ratios; the goal is >= 2) of the wall
times and of the CPU times (user + system of each child: less disturbed by the other work of a
shared machine), plus the in-process time of ``analyze_file`` (what the command runs) and of
``read_capture`` + ``analyze_capture`` (the record reader's path). Printed, never asserted; the
captures are deleted afterwards unless ``--dir`` was given.

    python benchmarks/bench_analyze.py [--cycles N] [--rounds R] [--dir D]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_decode import run_process as timed  # noqa: E402  (this folder: sys.path[0])

from emulator import WIRE, simulate_ecat, simulate_epl  # noqa: E402
from skinframes.analysis import analyze_capture, analyze_file  # noqa: E402
from skinframes.pcap import read_capture  # noqa: E402

GOAL_RATIO = 2.0
EPL_FIELDS = (
    "frame.number",
    "frame.time_epoch",
    "epl.mtyp",
    "epl.src",
    "epl.dest",
    "epl.pres.stat",
    "epl.soa.stat",
    "epl.asnd.svid",
)
ECAT_FIELDS = (
    "frame.number",
    "frame.time_epoch",
    "frame.interface_id",
    "eth.src",
    "ecat.cmd",
    "ecat.idx",
    "ecat.adp",
    "ecat.ado",
    "ecat.lad",
    "ecat.subframe.length",
    "ecat.cnt",
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=3000, help="emulated cycles per capture")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--dir", help="folder for the captures (default: a temporary one)")
    args = ap.parse_args()
    tshark = shutil.which("tshark")
    if tshark is None:
        sys.exit("bench_analyze: tshark is not installed")
    skinframes = str(Path(sys.executable).with_name("skinframes"))
    folder = Path(args.dir or tempfile.mkdtemp(prefix="bench_analyze_"))
    epl, ecat = folder / "epl.pcap", folder / "ecat.pcapng"
    simulate_epl(20, 192, WIRE, cycles=args.cycles, asnd=True, pcap=epl)
    simulate_ecat(20, 32, WIRE, cycles=5 * args.cycles, pcap=ecat)
    print(f"load average {os.getloadavg()[0]:.2f}; {args.rounds} rounds, median ratio")
    for name, path, names in (("EPL", epl, EPL_FIELDS), ("EtherCAT", ecat, ECAT_FIELDS)):
        records = len(read_capture(path))
        ours = [skinframes, "analyze", str(path), "--json"]
        theirs = [tshark, "-n", "-r", str(path), "-T", "fields"]
        theirs += [a for n in names for a in ("-e", n)]
        ratios, cpu_ratios, t_ours, t_theirs = [], [], [], []
        for r in range(args.rounds):
            if r % 2:
                a, b = timed(ours), timed(theirs)
            else:
                b, a = timed(theirs), timed(ours)
            t_ours.append(a[0])
            t_theirs.append(b[0])
            ratios.append(b[0] / a[0])
            cpu_ratios.append(b[1] / a[1])
        start = time.perf_counter()
        analyze_file(path)
        inside = time.perf_counter() - start
        start = time.perf_counter()
        analyze_capture(read_capture(path))
        reader = time.perf_counter() - start
        ratio, cpu = statistics.median(ratios), statistics.median(cpu_ratios)
        print(
            f"{name:<8} {records:>7} frames: analyze {statistics.median(t_ours):.3f} s, "
            f"tshark -T fields {statistics.median(t_theirs):.3f} s (wall); ratio {ratio:.2f}x "
            f"wall, {cpu:.2f}x CPU (goal >= {GOAL_RATIO:g}x"
            f"{'' if min(ratio, cpu) >= GOAL_RATIO else ': NOT MET'}); "
            f"in process: analyze_file {inside:.3f} s ({inside / records * 1e6:.1f} us/frame), "
            f"read_capture + analyze_capture {reader:.3f} s ({reader / records * 1e6:.1f} us/frame)"
        )
    if args.dir is None:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
