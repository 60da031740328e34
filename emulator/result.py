"""The outcome of an emulation run, and its JSON form (INTERFACE.md, ``simulate --json``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.records import RecordTrace
from emulator.trace import CycleTrace
from emulator.units import PS_PER_NS, PS_PER_US
from skinframes import taxel

__all__ = ["CycleDetail", "SimResult", "node_payloads"]


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
        """The INTERFACE.md ``cycles_detail`` entry."""
        return {
            "cycle": self.cycle,
            "start_ns": self.start_ps // PS_PER_NS,
            "cycle_us": self.cycle_ps / PS_PER_US,
            "wkc": self.wkc,
            "expected_wkc": self.expected_wkc,
        }


@dataclass
class SimResult:
    """Everything ``simulate`` reports."""

    protocol: str
    topology: str
    nodes: int
    bytes: int
    preset: str
    layout: str
    details: list[CycleDetail]
    trace: CycleTrace | RecordTrace
    pcap: str | None = None
    recovery_us: float | None = None
    diagnosis: list[str] = field(default_factory=list)

    @property
    def cycles(self) -> int:
        """Number of cycles emulated."""
        return len(self.details)

    @property
    def frames(self) -> int:
        """Frames at the master's port, both directions."""
        return self.trace.frames

    def cycle_us(self) -> dict[str, float]:
        """min / median / max cycle time in us, measured from the frames' timestamps."""
        values = np.array([d.cycle_ps for d in self.details], dtype=np.float64) / PS_PER_US
        return {
            "min": float(values.min()),
            "median": float(np.median(values)),
            "max": float(values.max()),
        }

    def to_json(self) -> dict[str, Any]:
        """The INTERFACE.md ``simulate --json`` document."""
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
            "recovery_us": self.recovery_us,
            "diagnosis": list(self.diagnosis),
            "pcap": self.pcap,
        }


def node_payloads(
    payloads: npt.NDArray[np.uint8] | None, cycles: int, nodes: int, data_bytes: int, seed: int
) -> npt.NDArray[np.uint8]:
    """The (cycles, nodes, data_bytes) taxel bytes a run carries: given, or seeded patterns.

    Given payloads (e.g. the samples of a CAN trace) must have exactly that shape and dtype uint8.
    """
    if payloads is None:
        return taxel.sample_payloads(nodes, cycles, data_bytes, seed=seed)
    arr = np.asarray(payloads)
    if arr.dtype != np.uint8 or arr.shape != (cycles, nodes, data_bytes):
        raise TopologyError(
            f"payloads: {arr.dtype} {arr.shape}, expected uint8 {(cycles, nodes, data_bytes)}"
        )
    return np.ascontiguousarray(arr)
