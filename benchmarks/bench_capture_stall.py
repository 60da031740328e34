"""How long ``serve``'s capture holds up its answers: ``CaptureWriter.write`` direct, and written
behind (``write_behind=True``, a thread of its own, which ``serve --pcap`` uses).

A serve-like writer appends records of ``--frame-bytes`` at ``--rate`` records a second (a burst
of ``--burst`` every burst's share of a second, as frames come in cycles) for ``--seconds``, and
times every ``write`` with ``perf_counter``. The capture goes to

  pipe  a reader in another process that reads 64 KiB at a time and stops for ``--pause-ms``
        every ``--every-ms`` (a Wireshark window redrawing, a ``tshark`` busy for a moment): a
        pipe holds 64 KiB, so a writer that writes into it waits as long as the reader pauses;
  file  a temporary file in ``--dir`` (default: the system's temporary folder): the kernel
        copies each flushed buffer into its page cache, which on this VM takes milliseconds a
        MiB, and throttles a writer while other programs' dirty pages go to the disk.

The two writers take turns over ``--rounds``. ``--chunk-bytes`` sets the chunk the thread is
handed (``skinframes.write_behind.CHUNK_BYTES``, 64 KiB), to show what 1 MiB chunks cost. Printed per target and writer: the writes, the
median and the largest time of one, and how many took 1 ms or more (serve's answer budget is
in the hundreds of microseconds). Printed, never asserted.

    python benchmarks/bench_capture_stall.py [--seconds 10] [--rate 2000] [--frame-bytes 250]
        [--burst 20] [--pause-ms 200] [--every-ms 1000] [--rounds 2] [--chunk-bytes N] [--dir D]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import BinaryIO, cast

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from skinframes import write_behind
from skinframes.capture_writer import CaptureWriter

READER = """
import os, sys, time
pause_s, every_s = float(sys.argv[1]), float(sys.argv[2])
fd, next_pause = sys.stdin.fileno(), time.monotonic() + every_s
while os.read(fd, 65536):
    if time.monotonic() >= next_pause:
        time.sleep(pause_s)
        next_pause = time.monotonic() + every_s
"""


def write_for(writer: CaptureWriter, args: argparse.Namespace) -> list[float]:
    """Write as serve would for ``args.seconds``; the time of each write, in seconds."""
    frame = bytes(args.frame_bytes)
    period_s = args.burst / args.rate
    times: list[float] = []
    clock = time.perf_counter
    end = time.monotonic() + args.seconds
    next_burst = time.monotonic()
    while time.monotonic() < end:
        for _ in range(args.burst):
            t0 = clock()
            writer.write(time.time_ns(), frame, outbound=False)
            times.append(clock() - t0)
        next_burst += period_s
        time.sleep(max(0.0, next_burst - time.monotonic()))
    return times


def one_run(target: str, behind: bool, args: argparse.Namespace, folder: str) -> list[float]:
    if target == "file":
        with CaptureWriter(Path(folder) / "stall.pcapng", write_behind=behind) as writer:
            return write_for(writer, args)
    reader = subprocess.Popen(
        [sys.executable, "-c", READER, str(args.pause_ms / 1e3), str(args.every_ms / 1e3)],
        stdin=subprocess.PIPE,
    )
    assert reader.stdin is not None
    try:
        pipe = cast(BinaryIO, reader.stdin)
        with CaptureWriter(pipe, fmt="pcapng", write_behind=behind) as writer:
            times = write_for(writer, args)
    finally:
        reader.stdin.close()
        reader.wait()
    return times


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--rate", type=int, default=2000, help="records a second")
    p.add_argument("--frame-bytes", type=int, default=250)
    p.add_argument("--burst", type=int, default=20)
    p.add_argument("--pause-ms", type=float, default=200.0)
    p.add_argument("--every-ms", type=float, default=1000.0)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--chunk-bytes", type=int, default=write_behind.CHUNK_BYTES)
    p.add_argument("--dir", default=None)
    args = p.parse_args()
    write_behind.CHUNK_BYTES = args.chunk_bytes  # type: ignore[misc]  # read at each write
    print(
        f"{args.rate} records/s of {args.frame_bytes} bytes in bursts of {args.burst}, "
        f"{args.seconds:g} s a run, {args.rounds} rounds; pipe reader pauses {args.pause_ms:g} ms "
        f"every {args.every_ms:g} ms; chunks of {args.chunk_bytes} bytes; nproc {os.cpu_count()}, loadavg {os.getloadavg()[0]:.2f}"
    )
    with tempfile.TemporaryDirectory(dir=args.dir) as folder:
        for target in ("pipe", "file"):
            pooled: dict[bool, list[float]] = {False: [], True: []}
            for r in range(args.rounds):
                for behind in (False, True) if r % 2 == 0 else (True, False):
                    pooled[behind] += one_run(target, behind, args, folder)
            for behind, times in pooled.items():
                slow = sum(1 for t in times if t >= 1e-3)
                print(
                    f"  {target:4}  {'behind' if behind else 'direct':6}  {len(times):7} writes  "
                    f"median {statistics.median(times) * 1e6:6.1f} us  "
                    f"largest {max(times) * 1e3:7.1f} ms  {slow:5} of 1 ms or more"
                )


if __name__ == "__main__":
    main()
