"""CaptureWriter.write_block against a raw sequential write of the same bytes.

Writes N cycles of a fixed layout (100 records per cycle, frame lengths 60..1514 from a seeded
RNG, two ports, mixed directions) with ``write_block`` in blocks of k cycles, to a temporary pcap
and to a pcapng, and in the same round the same number of bytes with a plain ``f.write`` loop of
buffers of one block's size. Prints the ratio writer time / raw time per format: the median of
the per-round ratios (writer and raw run back to back, in alternating order, so drifting load
cancels), and the ratio of the best times. The goal is <= 2. Printed, never asserted.

Every block passes the same data array (as an emulator passes the block it has just built, it is
warm in the cache); the raw loop writes one buffer over and over. On a shared machine single
figures move by tens of percent: read the median, and the load average printed with it.

    python benchmarks/bench_capture_writer.py [--cycles N] [--block K] [--rounds R] [--dir D]
"""

from __future__ import annotations

import argparse
import gc
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from skinframes.pcap import CaptureWriter  # noqa: E402

RECORDS_PER_CYCLE = 100
CYCLE_NS = 10_000_000  # a 10 ms cycle: the 100 frames take about 6.6 ms at 100 Mbit/s
WIRE_OVERHEAD_BYTES = 24  # preamble + SFD 8, FCS 4, IFG 12
NS_PER_BYTE = 80  # 100 Mbit/s
GOAL_RATIO = 2.0


