"""CPU per hostile frame of two checkouts of this project, frame by frame on one CPU (issue 11).

On a shared machine a process's CPU time per frame can differ by 2x from one process to the next
(seen here: the same code and frame, 4.3 ms in one process and 8.1 ms in the next), and two
processes running side by side disagree as well. So the checkouts run in two worker processes
pinned to the same CPU, and take turns ten frames at a time: whatever slows the machine
slows both. Each worker runs the frames of ``bench_serve_hostile`` with its defaults (hostile
frames of ``--seed``, 8 bytes a patch, a master's reset every 500) through its own chain of
``--nodes`` configured patches, the ESCs' clocks in host time as serve runs them (before
2026-11-27 they stood at 0 here, so that no SYNC0 pulse came due), ``--runs`` times, and keeps
each frame's least CPU time (this thread's clock, garbage collected between frames) until its
answer, as serve counts it (a checkout whose chain has ``answer`` lets the slaves' firmware
react after it, untimed, as serve does; an older one's ``process_frame`` includes the
firmware).

``--gap-us`` makes each worker sleep before each frame, as serve idles between a master's frames
(each frame then meets a cooler machine, as live frames do).

``--ordinary`` sends no hostile frame: ``--frames`` LRDs of the whole image, new taxels
published to every patch before each (untimed, as serve's taxel feed publishes between frames):
serve's everyday frame with a master at 160 patches.

Printed per checkout: frames above 2 ms, total, median and maximum CPU per frame; then the frames
whose time changed most. Run with the same checkout twice to see the method's own spread.

    python benchmarks/bench_serve_ab.py OLD_CHECKOUT [NEW_CHECKOUT] [--frames 3000] [--runs 2]
        [--nodes 160] [--seed 0] [--cpu 0] [--gap-us 0] [--ordinary]

A checkout is a directory with this project's sources (``git worktree add`` or
``git archive COMMIT | tar -x -C DIR``); NEW_CHECKOUT defaults to this one.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO

ROOT = Path(__file__).resolve().parent.parent
BUDGET_US = 2000
BATCH = 10  # frames a worker runs before the other one takes its turn
SIZE, EVERY = 8, 500  # bench_serve_hostile's defaults: bytes a patch, frames between resets


def worker(
    checkout: str, nodes: int, frames: int, seed: int, gap_us: float, ordinary: bool
) -> None:
    """Serve the master's requests on stdin: ``reset`` (a fresh configured chain) or ``run LO HI``
    (those frames; their CPU times in us as a JSON list)."""
    sys.path[:0] = [checkout, os.path.join(checkout, "benchmarks")]
    # the checkout's own
    from bench_serve_hostile import configured_chain, final_frames, with_resets

    from emulator.live import TaxelFeed

    sent = ordinary_frames(frames, nodes, final_frames) if ordinary else [
        f for f, _ in with_resets(frames, nodes, SIZE, seed, EVERY)
    ]  # fmt: skip
    feed = TaxelFeed(nodes, SIZE, samples=16, seed=seed, period_s=0.0) if ordinary else None
    cpu = time.thread_time_ns
    chain = None
    gc.disable()
    for line in sys.stdin:
        words = line.split()
        if words[0] == "reset":
            forget_caches()
            chain = configured_chain(nodes, SIZE, True)
            chain.clock_ns = time.monotonic_ns  # as serve runs the ESCs' clocks
            print("ok", flush=True)
            continue
        assert chain is not None
        us = []
        answer = getattr(chain, "answer", chain.process_frame)  # older checkouts: no answer
        firmware = getattr(chain, "run_firmware", lambda: None)
        for frame in sent[int(words[1]) : int(words[2])]:
            if gap_us:
                time.sleep(gap_us / 1e6)  # idle before each frame, as serve waits in select
            if feed is not None:  # new taxels at every patch, as serve publishes between frames
                feed.publish(chain, time.monotonic() + 1.0)
            c0 = cpu()
            answer(frame)
            us.append((cpu() - c0) // 1000)
            firmware()  # as serve does: after the answer, not timed
            gc.collect(0)
        print(json.dumps(us), flush=True)


def ordinary_frames(
    frames: int, nodes: int, final_frames: Callable[[int, int, bool], list[bytes]]
) -> list[bytes]:
    """``frames`` times the LRD of the whole image that ends ``final_frames``
    (bench_serve_hostile's)."""
    return [final_frames(nodes, SIZE, True)[-1]] * frames


def forget_caches() -> None:
    """Empty an older checkout's caches shared by every ESC: :func:`emulator.esc.mapping.forget`
    where the checkout has it, and every module-level dict named ``*_CACHE`` in
    ``emulator.esc`` (checkouts older than ``forget``): each run pays what a process that has
    seen none of the frames pays, as serve does. (Since issue 39 the caches are each chain's
    own, ``EcatChain.caches``: a fresh chain starts with none, and ``forget`` does nothing.)"""
    forget = getattr(sys.modules.get("emulator.esc.mapping"), "forget", None)
    if forget is not None:
        forget()
    for name, module in list(sys.modules.items()):
        if name.startswith("emulator.esc"):
            for attr, value in vars(module).items():
                if attr.endswith("_CACHE") and isinstance(value, dict):
                    value.clear()


def ask(proc: subprocess.Popen[str], request: str) -> str:
    stdin, stdout = proc.stdin, proc.stdout
    assert stdin is not None and stdout is not None
    stdin.write(request + "\n")
    stdin.flush()
    return stdout.readline()


def start(
    checkout: str, nodes: int, frames: int, seed: int, cpu: int, gap_us: float, ordinary: bool
) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, __file__, "--worker", checkout, "--nodes", str(nodes),
         "--frames", str(frames), "--seed", str(seed), "--gap-us", str(gap_us),
         *(["--ordinary"] if ordinary else [])],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: os.sched_setaffinity(0, {cpu}),
    )  # fmt: skip


