"""``skinframes analyze``: cycle statistics of an EPL or EtherCAT capture, streamed.

:func:`analyze_capture` reads the records once, in order, and keeps state per node (EPL) or per
frame pattern (EtherCAT) only; times are kept as int64 arrays (8 bytes per cycle), never as
Python objects per frame. :mod:`.epl` and :mod:`.ecat` say what is measured and how;
:func:`infer_config` names the network the capture shows (nodes, bytes per node, layout) so that
a caller holding a timing model can put its cycle time beside the measured period.

:class:`CaptureAnalyzer` is the same analysis fed record by record and read at any time
(:meth:`CaptureAnalyzer.result`); with a ``window`` it keeps the last values of each series only,
in memory that does not grow with the traffic: what ``skinframes watch`` shows.

Frames with IEEE 802.1Q/802.1ad VLAN tags (TPID 0x8100, 0x88A8, 0x9100; up to
:data:`skinframes.vlan.MAX_TAGS` stacked) are analysed as the untagged frame, as Wireshark's
``vlan`` dissector hands the payload on by the inner EtherType; EPL and EtherCAT over
unfragmented IPv4/UDP (ports 3819 and 0x88A4, :func:`skinframes.ipv4udp.claims`) as the message
the UDP datagram carries, an EPL message with the node ids of the IP addresses (DS 301 5.1.2:
its bytes 1-2 are reserved there).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Final

from skinframes import ethernet, ipv4udp, vlan
from skinframes.analysis.ecat import LOGICAL_WKC_PER_SLAVE, EcatAnalysis, EcatAnalyzer
from skinframes.analysis.epl import EplAnalysis, EplAnalyzer
from skinframes.analysis.stats import Series, Summary, Window
from skinframes.pcap import LINKTYPE_ETHERNET, Record, Skipped, read_capture
from skinframes.pcap_plain import NotPlainError, RecordRow, iter_plain_pcap, record_rows

__all__ = [
    "Analysis",
    "CaptureAnalyzer",
    "InferredConfig",
    "Series",
    "Summary",
    "Window",
    "analyze_capture",
    "analyze_file",
    "infer_config",
    "plain_frame",
]

PROGRESS_EVERY: Final = 4096  # records between progress callbacks
_EPL: Final = ethernet.ETHERTYPE_EPL.to_bytes(2, "big")
_ECAT: Final = ethernet.ETHERTYPE_ECAT.to_bytes(2, "big")
_ETHERTYPE: Final = slice(2 * ethernet.MAC_BYTES, 2 * ethernet.MAC_BYTES + 2)
_TAGGED: Final = frozenset(t.to_bytes(2, "big") for t in vlan.TPIDS)
_IPV4: Final = ipv4udp.ETHERTYPE_IPV4.to_bytes(2, "big")
_WRAPPED: Final = _TAGGED | {_IPV4}
_IP_SRC_LAST: Final = 15  # the last octets of the IPv4 source and destination (RFC 791)
_IP_DST_LAST: Final = 19


@dataclass(frozen=True, slots=True)
class InferredConfig:
    """The network a capture shows, in the terms of ``skinframes simulate``."""

    protocol: str  # "epl" or "ecat"
    nodes: int
    bytes: int
    layout: str  # "per-slave" or "logical"
    topology: str  # "daisy" (EPL), "open" or "closed" (EtherCAT)
    asnd: bool  # EPL: an ASnd in (most) cycles
    measured_period_ns: float | None  # median SoC period or cyclic-frame period

    def to_json(self) -> dict[str, Any]:
        """The ``config`` object of ``analyze --json``."""
        return {
            "protocol": self.protocol,
            "nodes": self.nodes,
            "bytes": self.bytes,
            "layout": self.layout,
            "topology": self.topology,
            "asnd": self.asnd,
            "measured_period_ns": self.measured_period_ns,
        }


@dataclass(frozen=True, slots=True)
class Analysis:
    """Everything ``analyze`` found in one capture."""

    records: int
    counts: dict[str, int]
    epl: EplAnalysis | None
    ecat: EcatAnalysis | None
    config: tuple[InferredConfig, ...]
    skipped: tuple[Skipped, ...] = ()  # records the reader could not read (its ``skipped``)

    def to_json(self) -> dict[str, Any]:
        """``{"records", "counts", "epl", "ecat", "config", "skipped"}`` (docs/interface.md)."""
        return {
            "records": self.records,
            "counts": self.counts,
            "epl": self.epl.to_json() if self.epl else None,
            "ecat": self.ecat.to_json() if self.ecat else None,
            "config": [c.to_json() for c in self.config],
            "skipped": [
                {"index": s.index, "frame": s.frame, "reason": s.reason} for s in self.skipped
            ],
        }


def analyze_capture(
    records: Iterable[Record],
    *,
    expected_wkc: int | None = None,
    pres_timeout_ns: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> Analysis:
    """Analyse the EPL and EtherCAT traffic of a capture, reading each record once.

    Args:
        records: the capture's records in order (``read_capture(path)``); frame numbers are
            ``record.index + 1``, as Wireshark counts. The records a capture (any
            :class:`~skinframes.pcap.RecordSource`) skipped are the analysis's ``skipped``.
        expected_wkc: the working counter every process-data (logical) datagram should return;
            default: each datagram's steady state (its most frequent value).
        pres_timeout_ns: the MN's PRes timeout; a PRes later than this after its PReq is late.
        progress: called with the number of records read since the last call.
    """
    analysis = _analyze_rows(record_rows(records), expected_wkc, pres_timeout_ns, progress)
    return replace(analysis, skipped=tuple(getattr(records, "skipped", ())))  # read: known now


def analyze_file(
    path: str | Path,
    *,
    expected_wkc: int | None = None,
    pres_timeout_ns: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> Analysis:
    """``analyze_capture(read_capture(path), ...)``: the same analysis, read faster where the
    file is a plain classic pcap (:func:`~skinframes.pcap_plain.iter_plain_pcap`). Where it is
    not, after all, the reader starts again from the first record (``progress`` then counts
    the records read before that twice)."""
    capture = read_capture(path)  # refuses what read_capture refuses, with its message
    if capture.format == "pcap":
        try:
            return _analyze_rows(iter_plain_pcap(path), expected_wkc, pres_timeout_ns, progress)
        except NotPlainError:
            pass
    return analyze_capture(
        capture, expected_wkc=expected_wkc, pres_timeout_ns=pres_timeout_ns, progress=progress
    )


def _analyze_rows(
    rows: Iterable[RecordRow],
    expected_wkc: int | None,
    pres_timeout_ns: int | None,
    progress: Callable[[int], None] | None,
) -> Analysis:
    """:func:`analyze_capture` of the records as rows (:data:`~skinframes.pcap_plain.RecordRow`)."""
    analyzer = CaptureAnalyzer(expected_wkc=expected_wkc, pres_timeout_ns=pres_timeout_ns)
    analyzer.feed_rows(rows, progress)
    return analyzer.result()


def plain_frame(data: bytes) -> bytes:
    """An Ethernet frame (at least its 14-byte header) as the analysis reads it: without VLAN
    tags, and an EPL or EtherCAT message over IPv4/UDP as the plain Ethernet frame of that
    message (module docstring); anything else as it is."""
    if data[_ETHERTYPE] in _TAGGED:
        data = _untagged(data)
    if data[_ETHERTYPE] == _IPV4:
        data = _unwrapped(data)
    return data


def _unwrapped(data: bytes) -> bytes:
    """An Ethernet frame with an EPL or EtherCAT message over IPv4/UDP as the plain Ethernet
    frame of that message (the same MACs); ``data`` itself when it carries none."""
    header = ethernet.HEADER_BYTES
    packet = data[header:]
    proto = ipv4udp.claims(packet)
    if proto is None:
        return data
    start = (packet[0] & 0x0F) * 4 + ipv4udp.UDP_HEADER_BYTES
    end = int.from_bytes(packet[2:4], "big")  # the IPv4 total length: the padding after it
    message = packet[start:end]
    if proto == "ecat":
        return data[: header - 2] + _ECAT + message
    nodes = bytes((packet[_IP_DST_LAST], packet[_IP_SRC_LAST]))  # EPL: dest, src (Table 22)
    return data[: header - 2] + _EPL + message[:1] + nodes + message[3:]


def _untagged(data: bytes) -> bytes:
    """An Ethernet frame without its VLAN tags (the MACs, then the inner EtherType and on)."""
    _, _, payload = vlan.peel(data)
    return data[: 2 * ethernet.MAC_BYTES] + data[payload - 2 :]


class CaptureAnalyzer:
    """:func:`analyze_capture` fed record by record: :meth:`feed` (or :meth:`feed_rows`), and
    :meth:`result` at any time.

    Args:
        expected_wkc, pres_timeout_ns: as :func:`analyze_capture`.
        window: keep only the last ``window`` values of each series and events of each kind
            (:class:`~skinframes.analysis.stats.Window`); counts still cover every record fed.
            None (``analyze``): keep everything.
    """

    def __init__(
        self,
        *,
        expected_wkc: int | None = None,
        pres_timeout_ns: int | None = None,
        window: int | None = None,
    ) -> None:
        self.epl = EplAnalyzer(pres_timeout_ns, window=window)
        self.ecat = EcatAnalyzer(expected_wkc, window=window)
        self.records = 0
        self.counts = {"epl": 0, "ecat": 0, "other": 0}

    def feed(self, record: Record) -> None:
        """One record, in capture order."""
        self.feed_rows(record_rows((record,)))

    def feed_rows(
        self, rows: Iterable[RecordRow], progress: Callable[[int], None] | None = None
    ) -> None:
        """Records as rows, in capture order; ``progress`` as :func:`analyze_capture`'s."""
        epl_feed = self.epl.feed
        ecat_feed = self.ecat.feed
        n = n_epl = n_ecat = n_other = 0
        header = ethernet.HEADER_BYTES
        try:
            for index, time_ns, data, linktype, _, interface, _, _ in rows:
                n += 1
                if progress is not None and n % PROGRESS_EVERY == 0:
                    progress(PROGRESS_EVERY)
                if linktype != LINKTYPE_ETHERNET or len(data) < header:
                    n_other += 1
                    continue
                kind = data[_ETHERTYPE]
                if kind in _WRAPPED:
                    data = plain_frame(data)
                    kind = data[_ETHERTYPE]
                if kind == _EPL:
                    n_epl += 1
                    epl_feed(index + 1, time_ns, data[header:])
                elif kind == _ECAT:
                    n_ecat += 1
                    ecat_feed(index + 1, time_ns, interface, data)
                else:
                    n_other += 1
        finally:
            self.records += n
            self.counts["epl"] += n_epl
            self.counts["ecat"] += n_ecat
            self.counts["other"] += n_other
        if progress is not None:
            progress(n % PROGRESS_EVERY)

    def result(self) -> Analysis:
        """The analysis of the records fed so far."""
        epl_result = self.epl.result() if self.counts["epl"] else None
        ecat_result = self.ecat.result() if self.counts["ecat"] else None
        config = tuple(
            c
            for c in (
                _epl_config(epl_result) if epl_result else None,
                _ecat_config(ecat_result) if ecat_result else None,
            )
            if c is not None
        )
        return Analysis(self.records, dict(self.counts), epl_result, ecat_result, config)