def layout(seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(lengths, offsets in the cycle in ns, ports, outbound) of the 100 records of a cycle."""
    rng = np.random.default_rng(seed)
    lengths = rng.integers(60, 1515, RECORDS_PER_CYCLE)
    wire_ns = (lengths + WIRE_OVERHEAD_BYTES) * NS_PER_BYTE  # back to back on one link
    offsets_ns = np.concatenate(([0], np.cumsum(wire_ns)[:-1]))
    ports = (np.arange(RECORDS_PER_CYCLE) % 2).astype(np.int64)
    outbound = np.arange(RECORDS_PER_CYCLE) % 4 < 2
    return lengths, offsets_ns, ports, outbound


def write_with_writer(
    path: Path, cycles: int, block: int, data: np.ndarray, plan: tuple[np.ndarray, ...]
) -> tuple[float, int, int]:
    """(seconds, file bytes, bytes of the largest block) for all cycles through write_block."""
    lengths, offsets_ns, ports, outbound = plan
    gc.collect()
    gc.disable()
    t0 = time.perf_counter()
    with CaptureWriter(path, ports=2, port_names=["port 0", "port 1"]) as w:
        header = w.bytes_written
        for first in range(0, cycles, block):
            k = min(block, cycles - first)
            times = (np.arange(first, first + k)[:, None] * CYCLE_NS) + offsets_ns
            w.write_block(times, lengths, data[:k], ports=ports, outbound=outbound)
    seconds = time.perf_counter() - t0
    gc.enable()
    size = path.stat().st_size
    per_cycle = (size - header) // cycles
    return seconds, size, per_cycle * min(block, cycles)


def write_raw(path: Path, total: int, buffer_bytes: int) -> float:
    """Seconds to write ``total`` bytes sequentially in buffers of ``buffer_bytes``."""
    buf = np.full(buffer_bytes, 0x5A, dtype=np.uint8)
    gc.collect()
    t0 = time.perf_counter()
    with open(path, "wb") as f:
        left = total
        while left:
            n = min(buffer_bytes, left)
            f.write(buf.data[:n])
            left -= n
    return time.perf_counter() - t0


def verify(tmp: Path, data: np.ndarray, plan: tuple[np.ndarray, ...]) -> None:
    """write_block must write what write() writes, record by record (both formats)."""
    lengths, offsets_ns, ports, outbound = plan
    starts = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    for name in ("check.pcap", "check.pcapng"):
        one, block = tmp / ("one-" + name), tmp / ("block-" + name)
        times = np.arange(3)[:, None] * CYCLE_NS + offsets_ns
        with CaptureWriter(one, ports=2, port_names=["port 0", "port 1"]) as w:
            for c in range(3):
                for j in range(RECORDS_PER_CYCLE):
                    frame = data[c, starts[j] : starts[j] + lengths[j]].tobytes()
                    w.write(int(times[c, j]), frame, port=int(ports[j]), outbound=bool(outbound[j]))
        with CaptureWriter(block, ports=2, port_names=["port 0", "port 1"]) as w:
            w.write_block(times, lengths, data[:3], ports=ports, outbound=outbound)
        if one.read_bytes() != block.read_bytes():
            sys.exit(f"VERIFICATION FAILED: write_block differs from write() for {name}")
        one.unlink()
        block.unlink()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=3_200, help="cycles per file (default 3,200)")
    ap.add_argument("--block", type=int, default=64, help="cycles per write_block call")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--dir", type=Path, default=None, help="where the temporary files go")
    args = ap.parse_args()
    plan = layout()
    lengths = plan[0]
    rng = np.random.default_rng(2)
    data = rng.integers(0, 256, (args.block, int(lengths.sum())), dtype=np.uint8)
    load = os.getloadavg()[0]
    print(
        f"{RECORDS_PER_CYCLE} records per cycle ({int(lengths.min())}..{int(lengths.max())} "
        f"bytes, {int(lengths.sum()):,} per cycle), {args.cycles:,} cycles, {args.block} cycles "
        f"per block, {args.rounds} rounds; load average {load:.1f}\n"
    )
    results: dict[str, list[tuple[float, float]]] = {"pcap": [], "pcapng": []}
    sizes: dict[str, int] = {}
    block_bytes: dict[str, int] = {}
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp_name:
        tmp = Path(tmp_name)
        verify(tmp, data, plan)
        # untimed warm-up: the first writes of a run touch page-cache memory the (virtual)
        # machine has not handed out yet, and take several times longer than later ones
        for fmt in results:
            path = tmp / f"warm.{fmt}"
            _, sizes[fmt], block_bytes[fmt] = write_with_writer(
                path, args.cycles, args.block, data, plan
            )
            path.unlink()
        write_raw(tmp / "warm.bin", 2 * sizes["pcapng"], 1 << 22)
        (tmp / "warm.bin").unlink()
        for r in range(args.rounds):
            order = ["pcap", "pcapng"] if r % 2 == 0 else ["pcapng", "pcap"]
            for fmt in order:
                path, raw_path = tmp / f"bench.{fmt}", tmp / "raw.bin"
                timed: dict[str, float] = {}
                for what in ("writer", "raw") if r % 2 == 0 else ("raw", "writer"):
                    if what == "writer":
                        timed[what] = write_with_writer(path, args.cycles, args.block, data, plan)[
                            0
                        ]
                        path.unlink()
                    else:
                        timed[what] = write_raw(raw_path, sizes[fmt], block_bytes[fmt])
                        raw_path.unlink()
                results[fmt].append((timed["writer"], timed["raw"]))
            print(
                f"round {r + 1}/{args.rounds}: "
                + ", ".join(
                    f"{f} {results[f][-1][0]:.3f} s vs raw {results[f][-1][1]:.3f} s" for f in order
                ),
                file=sys.stderr,
            )
    print(
        f"{'format':<8}{'file MB':>9}{'writer s':>10}{'raw s':>8}{'writer MB/s':>13}"
        f"{'raw MB/s':>10}{'ratio':>8}{'best/best':>11}   goal <= {GOAL_RATIO:g}"
    )
    for fmt, rows in results.items():
        size = sizes[fmt]
        writer = statistics.median(r[0] for r in rows)
        raw = statistics.median(r[1] for r in rows)
        ratio = statistics.median(r[0] / r[1] for r in rows)
        best = min(r[0] for r in rows) / min(r[1] for r in rows)
        verdict = "MET" if ratio <= GOAL_RATIO else "NOT MET"
        print(
            f"{fmt:<8}{size / 1e6:>9.0f}{writer:>10.3f}{raw:>8.3f}{size / 1e6 / writer:>13.0f}"
            f"{size / 1e6 / raw:>10.0f}{ratio:>8.2f}{best:>11.2f}   {verdict}"
        )
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak RSS {peak_mb:.0f} MB (the block's data {data.nbytes / 2**20:.0f} MB included)")


if __name__ == "__main__":
    main()
