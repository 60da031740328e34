"""The outcome of an emulation run, and its JSON form (docs/interface.md, ``simulate --json``).

Kept online while the engine runs: a histogram of cycle durations (integer ps), the number of
frames, and the cycles worth listing, so that a result's size does not grow with the run.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from emulator.model.units import PS_PER_NS, PS_PER_US

__all__ = ["CycleDetail", "SimResult"]


@dataclass(frozen=True, slots=True)
class CycleDetail:
    """One cycle as measured at the master's port.

    For EtherCAT ``wkc`` is the sum of the returned working counters; for EPL it is the number
    of PRes the MN received (the EPL analogue), with ``expected_wkc`` the number of CNs polled.
    """

    cycle: int
    start_ps: int
    cycle_ps: int
    wkc: int
    expected_wkc: int

    def to_json(self) -> dict[str, Any]:
        """The ``cycles_detail`` entry."""
        return {
            "cycle": self.cycle,
            "start_ns": self.start_ps // PS_PER_NS,
            "cycle_us": self.cycle_ps / PS_PER_US,
            "wkc": self.wkc,
            "expected_wkc": self.expected_wkc,
        }


@dataclass
class SimResult:
    """Everything ``simulate`` reports.

    ``details`` lists the first steady-state period (one cycle; EPL with ASnd: one per CN) and
    every later cycle whose duration, working counter or expected working counter differs from
    the cycle one period earlier (faults, recovery), at most ``MAX_LISTED`` of them
    (``details_omitted`` counts the rest).
    """

    protocol: str
    topology: str
    nodes: int
    bytes: int
    preset: str
    layout: str
    durations: Counter[int] = field(default_factory=Counter)  # cycle_ps -> cycles
    frames: int = 0
    frames_sent_per_cycle: int = 0  # cycle 0: distinct frames the master sends (its first port)
    wire_bytes_per_cycle: int = 0  # cycle 0: preamble + frame + FCS of every frame at the ports
    wire_bytes_sent_per_cycle: int = 0  # the same for the frames the master sends
    details: list[CycleDetail] = field(default_factory=list)
    details_omitted: int = 0
    pcap: str | None = None
    recovery_us: float | None = None
    diagnosis: list[str] = field(default_factory=list)
    startup_us: float | None = None  # simulate ecat --startup: when its last frame is back
    startup_frames: int = 0  # frames of the start-up at the master's port, sent and returned

    def add_cycles(self, cycle_ps: int, frames: int, times: int) -> None:
        """Count ``times`` cycles of ``cycle_ps`` with ``frames`` frames each."""
        self.durations[cycle_ps] += times
        self.frames += frames * times

    def list_detail(self, detail: CycleDetail, limit: int) -> None:
        """List one cycle (or count it as omitted beyond ``limit``)."""
        if len(self.details) < limit:
            self.details.append(detail)
        else:
            self.details_omitted += 1

    @property
    def cycles(self) -> int:
        """Number of cycles emulated."""
        return sum(self.durations.values())

    @property
    def degraded(self) -> bool:
        """Whether the run lost answers or saw errors, fault or not (e.g. a PRes timeout a CN
        cannot meet): a listed cycle's working counter is not the expected one, or the
        counters gave a diagnosis."""
        return bool(self.diagnosis) or any(d.wkc != d.expected_wkc for d in self.details)

    @property
    def duration_ps(self) -> int:
        """The whole run: the sum of its cycles."""
        return sum(ps * n for ps, n in self.durations.items())

    def cycle_us(self) -> dict[str, float]:
        """min / median / max cycle time in us, measured from the frames' timestamps."""
        values = sorted(self.durations)
        total = self.cycles
        lo_rank, hi_rank = (total - 1) // 2, total // 2  # the median's ranks (numpy's rule)
        lo = hi = None
        seen = 0
        for v in values:
            seen += self.durations[v]
            if lo is None and seen > lo_rank:
                lo = v
            if seen > hi_rank:
                hi = v
                break
        assert lo is not None and hi is not None
        return {
            "min": values[0] / PS_PER_US,
            "median": (lo + hi) / 2 / PS_PER_US,
            "max": values[-1] / PS_PER_US,
        }

    def to_json(self) -> dict[str, Any]:
        """The ``simulate --json`` document."""
        return {
            "protocol": self.protocol,
            "topology": self.topology,
            "nodes": self.nodes,
            "bytes": self.bytes,
            "preset": self.preset,
            "layout": self.layout,
            "cycles": self.cycles,
            "frames": self.frames,
            "cycle_us": self.cycle_us(),
            "cycles_detail": [d.to_json() for d in self.details],
            "cycles_detail_omitted": self.details_omitted,
            "recovery_us": self.recovery_us,
            "diagnosis": list(self.diagnosis),
            "pcap": self.pcap,
        } | (
            {"startup_us": self.startup_us, "startup_frames": self.startup_frames}
            if self.startup_us is not None
            else {}
        )
