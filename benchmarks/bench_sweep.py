"""Sweeps over the whole design space, measured against the default table in the same run.

1. Analytic: ``tables --nodes 1:239:1 --bytes 1:1486:1 --json`` (1.06 million cells) against the
   default 32-cell ``tables --json``, each a fresh process (whole process: start-up, imports,
   output to a file), alternating, median of three: the difference and the ratio of wall times
   (issue goal: at most a few seconds more) and each run's peak RSS (goal: at most 256 MB).
2. Emulated (``--emulated``): ``tables --model emulated --preset paper`` over a sample of node
   counts (default every 24th of 1..239) and every byte count 1..1486, against the analytic run of
   the same cells: wall time per cell and the projection to the full grid (issue goal: under 10
   minutes on 2 cores), peak RSS, and whether every cell equals the analytic one within 0.01 us.

Printed, never asserted.

    python benchmarks/bench_sweep.py [--rounds 3] [--emulated] [--every 24] [--jobs N]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CHILD = """
import resource, sys
from skinframes_cli import main
code = main(sys.argv[1:])
sys.stdout.flush()
print("BENCH", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, code, file=sys.stderr)
"""
FULL = ["--nodes", "1:239:1", "--bytes", "1:1486:1"]


def cli(argv: list[str], out: Path) -> tuple[float, float]:
    """Run the CLI in a fresh process, stdout to ``out``: (wall s, peak RSS MB of the child)."""
    t0 = time.perf_counter()
    with open(out, "w") as f:
        done = subprocess.run(
            [sys.executable, "-c", CHILD, *argv],
            stdout=f,
            stderr=subprocess.PIPE,
            text=True,
            check=True,
            cwd=ROOT,
        )
    wall = time.perf_counter() - t0
    line = next(x for x in done.stderr.splitlines() if x.startswith("BENCH"))
    return wall, int(line.split()[1]) / 1024


def analytic(rounds: int, tmp: Path) -> None:
    small, full = [], []
    for _ in range(rounds):
        small.append(cli(["tables", "--json"], tmp / "small.json"))
        full.append(cli(["tables", *FULL, "--json"], tmp / "full.json"))
    ws = statistics.median(w for w, _ in small)
    wf = statistics.median(w for w, _ in full)
    rss = max(r for _, r in full)
    size = (tmp / "full.json").stat().st_size / 1e6
    print(f"analytic, median of {rounds} (whole process, fresh each time):")
    print(f"  default 32 cells        {ws:6.2f} s   peak RSS {max(r for _, r in small):6.1f} MB")
    print(f"  1..239 x 1..1486 cells  {wf:6.2f} s   peak RSS {rss:6.1f} MB   ({size:.0f} MB JSON)")
    print(f"  difference {wf - ws:+.2f} s, ratio full / default {wf / ws:.2f}")
    print(
        f"  goal: a few seconds more, RSS <= 256 MB: {'MET' if wf - ws < 5 and rss <= 256 else 'NOT MET'}"
    )


def emulated(every: int, jobs: int | None, tmp: Path) -> None:
    nodes = ",".join(str(n) for n in range(1, 240, every))
    count = len(range(1, 240, every))
    argv = ["tables", "--nodes", nodes, "--bytes", "1:1486:1", "--json"]
    extra = ["--jobs", str(jobs)] if jobs else []
    wall, rss = cli([*argv[:1], "--model", "emulated", *argv[1:], *extra], tmp / "emu.json")
    cli(argv, tmp / "ana.json")
    emu = json.loads((tmp / "emu.json").read_text())
    ana = json.loads((tmp / "ana.json").read_text())
    worst = max(
        abs(emu[t][n][b] - v)
        for t in ("epl", "ecat", "ecat_closed_ring")
        for n, row in ana[t].items()
        for b, v in row.items()
    )
    cells = 3 * count * 1486
    # the work of a row grows with its nodes (about n^2 frames x hops for EtherCAT); the sample
    # is spread evenly over 1..239, so its mean stands for the full grid's
    projected = wall / cells * 3 * 239 * 1486
    print(
        f"emulated, paper preset, {count} node counts x 1486 byte counts x 3 tables = {cells} cells:"
    )
    print(
        f"  {wall:.1f} s whole process, {1e3 * wall / cells:.3f} ms per cell, peak RSS {rss:.0f} MB"
    )
    print(
        f"  projected full grid (3 x 239 x 1486 cells): {projected / 60:.1f} min (goal: < 10 min)"
    )
    print(
        f"  largest |emulated - analytic| {worst:.6f} us (goal: <= 0.01): "
        f"{'MET' if worst <= 0.01 and not math.isnan(worst) else 'NOT MET'}"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--emulated", action="store_true", help="also time the emulated sweep")
    ap.add_argument("--every", type=int, default=24, help="emulated: every Nth node count")
    ap.add_argument("--jobs", type=int, default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        analytic(args.rounds, Path(d))
        if args.emulated:
            emulated(args.every, args.jobs, Path(d))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
