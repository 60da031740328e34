"""A trace of individual records (any layout), for runs whose cycles differ: faults, marks.

Same role as :class:`emulator.trace.CycleTrace`, without the fixed per-cycle layout: each record
has its time, port, direction and bytes, and optionally a mark (a deliberately corrupted frame).
Marked traces are written as pcapng, where the mark is the packet comment and the CRC-error bit of
the packet flags; the direction goes into the flags too.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from emulator.errors import ScheduleError
from emulator.units import PS_PER_NS
from skinframes.pcap import (
    EPB_CRC_ERROR,
    EPB_INBOUND,
    EPB_OUTBOUND,
    MarkedRecord,
    pcap_bytes,
    pcapng_bytes,
)

__all__ = ["RecordTrace"]


@dataclass
class RecordTrace:
    """Records at the master's port(s), in time order.

    Attributes:
        times_ps: start of each frame (first preamble bit) at the master's port.
        data: the frames' bytes.
        wire_ps: wire time of each frame.
        outbound: True for frames the master sends.
        port: the master's port (0, or 1 for the second port of a closed EtherCAT ring).
        marks: a text for each deliberately corrupted frame (None for the others).
    """

    times_ps: list[int] = field(default_factory=list)
    data: list[bytes] = field(default_factory=list)
    wire_ps: list[int] = field(default_factory=list)
    outbound: list[bool] = field(default_factory=list)
    port: list[int] = field(default_factory=list)
    marks: list[str | None] = field(default_factory=list)

    def add(
        self,
        t_ps: int,
        frame: bytes,
        wire_ps: int,
        outbound: bool,
        port: int = 0,
        mark: str | None = None,
    ) -> None:
        """Append one record."""
        self.times_ps.append(t_ps)
        self.data.append(frame)
        self.wire_ps.append(wire_ps)
        self.outbound.append(outbound)
        self.port.append(port)
        self.marks.append(mark)

    def sorted(self) -> RecordTrace:
        """The same records in time order (ties: port, sent before received, then as added)."""
        order = sorted(
            range(len(self.times_ps)),
            key=lambda i: (self.times_ps[i], self.port[i], not self.outbound[i], i),
        )
        out = RecordTrace()
        for i in order:
            out.add(
                self.times_ps[i],
                self.data[i],
                self.wire_ps[i],
                self.outbound[i],
                self.port[i],
                self.marks[i],
            )
        return out

    @property
    def frames(self) -> int:
        """Number of records."""
        return len(self.data)

    @property
    def marked(self) -> int:
        """Number of deliberately corrupted records."""
        return sum(m is not None for m in self.marks)

    def check_no_overlap(self, gap_ps: int = 0) -> None:
        """Raise ScheduleError if two frames overlap on one direction of one port."""
        t = np.asarray(self.times_ps, dtype=np.int64)
        w = np.asarray(self.wire_ps, dtype=np.int64)
        key = np.asarray(self.port) * 2 + np.asarray(self.outbound, dtype=np.int64)
        for k in np.unique(key):
            idx = np.flatnonzero(key == k)
            idx = idx[np.argsort(t[idx], kind="stable")]
            start, end = t[idx], t[idx] + w[idx]
            bad = np.flatnonzero(start[1:] < end[:-1] + gap_ps)
            if len(bad):
                raise ScheduleError(
                    f"records {idx[bad[0]]} and {idx[bad[0] + 1]} overlap on "
                    f"port {k // 2} {'out' if k % 2 else 'in'}bound"
                )

    def times_ns(self) -> npt.NDArray[np.int64]:
        """Record times floored to ns, as the capture stores them."""
        return np.asarray(self.times_ps, dtype=np.int64) // PS_PER_NS

    def pcapng_bytes(self) -> bytes:
        """The trace as pcapng: direction flags on every record, marks as CRC error + comment."""
        recs = []
        for t, frame, out, mark in zip(
            self.times_ns().tolist(), self.data, self.outbound, self.marks, strict=True
        ):
            flags = EPB_OUTBOUND if out else EPB_INBOUND
            if mark is not None:
                flags |= EPB_CRC_ERROR
            recs.append(MarkedRecord(t, frame, flags, mark))
        return pcapng_bytes(recs)

    def write_pcap(self, path: str | Path) -> None:
        """Write a pcap, or a pcapng when ``path`` ends in .pcapng.

        Raises:
            ScheduleError: the trace has marked frames and ``path`` is a classic pcap, which
                cannot carry the marks.
        """
        path = Path(path)
        if path.suffix.lower() == ".pcapng":
            path.write_bytes(self.pcapng_bytes())
            return
        if self.marked:
            raise ScheduleError(
                f"{path}: {self.marked} corrupted frames can be marked only in a "
                ".pcapng file (packet comment and CRC-error flag); name it .pcapng"
            )
        path.write_bytes(pcap_bytes(zip(self.times_ns().tolist(), self.data, strict=True)))
