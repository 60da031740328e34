"""Conformance checks for a whole capture: per-frame findings plus rules that span frames.

Per frame (from the decoders): EPL Size vs payload, EtherCAT header length vs datagrams, the
more-follows chain, padding, reserved fields. Added here: EPL node-id ranges per message type
(DS 301 4.2.5.1.1), the EPL cycle order SoC -> PReq/PRes... -> SoA -> ASnd (DS 301 4.2.4.1), and
physical timing: two frames of one sender on one interface that overlap on the wire
(:class:`OverlapChecker`).
"""

from __future__ import annotations

import json
import textwrap
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from operator import itemgetter
from pathlib import Path
from typing import IO, Any, Final, TypeAlias

from skinframes import encap, ethercat, ethernet, ipv4udp, powerlink
from skinframes.dispatch import RepeatMemo, decode_frame, protocol_of
from skinframes.errors import DecodeError
from skinframes.findings import (
    Finding,
    FindingList,
    FrameFinding,
    Severity,
    error,
    info,
    warning,
)
from skinframes.pcap import (
    LINKTYPE_CAN_SOCKETCAN,
    LINKTYPE_ETHERNET,
    RecordSource,
    read_capture,
)
from skinframes.pcap_plain import NotPlainError, RecordRow, iter_plain_pcap, record_rows

__all__ = [
    "CaptureReport",
    "FrameFinding",
    "OverlapChecker",
    "check_capture",
    "check_file",
]

MN = powerlink.MN_NODE_ID
CORRUPTED_MARK = "skinframes: corrupted"  # how the emulator's fault injection marks a frame
BROADCAST = powerlink.BROADCAST_NODE_ID


@dataclass(slots=True)
class CaptureReport:
    """What ``check`` found in one capture."""

    path: str
    total: int = 0
    counts: Counter[str] = field(default_factory=Counter)
    # a sequence of FrameFinding, 12 bytes each (a finding in every frame of a long capture)
    findings: FindingList = field(default_factory=FindingList)

    @property
    def errors(self) -> int:
        """Number of ERROR findings."""
        return self.findings.count_at_least(Severity.ERROR)

    @property
    def warnings(self) -> int:
        """Number of WARNING findings."""
        return self.findings.count_at_least(Severity.WARNING) - self.errors

    def at_least(self, floor: Severity) -> list[FrameFinding]:
        """The findings of severity ``floor`` or worse, in capture order (a list: for all of
        them one at a time, ``findings.at_least(floor)``)."""
        return list(self.findings.at_least(floor))

    def to_json(self, floor: Severity = Severity.INFO) -> dict[str, Any]:
        """The ``skinframes check --json`` document.

        ``findings`` lists those of severity ``floor`` or worse; ``errors`` and ``warnings``
        count all of them.
        """
        doc = self._head()
        doc["findings"] = [_finding_json(f) for f in self.findings.at_least(floor)]
        return doc

    def _head(self) -> dict[str, Any]:
        """The document without its findings."""
        return {
            "path": self.path,
            "records": self.total,
            "counts": dict(self.counts),
            "errors": self.errors,
            "warnings": self.warnings,
            "findings": [],
        }

    def write_json(self, out: IO[str], floor: Severity = Severity.INFO) -> None:
        """``json.dump(self.to_json(floor), out, indent=2)``, the findings written one at a
        time (the document of a long capture is not held whole)."""
        text = json.dumps(self._head(), indent=2)
        cut = text.rindex('"findings": []')
        out.write(text[:cut] + '"findings": [')
        first = True
        for f in self.findings.at_least(floor):
            item = textwrap.indent(json.dumps(_finding_json(f), indent=2), "    ")
            out.write(("\n" if first else ",\n") + item)
            first = False
        out.write("]" if first else "\n  ]")
        out.write(text[cut + len('"findings": []') :])


def _finding_json(f: FrameFinding) -> dict[str, Any]:
    return {"index": f.index, "frame": f.frame, **f.finding.to_json()}


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
            if _is_reserved(node):
                bad(f"{name} {node} is reserved")
    return out


def _is_reserved(node: int) -> bool:
    return node == 0 or 241 <= node <= 252


