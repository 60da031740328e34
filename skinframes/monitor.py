"""What ``skinframes watch`` shows: a network's state as its frames come, over a sliding window.

:class:`Monitor` is fed one :class:`~skinframes.pcap.Record` at a time (a live capture or a
file) and keeps, in memory that does not grow with the traffic (each series the last
:data:`WINDOW` values):

- EPL: the SoC period; per CN the PReq -> PRes response time, the PReqs it was sent and those it
  did not answer (another PReq, SoA or SoC came first: the MN's next frame, as ``analyze``
  counts *missing*), its NMT state (from its PRes) and its taxels (the PRes payload).
- EtherCAT: per cyclic pattern (frames carrying a logical command: the process data; a pattern
  as ``analyze`` defines it) and master port the period between frames sent, the round trip,
  frames sent and never returned (another of the same pattern was sent first), each datagram's
  working counter against its most frequent value (deviations counted), AL states read from AL
  status (0x0130) per station, and the taxels of the returned logical data, 192 bytes per
  patch from the lowest logical address seen.
- Taxels: per patch the number of its 16 triangles in contact (a taxel below
  :data:`skinframes.taxel.CONTACT_THRESHOLD`) in its latest sample.

:meth:`Monitor.snapshot` returns the figures as plain data (microseconds), which the command
prints as a table on a terminal or as lines in a pipe.
"""

from __future__ import annotations

import statistics
from collections import Counter, deque
from dataclasses import dataclass, field
from typing import Any, Final

from skinframes import encap, ethercat, powerlink, taxel
from skinframes.analysis.ecat import AL_STATUS, al_state_name
from skinframes.dispatch import decode_frame
from skinframes.errors import DecodeError
from skinframes.ethercat import Command, EcatFrame
from skinframes.pcap import LINKTYPE_ETHERNET, Record
from skinframes.powerlink.enums import NmtState

__all__ = ["WINDOW", "Monitor", "Rolling"]

WINDOW: Final = 2000  # values kept per series (periods, response times, round trips)
STEADY_AFTER: Final = 8  # returned frames of a datagram before its usual WKC is trusted
_NS_PER_US: Final = 1000
_LOGICAL: Final = frozenset(int(c) for c in ethercat.LOGICAL_COMMANDS)
_AL_READS: Final = frozenset(int(c) for c in (Command.APRD, Command.FPRD, Command.BRD))
_TRIANGLE_BYTES: Final = taxel.TAXELS_PER_TRIANGLE
_PATCH_BYTES: Final = taxel.TRIANGLES_PER_PATCH * taxel.TAXELS_PER_TRIANGLE


@dataclass
class Rolling:
    """The last :data:`WINDOW` values of a series (nanoseconds)."""

    values: deque[int] = field(default_factory=lambda: deque(maxlen=WINDOW))
    count: int = 0  # every value ever added

    def add(self, value: int) -> None:
        """One more value."""
        self.values.append(value)
        self.count += 1

    def summary_us(self) -> dict[str, float] | None:
        """median, min, max and jitter (standard deviation) in microseconds, or None."""
        if not self.values:
            return None
        v = self.values
        return {
            "median_us": statistics.median(v) / _NS_PER_US,
            "min_us": min(v) / _NS_PER_US,
            "max_us": max(v) / _NS_PER_US,
            "jitter_us": (statistics.pstdev(v) if len(v) > 1 else 0.0) / _NS_PER_US,
        }


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


def _name(cmd: int) -> str:
    try:
        return Command(cmd).name
    except ValueError:
        return f"{cmd:#04x}"


@dataclass
class _Cn:
    polled: int = 0
    missing: int = 0
    response: Rolling = field(default_factory=Rolling)
    state: str | None = None


@dataclass
class _Pattern:
    text: str
    port: str
    sent: int = 0
    returned: int = 0
    lost: int = 0
    last_sent_ns: int | None = None
    pending: int | None = None  # time of the frame sent and not yet returned
    period: Rolling = field(default_factory=Rolling)
    round_trip: Rolling = field(default_factory=Rolling)
    wkc: list[Counter[int]] = field(default_factory=list)
    deviations: int = 0


