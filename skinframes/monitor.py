"""What ``skinframes watch`` shows: a network's state as its frames come, over a sliding window.

:class:`Monitor` is fed one :class:`~skinframes.pcap.Record` at a time (a live capture or a
file) and hands it to the analysis of ``analyze`` (:class:`skinframes.analysis.CaptureAnalyzer`
with a window: the last :data:`WINDOW` values of each series, memory that does not grow with the
traffic). Its figures are therefore ``analyze``'s, pairing and rules alike:

- EPL: the SoC period; per CN the PReq -> PRes response time, the PReqs it was sent and those it
  did not answer (*missing*), its NMT state now (the last one seen).
- EtherCAT: per cyclic pattern (frames carrying a logical command: the process data) and master
  port the period between frames sent, the round trip, frames sent and never returned
  (*unanswered*), each datagram's expected (steady) working counter and the deviations from it,
  and the AL state each target reported last.

Counts (polled, missing, sent, returned, lost, deviations) cover every frame fed, statistics
(median, jitter, min, max) the window. The monitor's own part is the taxel view: per patch the
number of its 16 triangles in contact (a taxel below :data:`skinframes.taxel.CONTACT_THRESHOLD`)
in its latest sample (EPL: the PRes payload of node id patch + 1; EtherCAT: 192 bytes a patch of
the returned LRD/LRW data, from the lowest logical address seen).

:meth:`Monitor.snapshot` returns the figures as plain data (microseconds), which the command
prints as a table on a terminal or as lines in a pipe.
"""

from __future__ import annotations

from typing import Any, Final

from skinframes import ethercat, ethernet, powerlink, taxel
from skinframes.analysis import CaptureAnalyzer, Summary, plain_frame
from skinframes.analysis.ecat import walk
from skinframes.ethercat import Command
from skinframes.pcap import LINKTYPE_ETHERNET, Record, Skipped
from skinframes.powerlink.enums import MessageType
from skinframes.powerlink.schemas import PDO_HEADER_BYTES, PDO_SIZE_OFFSET, SRC_OFFSET

__all__ = ["WINDOW", "Monitor", "contact_triangles"]

WINDOW: Final = 2000  # values kept per series (periods, response times, round trips)
_NS_PER_US: Final = 1000
_TAXEL_READS: Final = frozenset({int(Command.LRD), int(Command.LRW)})
_PRES: Final = int(MessageType.PRES)
_MTYPE_MASK: Final = 0x7F
_TRIANGLE_BYTES: Final = taxel.TAXELS_PER_TRIANGLE
_PATCH_BYTES: Final = taxel.TRIANGLES_PER_PATCH * taxel.TAXELS_PER_TRIANGLE


def contact_triangles(payload: bytes) -> int | None:
    """Triangles of a patch sample in contact (a taxel below the threshold), None when the
    payload is shorter than a patch."""
    if len(payload) < _PATCH_BYTES:
        return None
    low = taxel.CONTACT_THRESHOLD
    return sum(
        1
        for t in range(taxel.TRIANGLES_PER_PATCH)
        if min(payload[t * _TRIANGLE_BYTES : (t + 1) * _TRIANGLE_BYTES]) < low
    )


def summary_us(s: Summary) -> dict[str, float] | None:
    """median, min, max and jitter (the population standard deviation) in microseconds of an
    analysis :class:`~skinframes.analysis.Summary`, or None when it has no values."""
    if s.median_ns is None or s.min_ns is None or s.max_ns is None or s.std_ns is None:
        return None  # no values
    return {
        "median_us": s.median_ns / _NS_PER_US,
        "min_us": s.min_ns / _NS_PER_US,
        "max_us": s.max_ns / _NS_PER_US,
        "jitter_us": s.std_ns / _NS_PER_US,
    }


