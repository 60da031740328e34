"""Timed frames at the master's port, and their pcap: one fixed record layout per cycle.

A :class:`CycleTrace` holds C cycles of R records each. Every cycle has the same frames in the
same order (lengths fixed), so the whole pcap is assembled with a few numpy scatters instead of
one Python call per record. Timestamps are integer picoseconds from the start of the emulation;
the pcap stores them floored to nanoseconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from emulator.errors import ScheduleError
from emulator.records import RecordTrace
from emulator.units import PS_PER_NS
from skinframes.pcap import LINKTYPE_ETHERNET, NS_PER_S, pcap_header

__all__ = ["CycleTrace"]

_RECORD_HEADER_BYTES = 16


@dataclass(frozen=True)
class CycleTrace:
    """C cycles x R records: who sent what, when, at the master's port.

    Attributes:
        times_ps: (C, R) start of each frame (first preamble bit) at the master's port.
        lengths: (R,) frame lengths as captured (no FCS).
        data: (C, sum(lengths)) frame bytes, records concatenated in order.
        wire_ps: (R,) wire time of each frame (preamble, padding, FCS).
        outbound: (R,) True for frames the master sends, False for frames it receives.
        port: (R,) the master's port (1 = the second port of a closed EtherCAT ring); None = 0.
    """

    times_ps: npt.NDArray[np.int64]
    lengths: npt.NDArray[np.int64]
    data: npt.NDArray[np.uint8]
    wire_ps: npt.NDArray[np.int64]
    outbound: npt.NDArray[np.bool_]
    port: npt.NDArray[np.int64] | None = None

    @property
    def cycles(self) -> int:
        """Number of cycles."""
        return int(self.times_ps.shape[0])

    @property
    def frames(self) -> int:
        """Number of frames in the whole trace."""
        return int(self.times_ps.size)

    @property
    def frames_sent_per_cycle(self) -> int:
        """Distinct frames the master sends per cycle (the first port's; the second port of a
        closed ring sends copies of the same frames)."""
        port = np.zeros_like(self.lengths) if self.port is None else self.port
        return int((self.outbound & (port == 0)).sum())

    def frame(self, cycle: int, record: int) -> bytes:
        """The bytes of one record."""
        start = int(self.lengths[:record].sum())
        return bytes(self.data[cycle, start : start + int(self.lengths[record])])

    def check_no_overlap(self, gap_ps: int = 0) -> None:
        """Raise ScheduleError if two frames overlap on one direction of the master's link.

        Args:
            gap_ps: the least idle time required between two frames of one direction.
        """
        port = np.zeros_like(self.lengths) if self.port is None else self.port
        for direction, p in ((d, p) for d in (True, False) for p in np.unique(port)):
            cols = np.flatnonzero((self.outbound == direction) & (port == p))
            if len(cols) == 0:
                continue
            start = self.times_ps[:, cols].ravel()
            end = start + np.tile(self.wire_ps[cols], self.cycles)
            if np.any(start[1:] < end[:-1] + gap_ps):
                i = int(np.argmax(start[1:] < end[:-1] + gap_ps))
                raise ScheduleError(
                    f"frames {i} and {i + 1} of the {'outbound' if direction else 'inbound'} "
                    f"direction overlap or leave less than {gap_ps} ps between them"
                )

    def pcap_bytes(self) -> bytes:
        """The trace as a nanosecond pcap (LINKTYPE_ETHERNET), byte-deterministic."""
        return pcap_header(LINKTYPE_ETHERNET) + self._records_image().tobytes()

    def _records_image(self) -> npt.NDArray[np.uint8]:
        """(C, bytes per cycle): every record of a cycle, header and frame, as the pcap holds it."""
        c, r = self.times_ps.shape
        lengths = self.lengths.astype(np.int64)
        rec_sizes = lengths + _RECORD_HEADER_BYTES
        hdr_off = np.concatenate(([0], np.cumsum(rec_sizes)[:-1]))
        image = int(rec_sizes.sum())
        ns = self.times_ps // PS_PER_NS
        if np.any(ns < 0) or np.any(ns // NS_PER_S > 0xFFFFFFFF):
            raise ScheduleError("timestamps outside the pcap range")
        head = np.empty((c, r, 4), dtype="<u4")
        head[:, :, 0] = ns // NS_PER_S
        head[:, :, 1] = ns % NS_PER_S
        head[:, :, 2] = lengths
        head[:, :, 3] = lengths
        out = np.empty((c, image), dtype=np.uint8)
        head_bytes = head.view(np.uint8).reshape(c, r, _RECORD_HEADER_BYTES)
        src = 0
        for k, (off, n) in enumerate(zip(hdr_off.tolist(), lengths.tolist(), strict=True)):
            out[:, off : off + _RECORD_HEADER_BYTES] = head_bytes[:, k]
            out[:, off + _RECORD_HEADER_BYTES : off + _RECORD_HEADER_BYTES + n] = self.data[
                :, src : src + n
            ]
            src += n
        return out

    def to_records(self) -> RecordTrace:
        """The same frames as a :class:`~emulator.records.RecordTrace`."""
        out = RecordTrace()
        port = np.zeros_like(self.lengths) if self.port is None else self.port
        for c in range(self.cycles):
            for r in range(len(self.lengths)):
                out.add(
                    int(self.times_ps[c, r]),
                    self.frame(c, r),
                    int(self.wire_ps[r]),
                    bool(self.outbound[r]),
                    int(port[r]),
                )
        return out

    def write_pcap(self, path: str | Path) -> None:
        """Write :meth:`pcap_bytes` to ``path``; a pcapng (with direction flags) for .pcapng."""
        if Path(path).suffix.lower() == ".pcapng":
            self.to_records().write_pcap(path)
            return
        image = self._records_image()
        with open(path, "wb") as f:  # header, then the image without another copy
            f.write(pcap_header(LINKTYPE_ETHERNET))
            f.write(image.data)
