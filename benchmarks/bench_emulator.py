"""Emulator speed: simulated seconds per wall second, pcap output included.

Runs the 160-patch x 192-byte skin over EtherCAT (closed and open ring) and EPL for about one
simulated second each, writing the pcap to a temporary file, and prints the real-time factor
(simulated time / wall time, start-up of the run included: frame building, ESC resolution,
taxel generation, pcap assembly and write). Median of several rounds. Printed, never asserted.

    python benchmarks/bench_emulator.py [--quick]
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from emulator.ecat_cycle import simulate_ecat  # noqa: E402
from emulator.epl_cycle import simulate_epl  # noqa: E402
from emulator.params import WIRE  # noqa: E402

NODES, BYTES = 160, 192
GOALS = {"ecat closed ring": (50, 200), "ecat open ring": (50, 200), "epl": (20, 50)}


def run(name: str, cycles: int, path: Path) -> tuple[float, float, int]:
    """One run: (simulated s, wall s, pcap bytes)."""
    gc.collect()
    t0 = time.perf_counter()
    if name == "epl":
        r = simulate_epl(NODES, BYTES, WIRE, cycles=cycles, seed=1)
    else:
        r = simulate_ecat(
            NODES, BYTES, WIRE, redundant=name.endswith("closed ring"), cycles=cycles, seed=1
        )
    r.trace.write_pcap(path)
    wall = time.perf_counter() - t0
    last = r.details[-1]
    return (last.start_ps + last.cycle_ps) / 1e12, wall, path.stat().st_size


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds, ~0.25 s simulated")
    args = ap.parse_args()
    rounds = 3 if args.quick else 7
    target_s = 0.25 if args.quick else 1.0
    print(
        f"{NODES} patches x {BYTES} bytes, wire preset, pcap written to a temp dir; "
        f"median of {rounds} rounds\n"
    )
    print(
        f"{'network':<18}{'cycles':>8}{'sim s':>8}{'wall s':>9}{'x real time':>13}"
        f"{'pcap MB':>9}   goal / stretch"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for name, (goal, stretch) in GOALS.items():
            probe_sim, _, _ = run(name, 2, Path(tmp) / "probe.pcap")
            cycles = max(2, round(target_s / (probe_sim / 2)))
            results = [run(name, cycles, Path(tmp) / "bench.pcap") for _ in range(rounds)]
            sim = results[0][0]
            wall = statistics.median(r[1] for r in results)
            factor = sim / wall
            verdict = "MET" if factor >= goal else "NOT MET"
            verdict += ", stretch MET" if factor >= stretch else ""
            print(
                f"{name:<18}{cycles:>8}{sim:>8.3f}{wall:>9.3f}{factor:>13.1f}"
                f"{results[0][2] / 1e6:>9.1f}   {goal}x / {stretch}x: {verdict}"
            )


if __name__ == "__main__":
    main()