class Monitor:
    """The figures of :mod:`skinframes.monitor`, updated frame by frame."""

    def __init__(self) -> None:
        self.frames = 0
        self.other = 0
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self.soc_period = Rolling()
        self._last_soc: int | None = None
        self._epl_frames = 0
        self.cns: dict[int, _Cn] = {}
        self._pending: tuple[int, int] | None = None  # (CN, PReq time)
        self._ecat_frames = 0
        self.patterns: dict[tuple[Any, ...], _Pattern] = {}
        self.al_states: dict[str, str] = {}
        self.contact: dict[int, int] = {}  # patch (from 0) -> triangles in contact
        self._lad_base: int | None = None

    # --- feeding ----------------------------------------------------------------------------
    def feed(self, rec: Record) -> None:
        """One captured frame."""
        self.frames += 1
        if self.first_ns is None:
            self.first_ns = rec.time_ns
        self.last_ns = rec.time_ns
        if rec.linktype != LINKTYPE_ETHERNET:
            self.other += 1
            return
        try:
            frame = decode_frame(rec.data)
        except DecodeError:
            self.other += 1
            return
        message = encap.message_of(frame)
        if isinstance(message, EcatFrame):
            self._ecat(rec.time_ns, frame.src, message)
        elif isinstance(message, bytes | bytearray):
            self.other += 1
        else:
            self._epl(rec.time_ns, message)

    def _epl(self, t: int, m: Any) -> None:
        self._epl_frames += 1
        if isinstance(m, powerlink.SoC):
            if self._last_soc is not None:
                self.soc_period.add(t - self._last_soc)
            self._last_soc = t
            self._miss()
        elif isinstance(m, powerlink.PReq):
            self._miss()
            self.cns.setdefault(m.dest, _Cn()).polled += 1
            self._pending = (m.dest, t)
        elif isinstance(m, powerlink.PRes):
            node = m.src
            if node == powerlink.MN_NODE_ID:
                self._miss()  # the MN's own PRes ends the isochronous phase
                return
            cn = self.cns.setdefault(node, _Cn())
            try:
                cn.state = NmtState(m.nmt_status).name
            except ValueError:
                cn.state = f"{m.nmt_status:#04x}"
            if self._pending is not None and self._pending[0] == node:
                cn.response.add(t - self._pending[1])
                self._pending = None
            contact = contact_triangles(m.payload)
            if contact is not None and node >= 1:
                self.contact[node - 1] = contact  # patch = node id - 1, as the Lua plugin
        else:
            self._miss()

    def _miss(self) -> None:
        """The MN's next frame came before the polled CN answered."""
        if self._pending is not None:
            self.cns[self._pending[0]].missing += 1
            self._pending = None

    def _ecat(self, t: int, src: bytes, f: EcatFrame) -> None:
        self._ecat_frames += 1
        returned = bool(src[0] & ethercat.RETURNED_MAC_BIT)
        port = bytes((src[0] & ~ethercat.RETURNED_MAC_BIT & 0xFF,)) + src[1:]
        if returned:
            self._al_states(f)
        if not any(int(d.cmd) in _LOGICAL for d in f.datagrams):
            return
        key = (port, *((int(d.cmd), d.lad if int(d.cmd) in _LOGICAL else (d.adp, d.ado),
                        d.length) for d in f.datagrams))  # fmt: skip
        p = self.patterns.get(key)
        if p is None:
            text = ", ".join(f"{_name(d.cmd)} {d.lad:#010x}+{d.length}" if int(d.cmd) in _LOGICAL
                             else f"{_name(d.cmd)}+{d.length}" for d in f.datagrams)  # fmt: skip
            p = self.patterns[key] = _Pattern(text, ":".join(f"{b:02x}" for b in port))
            p.wkc = [Counter() for _ in f.datagrams]
        if not returned:
            p.sent += 1
            if p.pending is not None:
                p.lost += 1
            if p.last_sent_ns is not None:
                p.period.add(t - p.last_sent_ns)
            p.last_sent_ns = t
            p.pending = t
            return
        p.returned += 1
        if p.pending is not None:
            p.round_trip.add(t - p.pending)
            p.pending = None
        for counts, d in zip(p.wkc, f.datagrams, strict=True):
            total = sum(counts.values())
            if total >= STEADY_AFTER and d.wkc != counts.most_common(1)[0][0]:
                p.deviations += 1
            if total < WINDOW:
                counts[d.wkc] += 1
        self._taxels(f)

    def _al_states(self, f: EcatFrame) -> None:
        for d in f.datagrams:
            if int(d.cmd) in _AL_READS and d.ado == AL_STATUS and d.length >= 2 and d.wkc:
                who = f"station {d.adp:#06x}" if int(d.cmd) == Command.FPRD else "all"
                if int(d.cmd) == Command.APRD:
                    who = f"position {(-d.adp) & 0xFFFF}"
                value = int.from_bytes(d.data[:2], "little")
                self.al_states[who] = al_state_name(value)

    def _taxels(self, f: EcatFrame) -> None:
        for d in f.datagrams:
            if int(d.cmd) not in (Command.LRD, Command.LRW) or not d.wkc:
                continue
            if self._lad_base is None or d.lad < self._lad_base:
                self._lad_base = d.lad
            first = -(-(d.lad - self._lad_base) // _PATCH_BYTES)  # the first whole patch
            at = first * _PATCH_BYTES - (d.lad - self._lad_base)
            while at + _PATCH_BYTES <= len(d.data):
                contact = contact_triangles(d.data[at : at + _PATCH_BYTES])
                if contact is not None:
                    self.contact[first] = contact
                first += 1
                at += _PATCH_BYTES

    # --- reading ----------------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """The figures as plain data (times in microseconds)."""
        span = 0.0
        if self.first_ns is not None and self.last_ns is not None:
            span = (self.last_ns - self.first_ns) / 1e9
        doc: dict[str, Any] = {"frames": self.frames, "other": self.other, "span_s": span}
        if self._epl_frames:
            doc["epl"] = {
                "frames": self._epl_frames,
                "soc_period": self.soc_period.summary_us(),
                "cycles": self.soc_period.count + (self._last_soc is not None),
                "cns": [
                    {
                        "node": n,
                        "polled": cn.polled,
                        "missing": cn.missing,
                        "state": cn.state,
                        "response": cn.response.summary_us(),
                    }
                    for n, cn in sorted(self.cns.items())
                ],
            }
        if self._ecat_frames:
            doc["ecat"] = {
                "frames": self._ecat_frames,
                "patterns": [
                    {
                        "datagrams": p.text,
                        "port": p.port,
                        "sent": p.sent,
                        "returned": p.returned,
                        "lost": p.lost,
                        "period": p.period.summary_us(),
                        "round_trip": p.round_trip.summary_us(),
                        "wkc": [c.most_common(1)[0][0] if c else None for c in p.wkc],
                        "wkc_deviations": p.deviations,
                    }
                    for p in sorted(self.patterns.values(), key=lambda p: -p.sent)
                ],
                "al_states": dict(sorted(self.al_states.items())),
            }
        doc["contact"] = dict(sorted(self.contact.items()))
        return doc