def _udp_node_findings(packet: ipv4udp.Ipv4Udp) -> list[Finding]:
    """EPL over UDP: the node ids are the IP addresses' last octets (DS 301 5.1.2; bytes 1-2 are
    reserved). An ASnd's reserved ones are errors, as on Ethernet, where the address is in
    192.168.100.0/24; other message types and addresses are :mod:`ipv4udp`'s info findings."""
    out: list[Finding] = []
    if not isinstance(packet.payload, powerlink.ASnd):
        return out
    for name, node, ip in (
        ("source", packet.src_node, packet.src_ip),
        ("destination", packet.dest_node, packet.dst_ip),
    ):
        if ip in ipv4udp.EPL_IP_NETWORK and _is_reserved(node):
            out.append(error("epl.node_id", f"EPL ASnd over UDP: {name} {node} ({ip}) is reserved"))
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


_WIRE_MEMO: Final = 4096  # (interface, length, FCS) wire times an OverlapChecker remembers


class OverlapChecker:
    """Frames one sender puts on one interface cannot overlap on the wire (``eth.overlap``).

    A full-duplex MAC sends one frame at a time (IEEE 802.3-2018 4.2.3.2), each as preamble + SFD
    (3.2.1-3.2.2), the frame padded to 60 bytes (3.2.8), the FCS (3.2.9), then keeps the
    inter-frame gap (4.4.2) before the next one; the constants are :mod:`skinframes.ethernet`'s.
    The sender is the source MAC, the interface the pcapng interface id. Two of its frames
    stamped ``dt`` apart need ``dt >= wire time + IFG`` of the shorter one (whether a capture
    stamps the first or the last bit, the same bit of both frames is compared), less one tick
    of the timestamps' resolution (1 us when both stamps are whole microseconds). A warning, not
    an error: captures stamped in software (on the sender) show legal frames closer than this.

    Args:
        bit_rate_bps: the interface's speed by interface id; missing interfaces run at
            :data:`~skinframes.ethernet.DEFAULT_BIT_RATE_BPS`. A frame's own ``rate_bps`` (the
            pcapng ``if_speed`` its record carries) takes precedence.
    """

    def __init__(self, bit_rate_bps: dict[int, int] | None = None) -> None:
        self.bit_rate_bps = bit_rate_bps or {}
        # (interface, source) -> (index, time, wire, signature) of its last frame
        self.last: dict[tuple[int, bytes], tuple[int, int, int, tuple[object, ...] | None]] = {}
        # (bit rate, length, FCS captured) -> (wire_ns, inter-frame gap ns) of the lengths seen
        self._wire: dict[tuple[int, int, bool], tuple[int, int]] = {}

    def rate_bps(self, interface: int, rate_bps: int | None = None) -> int:
        """The bit rate of ``interface``: ``rate_bps`` when given, else as configured."""
        return rate_bps or self.bit_rate_bps.get(interface, ethernet.DEFAULT_BIT_RATE_BPS)

    def wire_ns(
        self, interface: int, frame_bytes: int, fcs_captured: bool, rate_bps: int | None = None
    ) -> int:
        """Time on the wire of a frame captured with ``frame_bytes`` (FCS included or not)."""
        rate = self.rate_bps(interface, rate_bps)
        body = frame_bytes - (ethernet.FCS_BYTES if fcs_captured else 0)
        octets = ethernet.wire_bytes(body)
        return -(-octets * 8 * 1_000_000_000 // rate)  # rounded up to whole ns

    def feed(
        self,
        index: int,
        time_ns: int,
        interface: int,
        src: bytes,
        length: int,
        fcs: bool,
        signature: tuple[object, ...] | None = None,
        rate_bps: int | None = None,
    ) -> list[Finding]:
        """The finding for a frame that starts before its sender's previous one has ended.

        ``signature``: an EtherCAT frame's datagram headers. The master's frame coming back
        through a closed ring keeps its source address (an ESC sets bit 1 of it only where the
        frame passes its port 0 processing), so in one stream (classic pcap) it meets the copy
        the master sent from its other port: a frame with the previous frame's signature is
        that return, not a second frame the sender put on the wire. ``rate_bps``: the speed
        of the interface the frame was captured on, when the capture says (pcapng ``if_speed``).
        """
        rate = self.rate_bps(interface, rate_bps)
        times = self._wire.get((rate, length, fcs))
        if times is None:
            if len(self._wire) >= _WIRE_MEMO:
                self._wire.clear()
            ifg = -(-ethernet.IFG_BYTES * 8 * 1_000_000_000 // rate)
            times = self._wire[rate, length, fcs] = (
                self.wire_ns(interface, length, fcs, rate),
                ifg,
            )
        wire, ifg = times
        key = (interface, bytes(src))
        prev = self.last.get(key)
        if prev is not None and signature is not None and signature == prev[3]:
            return []  # the return of the sender's last frame: its send stays the last
        self.last[key] = (index, time_ns, wire, signature)
        if prev is None:
            return []
        p_index, p_time, p_wire, _ = prev
        if time_ns - p_time > p_wire + ifg or time_ns < p_time:
            return []  # the common case, and never closer than need (<= p_wire + ifg) allows
        need = min(wire, p_wire) + ifg
        tick = 1000 if time_ns % 1000 == 0 and p_time % 1000 == 0 else 1
        if time_ns - p_time >= need - tick + 1 or time_ns < p_time:
            return []
        return [
            warning(  # a warning: a software capture's clock can be this wrong on legal traffic
                "eth.overlap",
                f"Ethernet: {time_ns - p_time} ns after frame {p_index + 1} from the same sender "
                f"{ethernet.format_mac(src)} on interface {interface}, which needs {need} ns "
                f"(wire time {min(wire, p_wire)} ns + inter-frame gap {ifg} ns at "
                f"{rate / 1e6:g} Mbit/s, IEEE 802.3-2018 4.2.3.2, 4.4.2): the frames overlap",
            )
        ]


def _socketcan_findings(data: bytes) -> list[Finding]:
    """A LINKTYPE_CAN_SOCKETCAN record: header, ``len`` against the frame type and the bytes."""
    from skinframes.canbus.wire import CanFrame  # here: EPL/EtherCAT captures need no CAN

    try:
        CanFrame.from_socketcan(data)
    except DecodeError as exc:
        return [error("can.socketcan", str(exc))]
    return []


def check_capture(
    capture: RecordSource, *, progress: Callable[[int], None] | None = None
) -> CaptureReport:
    """Run every check on every record of ``capture``, reading it once (streamed).
    ``progress``: called with the number of records read since the last call."""
    report = CaptureReport(capture.path)
    overlap = OverlapChecker()
    _check_records(report, _counted(record_rows(capture), progress), overlap)
    report.total = capture.total
    for s in capture.skipped:
        report.findings.append(FrameFinding(s.index, error(s.code, s.reason)))
        report.counts["skipped"] += 1
    report.findings += capture.findings
    report.findings.sort()  # capture order (by record index); the file's own findings first
    return report


def check_file(path: str | Path, *, progress: Callable[[int], None] | None = None) -> CaptureReport:
    """``check_capture(read_capture(path))``: the same report, read faster where the file is a
    plain classic pcap (:func:`~skinframes.pcap_plain.iter_plain_pcap`, no ``Record`` objects;
    the reader has nothing to report there: no skipped record, no finding of its own). Where it
    is not, after all, the reader starts again (``progress`` counts the records before twice)."""
    capture = read_capture(path)  # refuses what read_capture refuses, with its message
    if capture.format == "pcap":
        report = CaptureReport(capture.path)
        try:
            rows = _counted(iter_plain_pcap(path), progress)
            report.total = _check_records(report, rows, OverlapChecker())
        except NotPlainError:
            pass  # the reader says what is wrong with the file, from the start
        else:
            return report  # findings come in capture order: nothing to sort in
    return check_capture(capture, progress=progress)


PROGRESS_EVERY: Final = 4096  # records between progress callbacks


def _counted(
    rows: Iterable[RecordRow], progress: Callable[[int], None] | None
) -> Iterable[RecordRow]:
    """``rows``, calling ``progress`` every :data:`PROGRESS_EVERY` rows and at the end (as
    they are; nothing in between without ``progress``)."""
    if progress is None:
        return rows

    def counting() -> Iterator[RecordRow]:
        n = 0
        for row in rows:
            yield row
            n += 1
            if n == PROGRESS_EVERY:
                progress(n)
                n = 0
        progress(n)

    return counting()


# What the checks need of a frame that depend on its judged bytes alone (see _judge)
_Judged: TypeAlias = tuple[
    str, list[Finding], bool, bytes, tuple[object, ...] | None, int | None, Any
]


def _check_records(
    report: CaptureReport, rows: Iterable[RecordRow], overlap: OverlapChecker
) -> int:
    """The per-frame checks of ``records`` into ``report``; returns how many were read."""
    cycle = _CycleChecker()
    judge = RepeatMemo(_judge, key=JudgedBytes())  # each distinct frame decoded, judged once
    findings = report.findings
    counts = report.counts
    n = 0
    for index, time_ns, data, linktype, orig_len, interface, comments, rate_bps in rows:
        n += 1
        if linktype != LINKTYPE_ETHERNET:
            if linktype == LINKTYPE_CAN_SOCKETCAN:
                counts["can"] += 1
                findings += [FrameFinding(index, f) for f in _socketcan_findings(data)]
            else:
                counts["other"] += 1
            continue
        try:
            proto, found, fcs, src, signature, node, message = judge(data)
        except DecodeError as exc:  # capture mode raises only for a record under 14 bytes
            counts["other"] += 1
            findings.append(FrameFinding(index, error("eth.truncated", str(exc))))
            continue
        counts[proto] += 1
        later = overlap.feed(index, time_ns, interface, src, orig_len, fcs, signature, rate_bps)
        if later:
            found = found + later  # never in place: a repeated frame shares ``found``
        if comments:
            found = found + [
                error("eth.corrupted", c) for c in comments if c.startswith(CORRUPTED_MARK)
            ]
        if message is not None:
            more = cycle.feed(message)
            if more:
                found = found + more
        if found:
            findings += [FrameFinding(index, f, node) for f in found]
    return n


# An EPL PReq/PRes (DS 301 4.6.1.1.3-4): header to the end of Size, then the payload
_PDO_PAYLOAD_AT: Final = ethernet.HEADER_BYTES + powerlink.PDO_HEADER_BYTES  # 24
_PDO_TYPES: Final = (powerlink.MessageType.PREQ, powerlink.MessageType.PRES)
_EPL_TYPE: Final = ethernet.ETHERTYPE_EPL.to_bytes(2, "big")


_ECAT_TYPE: Final = ethernet.ETHERTYPE_ECAT.to_bytes(2, "big")
assert _ECAT_TYPE[0] == _EPL_TYPE[0] == 0x88
_ECAT_FIRST: Final = ethernet.HEADER_BYTES + ethercat.FRAME_HEADER_BYTES  # 16
_PROCESS_DATA: Final = frozenset(int(c) for c in ethercat.LOGICAL_COMMANDS)  # LRD, LWR, LRW
_LAYOUTS: Final = 64  # frame lengths whose EtherCAT layout JudgedBytes remembers


def judged_bytes(data: bytes) -> bytes:
    """The bytes the checks of a frame depend on: all of them, except the process data of an
    EPL PReq/PRes or of EtherCAT LRD/LWR/LRW datagrams when fewer than 4 bytes follow the
    message.

    No rule reads process data: the headers (Size, the datagram length words and their M bits,
    commands, reserved bits), the node ids and the padding decide every finding; only a trailing
    FCS (4 bytes or more after the message) covers the data. So PRes frames, and EtherCAT frames
    of logical datagrams, that differ only in their taxels are judged once.
    """
    if len(data) < _PDO_PAYLOAD_AT or data[12] != 0x88:  # EtherType high byte, EPL and ECAT
        return data
    if data[13] == _ECAT_TYPE[1]:
        return _ecat_judged(data)
    if data[13] == _EPL_TYPE[1] and data[14] in _PDO_TYPES:
        end = _PDO_PAYLOAD_AT + (data[22] | data[23] << 8)
        if end <= len(data) < end + ethernet.FCS_BYTES:
            return data[:_PDO_PAYLOAD_AT] + data[end:]
    return data


def _ecat_judged(data: bytes) -> bytes:
    """:func:`judged_bytes` of an EtherCAT frame (ETG.1000.4 Table 12/13): every byte but the
    data of LRD/LWR/LRW datagrams; the whole frame when any other command is in it."""
    spans = _ecat_spans(data)
    return data if spans is None else b"".join([data[a:b] for a, b in spans])


def _ecat_spans(data: bytes) -> list[tuple[int, int]] | None:
    """Where the judged bytes of an EtherCAT frame are: its header, each datagram's header and
    working counter, the tail; None when the whole frame is judged."""
    n = len(data)
    if n < _ECAT_FIRST or data[15] >> 4 != ethercat.FrameType.ECAT:
        return None
    spans = [(0, _ECAT_FIRST)]
    pos, more = _ECAT_FIRST, True
    while more and pos < n:
        if pos + ethercat.DATAGRAM_HEADER_BYTES > n or data[pos] not in _PROCESS_DATA:
            return None
        word = data[pos + 6] | data[pos + 7] << 8
        end = pos + ethercat.DATAGRAM_HEADER_BYTES + (word & 0x7FF)
        if end + ethercat.WKC_BYTES > n:
            return None
        spans.append((pos, pos + ethercat.DATAGRAM_HEADER_BYTES))
        spans.append((end, end + ethercat.WKC_BYTES))
        pos, more = end + ethercat.WKC_BYTES, bool(word & 0x8000)
    if n - pos >= ethernet.FCS_BYTES:
        return None
    spans.append((pos, n))
    return spans


class JudgedBytes:
    """:func:`judged_bytes`, faster for cyclic EtherCAT: per frame length, where the last
    EtherCAT frame of that length with logical datagrams had its judged bytes is remembered,
    and a frame with the same bytes where the walk over the datagrams looks (EtherType, frame
    header, each datagram's command and length word) has its judged bytes in the same places.

    Why that is exact: :func:`_ecat_spans` reads nothing but those bytes and the length; equal
    bytes there make it take the same steps and return the same spans.
    """

    __slots__ = ("_layouts",)

    def __init__(self) -> None:
        # frame length -> (bytes looked at, their values, the judged spans), as itemgetters
        self._layouts: dict[int, tuple[Callable[[bytes], Any], tuple[int, ...], Any]] = {}

    def __call__(self, data: bytes) -> bytes:
        """``judged_bytes(data)``."""
        layout = self._layouts.get(len(data))
        if layout is not None and layout[0](data) == layout[1]:
            return b"".join(layout[2](data))
        if len(data) >= _PDO_PAYLOAD_AT and data[12:14] == _ECAT_TYPE:
            spans = _ecat_spans(data)
            if spans is None:
                return data
            looked = [12, 13, 14, 15]
            for start, _ in spans[1:-1:2]:  # the datagram headers: command, length word
                looked += (start, start + 6, start + 7)
            look = itemgetter(*looked)
            pick = itemgetter(*(slice(a, b) for a, b in spans))  # >= 2 spans: a tuple
            if len(self._layouts) >= _LAYOUTS:
                self._layouts.clear()
            self._layouts[len(data)] = (look, look(data), pick)
            return b"".join(pick(data))
        return judged_bytes(data)


def _decode(data: bytes) -> tuple[ethernet.EthernetFrame, str, list[Finding]]:
    """A frame, its protocol, and the findings that depend on its bytes alone (not to be
    changed: a repeated frame shares them, and for a PReq/PRes a frame with other taxels,
    see :func:`judged_bytes`; the cycle checker reads only the message type and node ids)."""
    frame = decode_frame(data)
    proto = protocol_of(frame)
    found = list(frame.findings)
    if proto == "epl":
        if isinstance(frame.payload, ipv4udp.Ipv4Udp):
            found += _udp_node_findings(frame.payload)
        else:
            found += _node_findings(encap.message_of(frame))  # type: ignore[arg-type]
    return frame, proto, found


def _judge(data: bytes) -> _Judged:
    """What the checks need of a frame, all of it fixed by :func:`judged_bytes`: protocol,
    findings (:func:`_decode`), whether the FCS was captured, source MAC, EtherCAT signature
    (datagram headers, for :class:`OverlapChecker`), EPL source node, and the EPL message the
    cycle checker reads (None for other frames and EPL over UDP, which is routed, not cyclic)."""
    frame, proto, found = _decode(data)
    fcs = any(f.code == "eth.fcs" for f in frame.findings)
    message = encap.message_of(frame) if proto in ("ecat", "epl") else None
    signature = (
        tuple((d.cmd, d.idx, d.adp, d.ado, len(d.data)) for d in message.datagrams)
        if proto == "ecat" and isinstance(message, ethercat.EcatFrame) and message.datagrams
        else None
    )
    node: int | None = None
    cyclic = None
    if proto == "epl":
        if isinstance(frame.payload, ipv4udp.Ipv4Udp):
            node = frame.payload.src_node  # DS 301 5.1.2: bytes 1-2 are reserved over UDP
        else:
            node = getattr(message, "src", None)
            cyclic = message
    return proto, found, fcs, frame.src, signature, node, cyclic
