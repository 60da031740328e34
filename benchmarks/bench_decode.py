"""Reading captures: skinframes against tshark on the same files, in one run, as ratios.

Run from the repository root::

    python benchmarks/bench_decode.py [--cycles 2000] [--rounds 3] [--dir D]

Captures (written first by this checkout's ``skinframes simulate``, paper preset, seed 0): EPL
16 CNs x 192 bytes, EtherCAT 16 slaves x 192 bytes with one LRD per slave and with a logical
image. For each capture and round, in alternating order:

* ``taxels_from_capture(path)`` in this process, and ``skinframes decode --taxels`` as a
  process, against ``tshark -T fields`` extracting the payload (``data.data`` of the PRes,
  ``ecat.data`` of the datagrams; tshark 4.0 has no ``epl.pres.payload``). Target >= 10x.
* ``skinframes decode --json`` against ``tshark -T json``. Target >= 2x.
* ``skinframes check`` against ``tshark -q -z expert``. Target >= 1x.

Every command runs as a fresh process writing to /dev/null (tshark's start-up counts, as does
Python's). Reported: the median wall time of each and the median over rounds of the paired
ratios tshark / skinframes, of wall time and of CPU time (user + system: on a shared machine
the steadier of the two), both measured in the same round so that load drifting between rounds
cancels, with MET or NOT MET (by wall time). Nothing is asserted. Before timing, the taxels are checked equal
to the seeded patterns the emulator carried (``VERIFICATION FAILED``, exit 1, otherwise).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout, not an installed copy

from skinframes import taxel, taxels_from_capture  # noqa: E402
from skinframes_cli import main  # noqa: E402

NODES = 16
BYTES = 192
CAPTURES = {  # name -> (simulate arguments, tshark payload field, display filter)
    "epl": (["epl"], "data.data", "epl.pres"),
    "ecat per-slave": (["ecat", "--layout", "per-slave"], "ecat.data", ""),
    "ecat logical": (["ecat", "--layout", "logical"], "ecat.data", ""),
}


def skinframes(*args: str) -> list[str]:
    return [sys.executable, "-m", "skinframes_cli", *args]


def run_process(argv: list[str]) -> tuple[float, float]:
    """(wall, CPU user + system) seconds of one process, output to /dev/null."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run_call(fn: Callable[[], object]) -> tuple[float, float]:
    """(wall, CPU) seconds of a call in this process."""
    start, cpu = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - start, time.process_time() - cpu


def verify(path: Path, cycles: int) -> None:
    result = taxels_from_capture(path)
    want = taxel.contact_pattern(NODES, cycles, seed=0)
    if not np.array_equal(result.taxels, want) or not result.present.all():
        print(f"VERIFICATION FAILED: {path.name}: taxels differ from the emulated ones")
        raise SystemExit(1)


def main_bench() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cycles", type=int, default=2000, help="cycles per capture")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--dir", type=Path, help="where to write the captures (default: a temp dir)")
    args = ap.parse_args()
    tshark = shutil.which("tshark")
    if tshark is None:
        print("tshark not found: nothing to compare with")
        return 1
    work = Path(args.dir or tempfile.mkdtemp(prefix="bench_decode_"))
    version = subprocess.run([tshark, "-v"], capture_output=True, text=True).stdout.split("\n")[0]
    print(f"# bench_decode: {version}; CPython {sys.version.split()[0]}; numpy {np.__version__}")
    print(f"# load average {os.getloadavg()[0]:.2f}; {args.cycles} cycles; {args.rounds} rounds")
    rows: list[tuple[str, str, str, float, float, float, float, float]] = []
    for name, (sim, field, display) in CAPTURES.items():
        path = work / (name.replace(" ", "_") + ".pcap")
        argv = ["simulate", *sim, "--nodes", str(NODES), "--bytes", str(BYTES)]
        argv += ["--cycles", str(args.cycles), "--pcap", str(path)]
        with open(os.devnull, "w") as null:
            stdout, sys.stdout = sys.stdout, null
            try:
                assert main(argv) == 0
            finally:
                sys.stdout = stdout
        verify(path, args.cycles)
        frames = int(
            subprocess.run(
                [tshark, "-r", str(path), "-T", "fields", "-e", "frame.number"],
                capture_output=True,
                text=True,
            ).stdout.count("\n")
        )
        fields = [tshark, "-n", "-r", str(path), "-T", "fields", "-e", field]
        if display:
            fields += ["-Y", display]
        out = str(work / "taxels.npy")
        json_argv = [tshark, "-n", "-r", str(path), "-T", "json"]
        expert_argv = [tshark, "-n", "-r", str(path), "-q", "-z", "expert"]
        jobs: list[tuple[str, Callable[[], tuple[float, float]], str, list[str], float]] = [
            (
                "taxels_from_capture (library)",
                lambda p=path: run_call(lambda: taxels_from_capture(p)),  # type: ignore[misc]
                f"-T fields -e {field}",
                fields,
                10.0,
            ),
            (
                "decode --taxels (process)",
                lambda p=path, o=out: run_process(skinframes("decode", str(p), "--taxels", o)),  # type: ignore[misc]
                f"-T fields -e {field}",
                fields,
                10.0,
            ),
            (
                "decode --json",
                lambda p=path: run_process(skinframes("decode", str(p), "--json")),  # type: ignore[misc]
                "-T json",
                json_argv,
                2.0,
            ),
            (
                "check",
                lambda p=path: run_process(skinframes("check", str(p))),  # type: ignore[misc]
                "-q -z expert",
                expert_argv,
                1.0,
            ),
        ]
        for what, ours, reference, theirs, target in jobs:
            t_ours: list[float] = []
            t_theirs: list[float] = []
            ratios: list[float] = []
            cpu_ratios: list[float] = []
            for r in range(args.rounds):
                if r % 2:
                    b, a = run_process(theirs), ours()
                else:
                    a, b = ours(), run_process(theirs)
                t_ours.append(a[0])
                t_theirs.append(b[0])
                ratios.append(b[0] / a[0])
                cpu_ratios.append(b[1] / max(a[1], 1e-9))
                print(
                    f"  {name}: {what}: round {r}: wall {a[0]:.3f} s vs {b[0]:.3f} s, "
                    f"CPU {a[1]:.3f} s vs {b[1]:.3f} s",
                    file=sys.stderr,
                )
            rows.append(
                (
                    f"{name}, {frames} frames",
                    what,
                    f"tshark {reference}",
                    statistics.median(t_ours),
                    statistics.median(t_theirs),
                    statistics.median(ratios),
                    statistics.median(cpu_ratios),
                    target,
                )
            )
    print()
    print(
        "| capture | skinframes | against | skinframes s | tshark s | x tshark (wall) "
        "| x tshark (CPU) | target | verdict (wall) |"
    )
    print("|---|---|---|---:|---:|---:|---:|---:|---|")
    for capture, what, reference, ours_s, theirs_s, ratio, cpu_ratio, target in rows:
        verdict = "**MET**" if ratio >= target else "**NOT MET**"
        print(
            f"| {capture} | {what} | {reference} | {ours_s:.3f} | {theirs_s:.3f} | {ratio:.2f}x "
            f"| {cpu_ratio:.2f}x | >= {target:g}x | {verdict} |"
        )
    if args.dir is None:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main_bench())
