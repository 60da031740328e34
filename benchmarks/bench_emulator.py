"""Emulator speed and memory, measured against references in the same run (printed, never asserted).

1. With a pcap: ``simulate`` of the 160-patch x 192-byte skin (EtherCAT closed ring and EPL, wire
   preset) writing its pcap, against one sequential write of the same number of bytes into a
   file in the same directory (equal 8 MiB buffers), the two alternating, median of three each,
   each side after a sync and ``--settle`` seconds (both write into pages in the same state):
   the ratio emulator (whole process) / raw write (issue goal: at most 2), and the emulating
   process's peak RSS (goal: at most 256 MB). The ratio depends on the page cache: where the
   kernel writes back at disk speed the raw write is slower and the ratio smaller. Also printed:
   the CPU seconds (user + sys) of each side, and their ratio, which other jobs on a shared
   machine disturb less than wall times (the emulator draws its taxels on a second thread, so
   its wall time can be less than its CPU time on an idle machine).
2. Timing only (no pcap): ``simulate ecat --redundant`` of a million cycles: simulated seconds per
   wall second, whole process (goal: at least 1,000), and its peak RSS.

Each run is a fresh process (``python -m skinframes_cli`` or ``skinframes`` of this checkout), so
start-up and peak memory are its own. Its bytecode is compiled by the first run and kept in the
temporary folder, as an installed package keeps it, even where PYTHONDONTWRITEBYTECODE is set.

    python benchmarks/bench_emulator.py [--cycles 20000] [--timing-cycles 1000000] [--dir DIR]
                                        [--settle 3]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
NODES, BYTES = "160", "192"
CHILD = """
import resource, sys, time
from skinframes_cli import main
t = time.perf_counter()
code = main(sys.argv[1:])
wall = time.perf_counter() - t
use = resource.getrusage(resource.RUSAGE_SELF)
print("BENCH", wall, use.ru_maxrss, code, use.ru_utime + use.ru_stime, file=sys.stderr)
"""


def child_env(tmp: str) -> dict[str, str]:
    """The children's environment: bytecode compiled once and kept (in ``tmp``, not in the
    checkout), as an installed package has it, even where PYTHONDONTWRITEBYTECODE is set
    (compiling the 50-odd modules a run imports costs every run about 0.2 s here)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, "PYTHONPYCACHEPREFIX": str(Path(tmp) / "pycache")}


ENV: dict[str, str] = {}


def emulate(argv: list[str]) -> tuple[float, float, str, float]:
    """Run the CLI in a fresh process: (wall s of the whole process, peak RSS MB, stdout, CPU s
    of the whole process)."""
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", CHILD, *argv],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
        env=ENV or None,
    )
    wall = time.perf_counter() - t0
    line = next(x for x in done.stderr.splitlines() if x.startswith("BENCH"))
    rss_mb = int(line.split()[2]) / 1024
    return wall, rss_mb, done.stdout, float(line.split()[4])


def raw_write(path: Path, size: int) -> tuple[float, float]:
    """One sequential write of ``size`` bytes (8 MiB buffers), flushed to the page cache:
    (wall s, CPU s)."""
    buf = b"\x5a" * (8 << 20)
    t0, c0 = time.perf_counter(), time.process_time()
    with open(path, "wb") as f:
        left = size
        while left > 0:
            f.write(buf[: min(left, len(buf))])
            left -= len(buf)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    path.unlink()
    return wall, cpu


def settle(seconds: float) -> None:
    """No dirty pages to write back, and no pages freed a moment ago: on the VMs measured here
    a write into pages freed less than about half a second before runs 3-4x faster than into
    pages freed earlier (README), and a side that starts at once (the raw write) would get them
    while a side that starts a process first (the emulator) would not."""
    os.sync()
    time.sleep(seconds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=20_000, help="cycles of the pcap runs")
    ap.add_argument("--timing-cycles", type=int, default=1_000_000)
    ap.add_argument("--dir", default=None, help="where the pcaps go (default: a temp dir)")
    ap.add_argument(
        "--settle",
        type=float,
        default=3.0,
        help="seconds to wait after each side's sync, so both write into pages in the same "
        "state (README: 'pages freed a moment ago')",
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        ENV.update(child_env(tmp))
        load = os.getloadavg()[0]
        print(f"{NODES} patches x {BYTES} bytes, wire preset; pcaps in {tmp}; load {load:.1f}\n")
        print(
            f"{'with a pcap':<22}{'cycles':>9}{'GB':>7}{'emulator s':>12}{'raw write s':>13}"
            f"{'ratio':>7}{'peak MB':>9}{'CPU s':>7}{'raw CPU s':>11}{'CPU ratio':>11}"
        )
        for name, extra in (("ecat closed ring", ["ecat", "--redundant"]), ("epl", ["epl"])):
            pcap = Path(tmp) / "bench.pcap"
            argv = ["simulate", *extra, "--nodes", NODES, "--bytes", BYTES, "--preset", "wire"]
            argv += ["--cycles", str(args.cycles), "--pcap", str(pcap)]
            emulate(argv)  # a first run sizes the file, compiles, warms the page cache
            size = pcap.stat().st_size
            pcap.unlink()
            # raw write and emulator alternate, each on a fresh file: the median of three each
            raws, walls, rsss, cpus, raw_cpus = [], [], [], [], []
            for _ in range(3):
                settle(args.settle)  # each side starts in the same state (README)
                raw, raw_cpu = raw_write(Path(tmp) / "raw.bin", size)
                settle(args.settle)
                wall, rss, _, cpu = emulate(argv)
                pcap.unlink()
                raws.append(raw)
                raw_cpus.append(raw_cpu)
                walls.append(wall)
                rsss.append(rss)
                cpus.append(cpu)
            raw, wall, rss = sorted(raws)[1], sorted(walls)[1], max(rsss)
            cpu, raw_cpu = sorted(cpus)[1], sorted(raw_cpus)[1]
            print(
                f"{name:<22}{args.cycles:>9}{size / 1e9:>7.2f}{wall:>12.2f}{raw:>13.2f}"
                f"{wall / raw:>7.2f}{rss:>9.0f}{cpu:>7.2f}{raw_cpu:>11.2f}{cpu / raw_cpu:>11.2f}"
            )
        print(
            f"\n{'timing only':<22}{'cycles':>9}{'sim s':>9}{'wall s':>9}{'x real time':>13}"
            f"{'peak MB':>9}"
        )
        wall, rss, out, _ = emulate(
            [
                "simulate",
                "ecat",
                "--redundant",
                "--nodes",
                NODES,
                "--bytes",
                BYTES,
                "--preset",
                "wire",
                "--cycles",
                str(args.timing_cycles),
                "--json",
            ]
        )
        doc = json.loads(out)
        sim = doc["cycles"] * doc["cycle_us"]["median"] / 1e6
        print(
            f"{'ecat closed ring':<22}{args.timing_cycles:>9}{sim:>9.0f}{wall:>9.2f}"
            f"{sim / wall:>13.0f}{rss:>9.0f}"
        )
    os.sync()


if __name__ == "__main__":
    main()