def infer_config(analysis: Analysis, protocol: str) -> InferredConfig | None:
    """The inferred configuration of ``protocol`` ("epl" or "ecat"), if the capture shows one."""
    return next((c for c in analysis.config if c.protocol == protocol), None)


def _epl_config(epl: EplAnalysis) -> InferredConfig | None:
    """CNs: the nodes polled by PReq; bytes: the PRes payload size of those that answer, when
    all agree."""
    polled = [n for n, k in epl.polled.items() if k]
    sizes = {epl.pres_bytes[n] for n in polled if n in epl.pres_bytes}
    if len(sizes) != 1:
        return None
    (size,) = sizes
    return InferredConfig(
        "epl",
        len(polled),
        size,
        "per-slave",
        "daisy",
        asnd=epl.soas > 0 and 2 * epl.asnd_invites > epl.soas,
        measured_period_ns=epl.soc_period.median_ns,
    )


def _ecat_config(ecat: EcatAnalysis) -> InferredConfig | None:
    """The slaves and bytes that explain the cyclic frames of the first master port.

    The cycle is the set of cyclic patterns sent most often. Per-slave layout: logical
    datagrams of one length, each with a steady working counter of one slave. Otherwise one
    logical process image of N x B bytes from address 0: the N (largest first) whose slaves,
    B bytes each in a row, give every datagram its steady working counter (a slave counts in
    each datagram its bytes overlap; LOGICAL_WKC_PER_SLAVE per command).
    """
    if not ecat.ports:
        return None
    first = ecat.ports[0]
    cyclic = [
        (i, p) for i, p in enumerate(ecat.patterns) if p.cyclic and p.port == first and p.frames
    ]
    if not cyclic:
        return None
    most = max(p.frames for _, p in cyclic)
    cycle = [(i, p) for i, p in cyclic if p.frames == most]
    spans: list[tuple[int, int, int, int]] = []  # (lad, length, steady wkc, per-slave weight)
    for _, p in cycle:
        for (cmd, _, lad, length), wkc in zip(p.pattern, p.steady_wkc, strict=True):
            if cmd in LOGICAL_WKC_PER_SLAVE:
                spans.append((lad, length, wkc, LOGICAL_WKC_PER_SLAVE[cmd]))
    if not spans:
        return None
    closed = "closed" if len(ecat.ports) > 1 else "open"
    period = cycle[0][1].period.median_ns
    lengths = {s[1] for s in spans}
    if len(lengths) == 1 and all(w == weight for _, _, w, weight in spans):
        return InferredConfig("ecat", len(spans), lengths.pop(), "per-slave", closed, False, period)
    total = sum(s[1] for s in spans)
    for nodes in range(total, 0, -1):
        if total % nodes:
            continue
        size = total // nodes
        if all(
            w == weight * (min((lad + n - 1) // size, nodes - 1) - lad // size + 1)
            for lad, n, w, weight in spans
        ):
            return InferredConfig("ecat", nodes, size, "logical", closed, False, period)
    return None
