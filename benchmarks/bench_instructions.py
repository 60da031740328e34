"""Instructions per frame of two checkouts of this project, counted by callgrind (issue 11).

On this project's machines the CPU time of a frame moves by 2x from one minute to the next
(benchmarks/README, "The machine's share"); the instructions it executes do not.
``valgrind --tool=callgrind`` counts them, the same for the same code and frames whatever else the
machine does, so a change of a few per cent shows in one run. What the count misses is what
costs time without instructions: cache misses, page faults, a stalled CPU.

Each checkout's chain of ``--nodes`` configured patches (``bench_serve_hostile``'s) answers, under
callgrind, counting only inside ``EcatChain.answer`` (``--toggle-collect``; the configuration is
not counted):

- ``--lrds`` LRDs of the whole image, new taxels published to every patch before each (untimed,
  as serve's taxel feed publishes between frames): serve's everyday frame;
- ``--hostile`` hostile frames of ``--seed`` with a master's reset every 500 (the frames of
  ``bench_serve_hostile`` and ``bench_serve_ab``), 0 for none;
- ``--publishes`` the taxel feed's samples published to every patch, counted inside
  ``EcatChain.publish`` instead (what serve does between frames once a period), 0 for none.

Printed per checkout and workload: instructions per frame (per sample published), and new / old.

    python benchmarks/bench_instructions.py OLD_CHECKOUT [NEW_CHECKOUT] [--nodes 160]
        [--lrds 20] [--hostile 300] [--publishes 20] [--seed 0]

Needs valgrind and each checkout's ESC modules compiled (``make``, or ``python -m
emulator.esc.build`` in the checkout): the count is taken in the compiled ``answer``. A
checkout is a directory with this project's sources (``git archive COMMIT | tar -x -C DIR``).
Hash seeds are fixed (``PYTHONHASHSEED=0``) and the ESCs' clocks stand at 0 (the chain's
default, so no SYNC0 pulse comes due with the time of day): the same checkout counts the same
twice. (``bench_serve_ab.py`` runs the clocks in host time, as serve does.)
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SIZE, EVERY = 8, 500  # bench_serve_hostile's defaults: bytes a patch, frames between resets
ANSWER = "CPyDef_chain___EcatChain___answer"  # mypyc's C function for EcatChain.answer
PUBLISH = "CPyDef_chain___EcatChain___publish"  # and for EcatChain.publish
COLLECTED = re.compile(r"Collected : (\d+)")


def worker(checkout: str, nodes: int, workload: str, count: int, seed: int) -> None:
    """Run one workload in this process (under callgrind): print the frames answered."""
    sys.path[:0] = [checkout, os.path.join(checkout, "benchmarks")]
    from bench_serve_hostile import configured_chain, final_frames, with_resets

    from emulator.esc import compiled
    from emulator.live import TaxelFeed

    if not compiled.in_use():
        raise SystemExit(f"{checkout}: the ESC modules are not compiled (make)")
    chain = configured_chain(nodes, SIZE, True)
    if workload == "lrd":
        lrd = final_frames(nodes, SIZE, True)[-1]
        feed = TaxelFeed(nodes, SIZE, samples=16, seed=seed, period_s=0.0)
        for _ in range(count):
            feed.publish(chain, time.monotonic() + 1.0)
            chain.answer(lrd)
            chain.run_firmware()
        print(count)
    elif workload == "publish":  # the feed's samples, in turn (counted inside publish alone)
        feed = TaxelFeed(nodes, SIZE, samples=16, seed=seed, period_s=0.0)
        for _ in range(count):
            feed.publish(chain, time.monotonic() + 1.0)
        print(count)
    else:
        sent = [f for f, _ in with_resets(count, nodes, SIZE, seed, EVERY)]
        for frame in sent:
            chain.answer(frame)
            chain.run_firmware()
        print(len(sent))


def counted(checkout: str, nodes: int, workload: str, count: int, seed: int) -> tuple[int, int]:
    """(instructions inside ``EcatChain.answer``, frames answered) of one workload."""
    with tempfile.TemporaryDirectory() as scratch:
        run = subprocess.run(
            ["valgrind", "--tool=callgrind",
             f"--toggle-collect={PUBLISH if workload == 'publish' else ANSWER}",
             f"--callgrind-out-file={scratch}/callgrind.out", sys.executable, __file__,
             "--worker", checkout, "--nodes", str(nodes), "--workload", workload,
             "--count", str(count), "--seed", str(seed)],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONHASHSEED": "0"},
            check=False,
        )  # fmt: skip
    found = COLLECTED.search(run.stderr)
    if run.returncode != 0 or found is None:
        tail = (run.stderr.strip().splitlines() or ["no output"])[-1]
        raise SystemExit(f"bench_instructions: {checkout} ({workload}): {tail}")
    return int(found.group(1)), int(run.stdout.split()[-1])


def frames_count(text: str) -> int:
    """A count of frames: 0 or more."""
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is negative")
    return value


def patches(text: str) -> int:
    """A number of patches: 1 to MAX_SLAVES, as serve takes them."""
    value = int(text)
    if not 1 <= value <= 0xFFFF:
        raise argparse.ArgumentTypeError(f"{value} is not 1..65535")
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("old", help="a checkout of this project (the reference)")
    parser.add_argument("new", nargs="?", default=str(ROOT), help="default: this checkout")
    parser.add_argument("--nodes", type=patches, default=160, help="patches (default 160)")
    parser.add_argument(
        "--lrds", type=frames_count, default=20, help="LRDs of the image (default 20)"
    )
    parser.add_argument(
        "--hostile", type=frames_count, default=300, help="hostile frames (default 300; 0: none)"
    )
    parser.add_argument(
        "--publishes", type=frames_count, default=20, help="samples published (default 20)"
    )
    parser.add_argument("--seed", type=int, default=0, help="of the taxels and hostile frames")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--workload", choices=("lrd", "hostile", "publish"), help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.old, args.nodes, args.workload, args.count, args.seed)
        return
    for checkout in (args.old, args.new):
        if not (Path(checkout) / "emulator" / "esc" / "chain.py").is_file():
            parser.error(
                f"{checkout!r} is not a checkout of this project (no emulator/esc/chain.py)"
            )
    if shutil.which("valgrind") is None:
        parser.error("valgrind is not installed (apt install valgrind)")
    workloads = [
        (w, n)
        for w, n in (("lrd", args.lrds), ("hostile", args.hostile), ("publish", args.publishes))
        if n
    ]
    print(
        f"{args.nodes} patches; instructions inside EcatChain.answer (publish: inside "
        "EcatChain.publish), counted by callgrind"
    )
    for workload, count in workloads:
        per_frame = {}
        for name, checkout in (("old", args.old), ("new", args.new)):
            instructions, frames = counted(checkout, args.nodes, workload, count, args.seed)
            per_frame[name] = instructions / frames
            unit = "sample" if workload == "publish" else "frame"
            print(
                f"  {workload} {name} ({checkout}): {frames} {unit}s, "
                f"{per_frame[name]:,.0f} a {unit}"
            )
        print(f"  {workload} new / old: {per_frame['new'] / per_frame['old']:.3f}")


if __name__ == "__main__":
    main()
