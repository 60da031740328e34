"""Conformance checks for a whole capture: per-frame findings plus rules that span frames.

Per frame (from the decoders): EPL Size vs payload, EtherCAT header length vs datagrams, the
more-follows chain, padding, reserved fields. Added here: EPL node-id ranges per message type
(DS 301 4.2.5.1.1) and the EPL cycle order SoC -> PReq/PRes... -> SoA -> ASnd (DS 301 4.2.4.1).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from skinframes import powerlink
from skinframes.canbus.wire import CanFrame
from skinframes.dispatch import decode_frame, protocol_of
from skinframes.errors import DecodeError
from skinframes.findings import Finding, FrameFinding, Severity, error, info, warning
from skinframes.pcap import LINKTYPE_CAN_SOCKETCAN, LINKTYPE_ETHERNET, Capture

__all__ = ["CaptureReport", "FrameFinding", "check_capture"]

MN = powerlink.MN_NODE_ID
CORRUPTED_MARK = "skinframes: corrupted"  # how the emulator's fault injection marks a frame
BROADCAST = powerlink.BROADCAST_NODE_ID


@dataclass(slots=True)
class CaptureReport:
    """What ``check`` found in one capture."""

    path: str
    total: int = 0
    counts: Counter[str] = field(default_factory=Counter)
    findings: list[FrameFinding] = field(default_factory=list)

    @property
    def errors(self) -> int:
        """Number of ERROR findings."""
        return sum(f.finding.severity == Severity.ERROR for f in self.findings)

    @property
    def warnings(self) -> int:
        """Number of WARNING findings."""
        return sum(f.finding.severity == Severity.WARNING for f in self.findings)

    def at_least(self, floor: Severity) -> list[FrameFinding]:
        """The findings of severity ``floor`` or worse, in capture order."""
        return [f for f in self.findings if f.finding.severity >= floor]

    def to_json(self, floor: Severity = Severity.INFO) -> dict[str, Any]:
        """The ``skinframes check --json`` document.

        ``findings`` lists those of severity ``floor`` or worse; ``errors`` and ``warnings``
        count all of them.
        """
        return {
            "path": self.path,
            "records": self.total,
            "counts": dict(self.counts),
            "errors": self.errors,
            "warnings": self.warnings,
            "findings": [
                {"index": f.index, "frame": f.frame, **f.finding.to_json()}
                for f in self.at_least(floor)
            ],
        }


def _is_cn(node: int) -> bool:
    return powerlink.MIN_CN_NODE_ID <= node <= powerlink.MAX_CN_NODE_ID


def _node_findings(m: powerlink.EplMessage) -> list[Finding]:
    out: list[Finding] = []

    def bad(text: str) -> None:
        out.append(error("epl.node_id", f"EPL {type(m).__name__}: {text}"))

    if isinstance(m, powerlink.SoC | powerlink.SoA):
        if m.src != MN:
            bad(f"source {m.src}, the MN is {MN}")
        if m.dest != BROADCAST:
            bad(f"destination {m.dest}, expected broadcast {BROADCAST}")
    elif isinstance(m, powerlink.PReq):
        if m.src != MN:
            bad(f"source {m.src}, the MN is {MN}")
        if not _is_cn(m.dest):
            bad(f"destination {m.dest} is not a CN (1..239)")
    elif isinstance(m, powerlink.PRes):
        if not (_is_cn(m.src) or m.src == MN):
            bad(f"source {m.src} is neither a CN (1..239) nor the MN")
        if m.dest != BROADCAST:
            bad(f"destination {m.dest}, a PRes is broadcast to {BROADCAST}")
    elif isinstance(m, powerlink.ASnd):
        for name, node in (("source", m.src), ("destination", m.dest)):
            if node == 0 or 241 <= node <= 252:
                bad(f"{name} {node} is reserved")
    return out


class _CycleChecker:
    """EPL cycle order: SoC opens the isochronous phase, SoA the asynchronous one."""

    def __init__(self) -> None:
        self.phase = "unknown"  # before the first SoC or SoA we cannot judge
        self.polled: int | None = None
        self.asnd_after_soa = 0

    def feed(self, m: powerlink.EplMessage) -> list[Finding]:
        out: list[Finding] = []
        if isinstance(m, powerlink.SoC):
            if self.phase == "isochronous":
                out.append(warning("epl.cycle.no_soa", "EPL: SoC follows a cycle that had no SoA"))
            self.phase, self.polled = "isochronous", None
        elif isinstance(m, powerlink.PReq):
            if self.phase == "asynchronous":
                out.append(
                    error("epl.cycle.order", f"EPL: PReq to {m.dest} in the asynchronous phase")
                )
            self.polled = m.dest
        elif isinstance(m, powerlink.PRes):
            if self.phase == "asynchronous":
                out.append(
                    error("epl.cycle.order", f"EPL: PRes from {m.src} in the asynchronous phase")
                )
            elif self.phase == "isochronous" and m.src not in (self.polled, MN):
                out.append(
                    warning(
                        "epl.cycle.unpolled",
                        f"EPL: PRes from {m.src}, "
                        + (
                            f"the last PReq went to {self.polled}"
                            if self.polled is not None
                            else "but no PReq polled a CN since the last SoC or PRes"
                        ),
                    )
                )
            self.polled = None
        elif isinstance(m, powerlink.SoA):
            self.phase, self.asnd_after_soa = "asynchronous", 0
        elif isinstance(m, powerlink.ASnd):
            if self.phase == "isochronous":
                out.append(error("epl.cycle.order", "EPL: ASnd in the isochronous phase"))
            elif self.phase == "asynchronous":
                self.asnd_after_soa += 1
                if self.asnd_after_soa > 1:
                    out.append(
                        info("epl.cycle.asnd_count", "EPL: more than one ASnd after one SoA")
                    )
        return out


def _socketcan_findings(data: bytes) -> list[Finding]:
    """A LINKTYPE_CAN_SOCKETCAN record: header, ``len`` against the frame type and the bytes."""
    try:
        CanFrame.from_socketcan(data)
    except DecodeError as exc:
        return [error("can.socketcan", str(exc))]
    return []


def check_capture(capture: Capture) -> CaptureReport:
    """Run every check on every record of ``capture``, reading it once (streamed)."""
    report = CaptureReport(capture.path)
    cycle = _CycleChecker()
    for rec in capture:
        if rec.linktype == LINKTYPE_CAN_SOCKETCAN:
            report.counts["can"] += 1
            report.findings += [FrameFinding(rec.index, f) for f in _socketcan_findings(rec.data)]
            continue
        if rec.linktype != LINKTYPE_ETHERNET:
            report.counts["other"] += 1
            continue
        try:
            frame = decode_frame(rec.data)
        except DecodeError as exc:  # capture mode raises only for a record under 14 bytes
            report.counts["other"] += 1
            report.findings.append(FrameFinding(rec.index, error("eth.truncated", str(exc))))
            continue
        proto = protocol_of(frame)
        report.counts[proto] += 1
        found = list(frame.findings)
        found += [error("eth.corrupted", c) for c in rec.comments if c.startswith(CORRUPTED_MARK)]
        if proto == "epl":
            m = frame.payload
            assert not isinstance(m, bytes | bytearray)
            found += _node_findings(m)  # type: ignore[arg-type]
            found += cycle.feed(m)  # type: ignore[arg-type]
        report.findings += [FrameFinding(rec.index, f) for f in found]
    report.total = capture.total
    for s in capture.skipped:
        report.findings.append(FrameFinding(s.index, error(s.code, s.reason)))
        report.counts["skipped"] += 1
    report.findings += capture.findings
    report.findings.sort(key=lambda f: f.index)  # capture order; the file's own findings first
    return report