def report(name: str, least: list[int], out: IO[str]) -> None:
    over = sum(t > BUDGET_US for t in least)
    print(
        f"{name}: {over} frames above {BUDGET_US} us, total {sum(least) / 1e3:.0f} ms, "
        f"median {statistics.median(least):.0f} us, max {max(least)} us",
        file=out,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("old", help="a checkout of this project (the reference)")
    parser.add_argument("new", nargs="?", default=str(ROOT), help="default: this checkout")
    parser.add_argument("--frames", type=int, default=3000, help="hostile frames (default 3000)")
    parser.add_argument("--runs", type=int, default=2, help="runs per checkout (default 2)")
    parser.add_argument("--nodes", type=int, default=160, help="patches (default 160)")
    parser.add_argument("--seed", type=int, default=0, help="of the hostile frames (default 0)")
    parser.add_argument("--cpu", type=int, default=0, help="the CPU both workers run on")
    parser.add_argument(
        "--gap-us",
        type=float,
        default=0.0,
        help="sleep this long before each frame, as serve idles between a master's frames",
    )
    parser.add_argument(
        "--ordinary",
        action="store_true",
        help="no hostile frame: LRDs of the image, new taxels published before each",
    )
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.old, args.nodes, args.frames, args.seed, args.gap_us, args.ordinary)
        return
    for checkout in (args.old, args.new):
        if not (Path(checkout) / "emulator" / "esc" / "chain.py").is_file():
            parser.error(
                f"{checkout!r} is not a checkout of this project (no emulator/esc/chain.py)"
            )
    sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]
    from bench_serve_hostile import describe, final_frames, with_resets

    sent = ordinary_frames(args.frames, args.nodes, final_frames) if args.ordinary else [
        f for f, _ in with_resets(args.frames, args.nodes, SIZE, args.seed, EVERY)
    ]  # fmt: skip
    checkouts = {"old": args.old, "new": args.new}
    procs = {
        k: start(v, args.nodes, args.frames, args.seed, args.cpu, args.gap_us, args.ordinary)
        for k, v in checkouts.items()
    }
    least = {k: [1 << 62] * len(sent) for k in checkouts}
    for _ in range(args.runs):
        for proc in procs.values():
            ask(proc, "reset")
        for lo in range(0, len(sent), BATCH):
            for k, proc in procs.items():
                for j, us in enumerate(json.loads(ask(proc, f"run {lo} {lo + BATCH}"))):
                    least[k][lo + j] = min(least[k][lo + j], us)
    for proc in procs.values():
        assert proc.stdin is not None
        proc.stdin.close()
        proc.wait()
    what = "LRDs of the image, taxels published before each" if args.ordinary else (
        f"{args.frames} hostile, seed {args.seed}"
    )  # fmt: skip
    print(
        f"{len(sent)} frames ({what}), {args.nodes} slaves, "
        f"least of {args.runs} runs, both checkouts on CPU {args.cpu}, {BATCH} frames a turn"
        + (f", {args.gap_us:.0f} us idle before each" if args.gap_us else "")
    )
    for k, path in checkouts.items():
        report(f"  {k} ({path})", least[k], sys.stdout)
    if args.ordinary:
        return  # the same frame throughout: nothing to tell apart frame by frame
    old, new = least["old"], least["new"]
    order = sorted(range(len(sent)), key=lambda i: new[i] - old[i])
    print("  most faster (frame: old us -> new us, datagrams cmd@ado+bytes):")
    for i in order[:8]:
        print(f"    {i}: {old[i]} -> {new[i]}  {describe(sent[i])}")
    print("  most slower:")
    for i in order[-8:][::-1]:
        print(f"    {i}: {old[i]} -> {new[i]}  {describe(sent[i])}")


if __name__ == "__main__":
    main()
