"""Start-up on small real captures: ``decode --json`` and ``check`` against tshark, in one run.

Run from the repository root::

    python benchmarks/bench_startup.py [--rounds 5] [--dir ../shared/captures]

Issue 42 (item 6): on a small capture, start-up dominates; ``check`` and ``decode --json``
should take no longer than ``tshark -q -z expert`` and ``tshark -T json`` of the same file. For
each Ethernet capture of the shared folder (third-party captures of 0.4-290 kB) and round, in
alternating order, each command runs as a fresh process writing to /dev/null:

* ``skinframes decode --json F`` against ``tshark -n -r F -T json``;
* ``skinframes check F`` against ``tshark -n -r F -q -z expert``.

Reported: the median wall time of each side and the median over rounds of the paired ratios
tshark / skinframes (above 1: skinframes is faster), of wall time and of CPU time (user +
system: on a shared machine the steadier of the two), with the load average before and after.
Nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_decode import ROOT, run_process, skinframes

SHARED = ROOT.parent / "shared" / "captures"
SUFFIXES = (".pcap", ".pcapng", ".cap")
JOBS = (  # (skinframes arguments, tshark arguments, what)
    (["decode", "--json"], ["-T", "json"], "decode --json / -T json"),
    (["check"], ["-q", "-z", "expert"], "check / -q -z expert"),
)


def main_bench() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--dir", type=Path, default=SHARED, help="the captures (default: %(default)s)")
    args = ap.parse_args()
    tshark = shutil.which("tshark")
    if tshark is None:
        print("tshark not found: nothing to compare with")
        return 1
    files = sorted(p for p in args.dir.iterdir() if p.suffix in SUFFIXES)
    if not files:
        print(f"no capture in {args.dir}")
        return 1
    version = subprocess.run([tshark, "-v"], capture_output=True, text=True).stdout.split("\n")[0]
    load_before = os.getloadavg()
    print(f"# bench_startup: {version}; CPython {sys.version.split()[0]}; {os.cpu_count()} CPUs")
    print(f"# load average before {load_before[0]:.2f} (1 min), {load_before[1]:.2f} (5 min)")
    print(f"# {args.rounds} rounds, alternating order; every command a fresh process")
    rows = []
    for path in files:
        for ours_args, theirs_args, what in JOBS:
            ours = skinframes(*ours_args, str(path))
            theirs = [tshark, "-n", "-r", str(path), *theirs_args]
            walls: tuple[list[float], list[float]] = ([], [])
            ratios: list[float] = []
            cpu_ratios: list[float] = []
            for r in range(args.rounds):
                if r % 2:
                    b, a = run_process(theirs), run_process(ours)
                else:
                    a, b = run_process(ours), run_process(theirs)
                walls[0].append(a[0])
                walls[1].append(b[0])
                ratios.append(b[0] / a[0])
                cpu_ratios.append(b[1] / max(a[1], 1e-9))
                print(f"  {path.name}: {what}: round {r}: wall {a[0]:.3f} s vs {b[0]:.3f} s, "
                      f"CPU {a[1]:.3f} s vs {b[1]:.3f} s", file=sys.stderr)  # fmt: skip
            rows.append(
                (
                    f"{path.name} ({path.stat().st_size / 1000:.1f} kB)",
                    what,
                    statistics.median(walls[0]),
                    statistics.median(walls[1]),
                    statistics.median(ratios),
                    statistics.median(cpu_ratios),
                )
            )
    load_after = os.getloadavg()
    print(f"# load average after {load_after[0]:.2f} (1 min), {load_after[1]:.2f} (5 min)")
    print()
    print("| capture | skinframes / tshark | skinframes s | tshark s | x tshark (wall) "
          "| x tshark (CPU) | no slower (wall) |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---|")
    for capture, what, ours_s, theirs_s, ratio, cpu_ratio in rows:
        verdict = "**MET**" if ratio >= 1 else "**NOT MET**"
        print(f"| {capture} | {what} | {ours_s:.3f} | {theirs_s:.3f} | {ratio:.2f}x "
              f"| {cpu_ratio:.2f}x | {verdict} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main_bench())