class Monitor:
    """The figures of :mod:`skinframes.monitor`, updated frame by frame."""

    def __init__(self, window: int = WINDOW) -> None:
        self.analyzer = CaptureAnalyzer(window=window)
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self.contact: dict[int, int] = {}  # patch (from 0) -> triangles in contact
        self._lad_base: int | None = None
        self.skipped: tuple[Skipped, ...] = ()  # the capture's, once read (its ``skipped``)

    # --- feeding ----------------------------------------------------------------------------
    def feed(self, rec: Record) -> None:
        """One captured frame."""
        if self.first_ns is None:
            self.first_ns = rec.time_ns
        self.last_ns = rec.time_ns
        self.analyzer.feed(rec)
        if rec.linktype == LINKTYPE_ETHERNET and len(rec.data) >= ethernet.HEADER_BYTES:
            self._taxels(rec.data)

    def _taxels(self, data: bytes) -> None:
        data = plain_frame(data)  # as the analysis reads it: no VLAN tags, no UDP/IPv4
        at = ethernet.HEADER_BYTES
        ethertype = int.from_bytes(data[at - 2 : at], "big")
        if ethertype == ethernet.ETHERTYPE_EPL:
            epl = data[at:]
            if len(epl) < PDO_HEADER_BYTES or epl[0] & _MTYPE_MASK != _PRES:
                return
            node = epl[SRC_OFFSET]
            if not 1 <= node < powerlink.MN_NODE_ID:
                return
            size = epl[PDO_SIZE_OFFSET] | epl[PDO_SIZE_OFFSET + 1] << 8
            contact = contact_triangles(epl[PDO_HEADER_BYTES : PDO_HEADER_BYTES + size])
            if contact is not None:
                self.contact[node - 1] = contact  # patch = node id - 1, as the Lua plugin
        elif ethertype == ethernet.ETHERTYPE_ECAT and data[6] & ethercat.RETURNED_MAC_BIT:
            for cmd, _, adp, ado, n, start, wkc in walk(data, at):
                if cmd in _TAXEL_READS and wkc:
                    self._image(adp | ado << 16, data[start : start + n])

    def _image(self, lad: int, data: bytes) -> None:
        """The whole patches in returned logical data at address ``lad``."""
        if self._lad_base is None or lad < self._lad_base:
            self._lad_base = lad
        first = -(-(lad - self._lad_base) // _PATCH_BYTES)  # the first whole patch
        at = first * _PATCH_BYTES - (lad - self._lad_base)
        while at + _PATCH_BYTES <= len(data):
            contact = contact_triangles(data[at : at + _PATCH_BYTES])
            if contact is not None:
                self.contact[first] = contact
            first += 1
            at += _PATCH_BYTES

    # --- reading ----------------------------------------------------------------------------
    @property
    def span_s(self) -> float:
        """Seconds from the first frame to the last (0 before two)."""
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        return (self.last_ns - self.first_ns) / 1e9

    def snapshot(self) -> dict[str, Any]:
        """The figures as plain data (times in microseconds)."""
        a = self.analyzer.result()
        doc: dict[str, Any] = {
            "frames": a.records,
            "other": a.counts["other"],
            "span_s": self.span_s,
            "skipped": len(self.skipped),
        }
        if a.epl is not None:
            e = a.epl
            doc["epl"] = {
                "frames": a.counts["epl"],
                "soc_period": summary_us(e.soc_period),
                "cycles": e.message_counts.get("SOC", 0),
                "cns": [
                    {
                        "node": n,
                        "polled": e.polled.get(n, 0),
                        "missing": e.missing_count.get(n, 0),
                        "state": e.current_states.get(n),
                        "response": summary_us(e.responses[n]),
                    }
                    for n in sorted(e.responses)
                ],
            }
        if a.ecat is not None:
            cyclic = sorted((p for p in a.ecat.patterns if p.cyclic), key=lambda p: -p.frames)
            doc["ecat"] = {
                "frames": a.counts["ecat"],
                "patterns": [
                    {
                        "datagrams": p.text,
                        "port": p.port,
                        "sent": p.frames,
                        "returned": p.returned,
                        "lost": p.unanswered_count,
                        "period": summary_us(p.period),
                        "round_trip": summary_us(p.round_trip),
                        "wkc": list(p.expected_wkc),
                        "wkc_deviations": p.wkc_deviation_count,
                    }
                    for p in cyclic
                ],
                "al_states": a.ecat.al_current,
            }
        doc["contact"] = dict(sorted(self.contact.items()))
        return doc
