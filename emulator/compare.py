"""The same taxels on the legacy CAN bus, on EPL and on EtherCAT, side by side.

A skin CAN trace gives boards, triangles, samples and their period. Per sample:

* CAN as recorded: the exact wire time of the sample's frames (``skinframes.canwire``: stuff bits
  and intermission included) on the 1 Mbit/s bus, back to back;
* CAN re-emulated: every board queues its frames at the start of the period and the bus
  arbitrates them (:mod:`emulator.net.can_bus`); the time until the last frame is through;
* EPL and EtherCAT: the emulated cycle that carries the same samples, one node per board.

``bus_load`` is the share of the sample period the bus is busy moving the skin's data;
``wire_bytes_per_sample`` counts what travels on the wire (CAN: bits / 8; Ethernet: preamble,
padded frame and FCS of every frame the master's port sends or receives once, IFG excluded).
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.model.limits import MAX_EMULATED_SLAVES
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_NS, PS_PER_US
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.can_bus import BusFrame, arbitrate, bit_time_ps
from emulator.net.result import SimResult
from skinframes import canbus, powerlink, taxel
from skinframes.canbus.log import CanLog

__all__ = ["SkinSamples", "compare", "samples_of"]

DEFAULT_PERIOD_PS: Final = canbus.DEFAULT_PERIOD_MS * 1_000_000_000
BUDGETS_US: Final = (1_000, 5_000)  # the reactive loops the comparison asks about
MAX_EMULATED_SAMPLES: Final = 20  # cycles emulated per Ethernet bus (the cycle repeats exactly)


@dataclass(frozen=True)
class SkinSamples:
    """The skin samples of a trace, one row per board, in board order.

    Attributes:
        boards: board addresses, ascending (EPL CN i+1 / EtherCAT slave i carries boards[i]).
        triangles: triangles per board (the most any board sent; missing ones read no-load).
        taxels: (samples, boards, 12 * triangles) uint8, in time order.
        start_ns: (samples,) time of each sample's first frame.
        frames: per sample, the skin frames that carried it.
        period_ps: the sample period (median spacing of the samples; 50 ms with one sample).
    """

    boards: tuple[int, ...]
    triangles: int
    taxels: npt.NDArray[np.uint8]
    start_ns: npt.NDArray[np.int64]
    frames: tuple[tuple[canbus.CanFrame, ...], ...]
    period_ps: int

    @property
    def samples(self) -> int:
        """Complete samples (every board and triangle present)."""
        return int(self.taxels.shape[0])

    @property
    def data_bytes(self) -> int:
        """Taxel bytes per board and sample."""
        return int(self.taxels.shape[2])


def samples_of(trace: CanLog) -> SkinSamples:
    """Group a trace's reassembled samples: the k-th sample of every (board, triangle) is sample k.

    Raises:
        TopologyError: the trace holds no skin sample.
    """
    per_key: dict[tuple[int, int], list[canbus.TimedSample]] = defaultdict(list)
    for s in trace.samples:
        per_key[(s.sample.board, s.sample.triangle)].append(s)
    if not per_key:
        raise TopologyError(f"{trace.path}: no skin samples (class 4 head/tail pairs) in the trace")
    boards = tuple(sorted({b for b, _ in per_key}))
    triangles = max(t for _, t in per_key) + 1
    count = min(len(v) for v in per_key.values())
    taxels = np.full((count, len(boards), triangles, 12), taxel.NO_LOAD, dtype=np.uint8)
    frames: list[list[canbus.CanFrame]] = [[] for _ in range(count)]
    start = np.full(count, np.iinfo(np.int64).max, dtype=np.int64)
    for (board, tri), items in per_key.items():
        for k, ts in enumerate(items[:count]):
            taxels[k, boards.index(board), tri] = ts.sample.taxels
            frames[k].extend(ts.can_frames())
            start[k] = min(start[k], ts.time_ns)
    period = int(np.median(np.diff(start))) * PS_PER_NS if count > 1 else DEFAULT_PERIOD_PS
    if period <= 0:
        period = DEFAULT_PERIOD_PS
    ordered = tuple(tuple(sorted(f, key=lambda fr: fr.time_ns)) for f in frames)
    return SkinSamples(
        boards, triangles, taxels.reshape(count, len(boards), -1), start, ordered, period
    )


def _ethernet_wire_bytes(r: SimResult, outbound_only: bool) -> int:
    return r.wire_bytes_sent_per_cycle if outbound_only else r.wire_bytes_per_cycle


def _largest(fits: Any, hi: int) -> int:
    """Largest n in 0..hi with fits(n) (fits is monotone: true up to some n)."""
    lo = 0
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if fits(mid):
            lo = mid
        else:
            hi = mid - 1
    return lo


def compare(s: SkinSamples, params: TimingParams) -> dict[str, Any]:
    """The comparison document (``skinframes compare --json``)."""
    bit = bit_time_ps(canbus.BITRATE_BPS)
    period_us = s.period_ps / PS_PER_US
    recorded = [sum(f.bits() for f in frames) * bit for frames in s.frames]
    can_cycle = float(np.median(recorded)) / PS_PER_US

    # re-emulated: every board queues its sample's frames at the period start, in the order sent
    bus = [
        BusFrame(k * s.period_ps, f.arbitration_id >> 4 & 0xF, f.arbitration_id, f.bits())
        for k, frames in enumerate(s.frames)
        for f in frames
    ]
    sched = arbitrate(bus, canbus.BITRATE_BPS)
    k_of = np.array([b.release_ps // s.period_ps for b in bus], dtype=np.int64)
    emulated = [int(sched.end_ps[k_of == k].max()) - k * s.period_ps for k in range(s.samples)]
    node_of = np.array([b.node for b in bus], dtype=np.int64)
    latency = {  # per board: from the period start until its last frame of the sample is through
        str(board): float(
            np.median(
                [
                    int(sched.end_ps[(k_of == k) & (node_of == board)].max()) - k * s.period_ps
                    for k in range(s.samples)
                ]
            )
        )
        / PS_PER_US
        for board in s.boards
    }
    horizon = s.samples * s.period_ps
    mean_bits = float(np.mean([f.bits() for frames in s.frames for f in frames]))
    per_board_us = canbus.FRAMES_PER_BOARD * mean_bits * bit / PS_PER_US  # a full 16-triangle patch

    cycles = min(s.samples, MAX_EMULATED_SAMPLES)
    load = s.taxels[:cycles]
    n, size = len(s.boards), s.data_bytes
    epl = simulate_epl(n, size, params, cycles=cycles, payloads=load)
    ecat = simulate_ecat(n, size, params, cycles=cycles, payloads=load)

    def epl_fits(budget: float) -> Any:
        return lambda k: (
            simulate_epl(k, taxel.PATCH_BYTES, params, cycles=1).cycle_us()["max"] <= budget
        )

    def ecat_fits(budget: float) -> Any:
        return lambda k: (
            simulate_ecat(k, taxel.PATCH_BYTES, params, cycles=1).cycle_us()["max"] <= budget
        )

    doc: dict[str, Any] = {
        "boards": list(s.boards),
        "triangles": s.triangles,
        "samples": s.samples,
        "period_us": period_us,
        "bytes_per_board": size,
        "preset": params.name,
        "can": {
            "cycle_us": can_cycle,
            "bus_load": can_cycle / period_us,
            "wire_bytes_per_sample": float(
                np.median([sum(f.bits() for f in fr) for fr in s.frames])
            )
            / 8,
            "max_patches_1ms": int(BUDGETS_US[0] // per_board_us),
            "max_patches_5ms": int(BUDGETS_US[1] // per_board_us),
            "emulated": {
                "cycle_us": float(np.median(emulated)) / PS_PER_US,
                "bus_load": sched.load(0, horizon),
                "latency_us": latency,
            },
        },
    }
    for name, r, fits, hi, outbound_only in (
        ("epl", epl, epl_fits, powerlink.MAX_CN_NODE_ID, False),
        ("ecat", ecat, ecat_fits, MAX_EMULATED_SLAVES, True),
    ):
        cycle = r.cycle_us()["median"]
        doc[name] = {
            "cycle_us": cycle,
            "bus_load": cycle / period_us,
            "wire_bytes_per_sample": _ethernet_wire_bytes(r, outbound_only),
            "max_patches_1ms": _largest(fits(BUDGETS_US[0]), hi),
            "max_patches_5ms": _largest(fits(BUDGETS_US[1]), hi),
        }
    return doc
