"""``skinframes can decode`` against python-can's own ``can.LogReader``, same file, same run.

Writes a skin CAN log with the project's own writer (the emulated 1 Mbit/s bus of
:func:`emulator.net.can_bus.skin_bus`, 7 boards x 16 triangles, 50 ms period, through
:func:`skinframes.canbus.log.write_can_log`) into a temporary folder, then alternates, ``--rounds``
times in this one process:

- python-can: ``for msg in can.LogReader(path)`` (iteration only: no decoding, no output);
- skinframes: ``skinframes can decode PATH`` (``main([...])``: read, reassemble, print every
  sample to /dev/null, the accounting to stderr, also /dev/null).

It prints the frames per second of each (wall clock, and per second of the process's CPU time,
which a machine shared with other jobs disturbs less), the medians of the per-round ratios decode /
python-can (the issue's goal: at least 1), and the file's size. Printed, never asserted. ``--log PATH`` times
an existing log instead; ``--write-only`` just writes the log (e.g. the 1 GB log the issue's
memory check decodes under ``/usr/bin/time -v``).

    python benchmarks/bench_can_log.py [--samples 2000] [--format .asc] [--rounds 3]
    python benchmarks/bench_can_log.py --write-only --samples 75000 --out /tmp/x/skin_1g.asc
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import can

from emulator.net.can_bus import skin_bus
from skinframes import taxel
from skinframes.canbus import DEFAULT_PERIOD_MS, CanFrame
from skinframes.canbus.log import write_can_log
from skinframes_cli import main as cli

BOARDS = list(range(8, 15))  # a 7-board skin bus, as the demo's
CHUNK_SAMPLES = 50  # samples emulated per call of skin_bus (its frame list stays small)
PERIOD_PS = DEFAULT_PERIOD_MS * 1_000_000_000


def skin_frames(samples: int) -> Iterator[CanFrame]:
    """The frames of ``samples`` periods of the emulated skin bus, generated chunk by chunk."""
    for c in range(0, samples, CHUNK_SAMPLES):
        n = min(CHUNK_SAMPLES, samples - c)
        taxels = taxel.contact_pattern(len(BOARDS), n, seed=c)
        frames, _ = skin_bus(BOARDS, taxels, PERIOD_PS)
        shift_ns = c * PERIOD_PS // 1000
        for f in frames:
            yield CanFrame(f.arbitration_id, f.data, time_ns=f.time_ns + shift_ns)


def python_can_rate(path: Path) -> tuple[int, float, float]:
    """(frames, wall s, CPU s) of one iteration of can.LogReader over the file."""
    t, c = time.perf_counter(), time.process_time()
    with can.LogReader(str(path)) as reader:
        n = sum(1 for _ in reader)
    return n, time.perf_counter() - t, time.process_time() - c


def decode_rate(path: Path) -> tuple[float, float]:
    """(wall s, CPU s) of one ``skinframes can decode PATH``, output to /dev/null."""
    with (
        open(os.devnull, "w") as null,
        contextlib.redirect_stdout(null),
        contextlib.redirect_stderr(null),
    ):
        t, c = time.perf_counter(), time.process_time()
        code = cli(["can", "decode", str(path)])
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    if code != 0:
        sys.exit(f"can decode exited {code}")
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=2000, help="periods of 7 boards (224 frames)")
    ap.add_argument("--format", default=".asc", help="log format suffix (default .asc)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--log", type=Path, help="time this log instead of writing one")
    ap.add_argument("--write-only", action="store_true", help="write the log to --out and stop")
    ap.add_argument("--out", type=Path, help="with --write-only: the log to write")
    args = ap.parse_args()
    if args.write_only:
        if args.out is None:
            sys.exit("--write-only needs --out")
        t = time.perf_counter()
        n = write_can_log(args.out, skin_frames(args.samples))
        size = args.out.stat().st_size
        print(f"{args.out}: {n:,} frames, {size / 1e6:,.1f} MB in {time.perf_counter() - t:.0f} s")
        return
    with tempfile.TemporaryDirectory() as tmp:
        path = args.log or Path(tmp) / f"skin{args.format}"
        if args.log is None:
            write_can_log(path, skin_frames(args.samples))
        size_mb = path.stat().st_size / 1e6
        frames, _, _ = python_can_rate(path)  # warm-up (page cache, imports), also the frame count
        decode_rate(path)
        print(f"{path.name}: {size_mb:,.1f} MB, {frames:,} frames; {args.rounds} rounds\n")
        print(
            f"{'round':>5}{'python-can fps':>16}{'can decode fps':>16}{'ratio':>8}"
            f"{'CPU: python-can':>17}{'can decode':>12}{'ratio':>8}"
        )
        ratios, cpu_ratios, ours, theirs = [], [], [], []
        for k in range(args.rounds):
            n, wall_pc, cpu_pc = python_can_rate(path)
            wall_sf, cpu_sf = decode_rate(path)
            theirs.append(n / wall_pc)
            ours.append(n / wall_sf)
            ratios.append(wall_pc / wall_sf)
            cpu_ratios.append(cpu_pc / cpu_sf)
            print(
                f"{k + 1:>5}{theirs[-1]:>16,.0f}{ours[-1]:>16,.0f}{ratios[-1]:>8.2f}"
                f"{n / cpu_pc:>17,.0f}{n / cpu_sf:>12,.0f}{cpu_ratios[-1]:>8.2f}"
            )
        ratio, cpu_ratio = statistics.median(ratios), statistics.median(cpu_ratios)
        print(
            f"\nmedian: python-can LogReader {statistics.median(theirs):,.0f} frames/s, "
            f"skinframes can decode {statistics.median(ours):,.0f} frames/s (wall clock); "
            f"ratio (median of rounds) {ratio:.2f} wall, {cpu_ratio:.2f} CPU time: "
            f"{'MET' if min(ratio, cpu_ratio) >= 1 else 'NOT MET'} (goal >= 1)"
        )


if __name__ == "__main__":
    main()
