"""Stalls this machine charges to a thread as CPU time: what serve's CPU per frame cannot tell
from its own work (issue 11 bounds serve's CPU per frame).

A busy loop on one CPU reads the wall clock (``time.monotonic_ns``) and its thread's CPU clock
(``time.thread_time_ns``, what ``serve`` measures a frame with) over and over; a step takes well
under a microsecond. A step longer than ``--min-us`` is a stall:

- **charged**: the thread's CPU clock went on with the wall clock (by 90 % or more), although the
  loop did not run: time a virtual machine's hypervisor took that the guest's kernel did not
  count as steal, or interrupts handled in the thread's stead. A frame that meets such a stall
  counts it as CPU;
- **descheduled**: the CPU clock stood still: the guest's kernel ran something else, or counted
  the time as steal (serve's CPU per frame does not count that).

Then, for as long again, a fixed piece of Python work (:func:`unit`: ints, tuples and a dict,
about what the emulator does between two numpy calls) runs over and over, each time measured
with the thread's CPU clock. Without stalls, slower memory or a busier core, it would take the
same time each time: how often it takes several times its median is how often the machine,
not the work, decides a frame's CPU time. (On this VM a profiled LRD 4.5 times its median CPU
ran every function slower alike, ``list.append`` at 1.7 us a call: no code path of its own.)

Printed: the seconds, the charged stalls (count, total, the largest, how many above 1 ms and
above serve's budget of 2 ms), the descheduled ones, and the CPU's steal time over the same
seconds from ``/proc/stat`` (in its ticks of 10 ms); the fixed work's median, 99.9th
percentile and largest CPU time, and how many times it took 4 times its median or more.

    python benchmarks/bench_stalls.py [--seconds 60] [--cpu N] [--min-us 200]

``--seconds`` is each part's.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from emulator.live import CPU_BUDGET_US as BUDGET_US  # serve's CPU budget per frame

CHARGED = 0.9  # a stall whose CPU time is this share of its wall time or more was charged
SLOW = 4  # fixed work that took this many times its median or more


def steal_ticks(cpu: int) -> int:
    """The steal time of ``cpu`` so far (``/proc/stat``, the 8th value of its line), in ticks."""
    with open("/proc/stat") as stat:
        for line in stat:
            if line.startswith(f"cpu{cpu} "):
                return int(line.split()[8])
    return 0


def stalls(seconds: float, min_us: float) -> list[tuple[int, int]]:
    """The busy loop: every step longer than ``min_us`` as (wall ns, this thread's CPU ns)."""
    wall, cpu = time.monotonic_ns, time.thread_time_ns
    end = wall() + int(seconds * 1e9)
    least = int(min_us * 1000)
    found: list[tuple[int, int]] = []
    last, last_cpu = wall(), cpu()
    while last < end:
        now, now_cpu = wall(), cpu()
        if now - last > least:
            found.append((now - last, now_cpu - last_cpu))
        last, last_cpu = now, now_cpu
    return found


def unit() -> int:
    """The fixed piece of work: 300 tuples made into a dict of 64 and dropped."""
    table: dict[int, tuple[int, int, int]] = {}
    for i in range(300):
        table[i & 63] = (i, i * 3, i ^ 0x55)
    return len(table)


def fixed_work(seconds: float) -> list[int]:
    """:func:`unit` over and over for ``seconds``: each one's CPU time (ns, this thread)."""
    wall, cpu = time.monotonic_ns, time.thread_time_ns
    end = wall() + int(seconds * 1e9)
    times: list[int] = []
    while wall() < end:
        c0 = cpu()
        unit()
        times.append(cpu() - c0)
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument(
        "--cpu",
        type=int,
        default=max(os.sched_getaffinity(0)),
        help="the CPU the loop runs on (default: the highest this process may use)",
    )
    ap.add_argument("--min-us", type=float, default=200.0, help="a longer step is a stall")
    args = ap.parse_args()
    if not 0 < args.seconds < 86400 or not 0 <= args.min_us < 1e6:
        ap.error("--seconds: more than 0, under a day; --min-us: 0 to 1e6")
    if args.cpu not in os.sched_getaffinity(0):
        ap.error(f"--cpu {args.cpu}: not among the CPUs this process may use")
    os.sched_setaffinity(0, {args.cpu})
    steal_before = steal_ticks(args.cpu)
    found = stalls(args.seconds, args.min_us)
    steal = steal_ticks(args.cpu) - steal_before
    charged = sorted(c / 1000 for w, c in found if c >= CHARGED * w)
    over_1ms = sum(us > 1000 for us in charged)
    over_budget = sum(us > BUDGET_US for us in charged)
    print(f"{args.seconds:g} s busy on CPU {args.cpu}, steps over {args.min_us:.0f} us:")
    print(
        f"  charged as this thread's CPU: {len(charged)}, {sum(charged) / 1000:.1f} ms in all, "
        f"the largest {charged[-1] if charged else 0:.0f} us; {over_1ms} above 1 ms, "
        f"{over_budget} above {BUDGET_US:.0f} us"
    )
    print(f"  descheduled (CPU clock still): {len(found) - len(charged)}")
    print(f"  steal time of CPU {args.cpu} meanwhile (/proc/stat): {steal * 10} ms")
    times = sorted(fixed_work(args.seconds))
    median = times[len(times) // 2]
    slow = sum(t >= SLOW * median for t in times)
    print(
        f"fixed work, {len(times)} times in {args.seconds:g} s: median {median / 1000:.0f} us, "
        f"p99.9 {times[int(len(times) * 0.999)] / 1000:.0f} us, the largest "
        f"{times[-1] / 1000:.0f} us; {slow} took {SLOW}x the median or more"
    )


if __name__ == "__main__":
    main()
