"""EtherCAT cycle analysis of a capture, frame by frame with state per frame pattern only.

A frame's *pattern* is its datagram chain without the data: each datagram's command, address
and length (ETG.1000.4 Table 13). The address is the logical address for LRD/LWR/LRW, station
address and offset for configured-address commands, and the offset alone for auto-increment
and broadcast commands (every slave increments their ADP on the way, ETG.1000.4 5.4.1). A
pattern is *cyclic* when it carries process data (a logical command).

Directions: an ESC sets bit 0x02 of the first source-MAC octet of a frame it processed
(:data:`skinframes.ethercat.RETURNED_MAC_BIT`); in a closed ring a frame can also come back on
the master's other port (another pcapng interface). A frame is the *return* of an earlier one
when their patterns, first datagram index and master port (source MAC with that bit cleared)
agree and either the bit or the interface differ; otherwise it is sent by the master
(*outbound*). But for one case a capture without interfaces (classic pcap) cannot tell apart:
a closed ring's master sends each frame from both ports, and the copy from the second port
runs the ring unprocessed (in forwarding direction, no bit set) back to the first; so a frame
that equals its port's outstanding send, working counters and all, while the same frame sent
earlier (in capture order: both sends may carry one time stamp) from another port of the
master is outstanding too, is that copy's return. An outbound frame followed by another outbound frame of the same key before its
return is *unanswered* (lost), provided the capture holds returns of that pattern at all.

Per pattern and master port: the period between outbound frames, the round trip (outbound to
return) and the working counter of each datagram in the returned frames against its steady
state (the most frequent value, ties to the lower) or a given value for the process data
datagrams. AL states (ETG.1000.4 Table 31): writes of AL control (0x0120) in outbound frames
are the states the master requested; reads of AL status (0x0130) in returned frames are what
the slaves reported, each change listed once.

With a ``window`` (``skinframes watch``'s sliding window) the analyzer keeps only the last
``window`` values of each series (period, round trip, unanswered frames) and events of each
kind, and per datagram how often each working counter came instead of one row per frame: the
counts (frames, returned, unanswered, working-counter deviations) and the steady working
counters still cover everything fed, the statistics and event lists the window; memory then does
not grow with the traffic (but for the patterns themselves, as many as the master sends).
"""

from __future__ import annotations

import struct
from collections import Counter, deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np

from skinframes import ethercat, ethernet
from skinframes.analysis.stats import Rows, Series, Summary, Window
from skinframes.ethercat import Command

__all__ = [
    "AL_CONTROL",
    "AL_STATUS",
    "AlStateChange",
    "EcatAnalysis",
    "EcatAnalyzer",
    "PatternReport",
    "WkcDeviation",
    "pattern_text",
    "walk",
]

AL_CONTROL: Final = 0x0120  # ETG.1000.4 Table 31: AL control register (2 bytes)
AL_STATUS: Final = 0x0130  # ETG.1000.4 Table 31: AL status register (2 bytes)
AL_STATE_MASK: Final = 0x0F  # bits 0-3: the state; bit 4 error indication / acknowledge
AL_ERROR_BIT: Final = 0x10
AL_STATE_NAMES: Final = {1: "INIT", 2: "PREOP", 3: "BOOT", 4: "SAFEOP", 8: "OP"}  # ETG.1000.6 6.4.1
RETURNED_MAC_BIT: Final = ethercat.RETURNED_MAC_BIT

_LOGICAL: Final = frozenset(int(c) for c in ethercat.LOGICAL_COMMANDS)
_CONFIGURED: Final = frozenset(
    int(c) for c in (Command.FPRD, Command.FPWR, Command.FPRW, Command.FRMW)
)
_AUTO_INCREMENT: Final = frozenset(
    int(c) for c in (Command.APRD, Command.APWR, Command.APRW, Command.ARMW)
)
_WRITES: Final = frozenset(
    int(c)
    for c in (Command.APWR, Command.APRW, Command.FPWR, Command.FPRW, Command.BWR, Command.BRW)
)
_READS: Final = frozenset(
    int(c)
    for c in (
        Command.APRD,
        Command.APRW,
        Command.FPRD,
        Command.FPRW,
        Command.BRD,
        Command.BRW,
        Command.ARMW,
        Command.FRMW,
    )
)
# Working-counter increments of one slave for a logical command it serves both ways
# (ETG.1000.4 Table 17: read 1, write 1... LRW read 1 + write 2).
LOGICAL_WKC_PER_SLAVE: Final = {int(Command.LRD): 1, int(Command.LWR): 1, int(Command.LRW): 3}

Pattern = tuple[tuple[int, int, int, int], ...]  # (cmd, adp or -1, ado or lad, length) each


# (cmd, idx, adp, ado, data length, data offset in the Ethernet frame, wkc) of one datagram
_Walked = tuple[int, int, int, int, int, int, int]
_HEAD: Final = struct.Struct("<BBHHH")  # cmd idx adp ado len|flags; then irq (ETG.1000.4 Table 13)
_HEADER_TYPE_SHIFT: Final = 12  # EtherCAT header: length 11 bits, reserved 1, type 4 (Table 12)
_LEN_MASK: Final = 0x07FF
_MORE: Final = 0x8000


def walk(data: bytes, start: int) -> list[_Walked]:
    """The datagram headers of the EtherCAT frame at ``data[start:]``, read as
    :func:`skinframes.ethercat.decode` reads them (while the M bit says more follow), without
    building datagrams; empty when the frame is not one of EtherCAT commands or is truncated."""
    end = len(data)
    if end - start < ethercat.FRAME_HEADER_BYTES:
        return []
    header = data[start] | data[start + 1] << 8
    if header >> _HEADER_TYPE_SHIFT != ethercat.FrameType.ECAT:
        return []
    out: list[_Walked] = []
    pos = first = start + ethercat.FRAME_HEADER_BYTES
    last = first + (header & _LEN_MASK)  # a set M bit on the last datagram ends here
    head = _HEAD.unpack_from
    more = True
    while more and pos < end:
        if end - pos < ethercat.DATAGRAM_OVERHEAD_BYTES:
            return []
        cmd, idx, adp, ado, word = head(data, pos)
        n = word & _LEN_MASK
        at = pos + ethercat.DATAGRAM_HEADER_BYTES
        pos = at + n + ethercat.WKC_BYTES
        if pos > end:
            return []
        out.append((cmd, idx, adp, ado, n, at, data[pos - 2] | data[pos - 1] << 8))
        more = bool(word & _MORE) and pos != last
    return out


def _register(data: bytes, at: int, ado: int, n: int, register: int) -> int | None:
    """The 16-bit register a physical datagram at offset ``ado`` with ``n`` bytes carries."""
    first = register - ado
    if not 0 <= first <= n - 2:
        return None
    return data[at + first] | data[at + first + 1] << 8


def _touches_al(pattern: Pattern) -> bool:
    """Does a frame of this pattern write AL control or read AL status?"""
    for cmd, _, ado, n in pattern:
        if cmd in _LOGICAL:
            continue
        if cmd in _WRITES and 0 <= AL_CONTROL - ado <= n - 2:
            return True
        if cmd in _READS and 0 <= AL_STATUS - ado <= n - 2:
            return True
    return False


def _command_name(cmd: int) -> str:
    try:
        return Command(cmd).name
    except ValueError:
        return f"{cmd:#04x}"


def pattern_text(pattern: Pattern) -> str:
    """``LRD 0x00000000+8, FPRD 0x1001:0x0130+2, BRD *:0x0130+2`` for a pattern."""
    parts = []
    for cmd, adp, addr, n in pattern:
        if cmd in _LOGICAL:
            where = f"{addr:#010x}"
        elif adp >= 0:
            where = f"{adp:#06x}:{addr:#06x}"
        else:
            where = f"*:{addr:#06x}"
        parts.append(f"{_command_name(cmd)} {where}+{n}")
    return ", ".join(parts)


def al_state_name(value: int) -> str:
    """``OP``, ``SAFEOP+ERR``... for an AL control or status word."""
    state = AL_STATE_NAMES.get(value & AL_STATE_MASK, f"{value & AL_STATE_MASK:#x}")
    return state + ("+ERR" if value & AL_ERROR_BIT else "")


@dataclass(frozen=True, slots=True)
class WkcDeviation:
    """A returned datagram whose working counter differs from the expected value."""

    frame: int
    time_ns: int
    pattern: int  # index into EcatAnalysis.patterns (a pattern from one master port)
    datagram: int  # position in the frame
    wkc: int
    expected: int


@dataclass(frozen=True, slots=True)
class AlStateChange:
    """An AL state the master requested (``requested``) or a slave reported (``reported``)."""

    frame: int
    time_ns: int
    kind: str  # "requested" or "reported"
    target: str  # "station 0x1001", "position 0", "all"
    state: str
    value: int


@dataclass(frozen=True, slots=True)
class PatternReport:
    """What ``analyze`` found for one pattern sent from one master port."""

    pattern: Pattern
    text: str
    cyclic: bool
    port: str  # the master port's MAC
    frames: int  # outbound frames
    returned: int
    unanswered: tuple[int, ...]  # frame numbers of outbound frames that never came back
    period: Summary
    period_ns: Any
    round_trip: Summary
    round_trip_ns: Any
    expected_wkc: tuple[int, ...]
    steady_wkc: tuple[int, ...]  # the most frequent returned working counter per datagram
    unanswered_count: int = 0  # all of them (``unanswered``: a window's last ones)
    wkc_deviation_count: int = 0  # datagrams of this pattern's frames off their expected_wkc

    def to_json(self, index: int) -> dict[str, Any]:
        """One entry of ``ecat.patterns``."""
        return {
            "pattern": index,
            "datagrams": self.text,
            "cyclic": self.cyclic,
            "port": self.port,
            "frames": self.frames,
            "returned": self.returned,
            "unanswered": list(self.unanswered),
            "period": self.period.to_json(),
            "round_trip": self.round_trip.to_json(),
            "expected_wkc": list(self.expected_wkc),
            "steady_wkc": list(self.steady_wkc),
        }


@dataclass(frozen=True, slots=True)
class EcatAnalysis:
    """The EtherCAT part of ``analyze``."""

    frames: int
    undecodable: int
    patterns: tuple[PatternReport, ...]
    wkc_deviations: tuple[WkcDeviation, ...]
    al_states: tuple[AlStateChange, ...]
    ports: tuple[str, ...]
    # the AL state each target reported last (``al_states``'s targets), by name
    al_current: dict[str, str] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The ``ecat`` object of ``analyze --json`` (docs/interface.md)."""
        return {
            "frames": self.frames,
            "undecodable": self.undecodable,
            "ports": list(self.ports),
            "patterns": [p.to_json(i) for i, p in enumerate(self.patterns)],
            "wkc_deviations": [
                {
                    "frame": d.frame,
                    "time_ns": d.time_ns,
                    "pattern": d.pattern,
                    "datagram": d.datagram,
                    "wkc": d.wkc,
                    "expected": d.expected,
                }
                for d in self.wkc_deviations
            ],
            "al_states": [
                {
                    "frame": a.frame,
                    "time_ns": a.time_ns,
                    "kind": a.kind,
                    "target": a.target,
                    "state": a.state,
                    "value": a.value,
                }
                for a in self.al_states
            ],
        }


class _WkcCounts:
    """Per datagram how often each working counter came: a window's :class:`Rows` (memory
    bounded by the distinct values, not by the frames)."""

    __slots__ = ("columns", "rows")

    def __init__(self, width: int) -> None:
        self.columns: list[Counter[int]] = [Counter() for _ in range(width)]
        self.rows = 0

    def append(self, row: Sequence[int]) -> None:
        """One frame's working counters."""
        self.rows += 1
        for counts, wkc in zip(self.columns, row, strict=True):
            counts[wkc] += 1

    def __len__(self) -> int:
        return self.rows


@dataclass(slots=True)
class _Stream:
    """One pattern from one master port."""

    width: int
    series: Callable[[], Series | Window]
    counted: bool  # working counters as _WkcCounts (a window) or Rows
    frames: int = 0
    returned: int = 0
    last_out_ns: int | None = None
    period_ns: Series | Window = field(init=False)
    round_trip_ns: Series | Window = field(init=False)
    out_frames: Series | Window = field(init=False)
    out_times: Series | Window = field(init=False)
    back_frames: Series | Window = field(init=False)
    back_times: Series | Window = field(init=False)
    unanswered: Series | Window = field(init=False)
    out_wkc: Rows | _WkcCounts = field(init=False)
    back_wkc: Rows | _WkcCounts = field(init=False)

    def __post_init__(self) -> None:
        new = self.series
        self.period_ns, self.round_trip_ns, self.unanswered = new(), new(), new()
        self.out_frames, self.out_times, self.back_frames, self.back_times = (
            new(),
            new(),
            new(),
            new(),
        )
        wkc = _WkcCounts if self.counted else Rows
        self.out_wkc = wkc(self.width)
        self.back_wkc = wkc(self.width)


def _mac(b: bytes) -> str:
    return ":".join(f"{x:02x}" for x in b)


_SKELETON: Final = slice(ethernet.HEADER_BYTES, ethernet.HEADER_BYTES + 3)  # header + cmd
_LAYOUT_MIN_DATAGRAMS: Final = 3  # below this the walk is as fast as the cached layout


@dataclass(frozen=True, slots=True)
class _Layout:
    """A frame layout seen before: one struct reads every header and working counter at once.

    A frame matches when its EtherCAT header and each datagram's command, ADP, ADO and
    length word (M bit included) are the layout's, so the walk would give the same pattern;
    only patterns without auto-increment or broadcast datagrams (whose ADP changes on the
    way) and without AL registers are cached.
    """

    pid: int
    head: struct.Struct  # "<H" + per datagram "BBHHHH{n}xH": 7 values each
    header: int
    cmds: tuple[int, ...]
    adps: tuple[int, ...]
    ados: tuple[int, ...]
    words: tuple[int, ...]

    @classmethod
    def of(cls, pid: int, dgs: list[_Walked], data: bytes) -> _Layout | None:
        """The layout of a walked frame, or None when its pattern cannot be cached."""
        if any(c not in _LOGICAL and c not in _CONFIGURED for c, *_ in dgs):
            return None
        fmt = "<H" + "".join(f"BBHHHH{n}xH" for _, _, _, _, n, _, _ in dgs)
        head = struct.Struct(fmt)
        values = head.unpack_from(data, ethernet.HEADER_BYTES)
        return cls(
            pid,
            head,
            values[0],
            values[1::7],
            values[3::7],
            values[4::7],
            values[5::7],
        )

    def match(self, data: bytes) -> tuple[int, ...] | None:
        """The unpacked values when ``data`` has this layout, else None."""
        values = self.head.unpack_from(data, ethernet.HEADER_BYTES)
        if (
            values[0] == self.header
            and values[1::7] == self.cmds
            and values[3::7] == self.adps
            and values[4::7] == self.ados
            and values[5::7] == self.words
        ):
            return values
        return None


# an outbound frame awaiting its return: (frame, time_ns, mac bit, interface, adps, wkcs)
_Sent = tuple[int, int, int, int, tuple[int, ...], tuple[int, ...]]


def _forwarded(sends: dict[bytes, _Sent], port: bytes, sent: int) -> bool:
    """Whether another master port has the same frame outstanding, sent before this port's
    (frame ``sent``): a closed ring's second copy, run unprocessed (module docstring). Before
    in capture order, not by time: the master's two sends may share a time stamp, and the
    first port's send, lost, is not the second copy of the other's."""
    return any(p != port and s[0] < sent for p, s in sends.items())


class EcatAnalyzer:
    """Feed EtherCAT frames in capture order (:meth:`feed`), then read :meth:`result` (at any
    time).

    ``window``: keep only the last ``window`` values of each series and events of each kind
    (module docstring); None keeps everything (``analyze``).
    """

    def __init__(self, expected_wkc: int | None = None, *, window: int | None = None) -> None:
        self.expected_wkc = expected_wkc
        self.window = window
        self.series: Callable[[], Series | Window] = (
            Series if window is None else lambda: Window(window)
        )
        self.frames = 0
        self.undecodable = 0
        self.patterns: dict[Pattern, int] = {}
        self.streams: dict[tuple[int, bytes], _Stream] = {}
        # (pattern, first idx) -> port -> (frame, time_ns, mac bit, interface, adps, wkcs)
        self.pending: dict[tuple[int, int], dict[bytes, _Sent]] = {}
        self.requested: deque[AlStateChange] = deque(maxlen=window)
        self.reported: dict[bool, deque[AlStateChange]] = {
            False: deque(maxlen=window),
            True: deque(maxlen=window),
        }
        self.al_last: dict[tuple[bool, str], int] = {}
        self.al_patterns: list[bool] = []  # per pattern: does it touch the AL registers?
        self.layouts: dict[tuple[int, bytes], _Layout] = {}

    def feed(self, frame: int, time_ns: int, interface: int, data: bytes) -> None:
        """One EtherCAT frame (the whole Ethernet frame) with its frame number, time, interface."""
        layout_key = (len(data), data[_SKELETON])
        layout = self.layouts.get(layout_key)
        dgs: list[_Walked] = []
        if layout is not None and (values := layout.match(data)) is not None:
            pid, idx0, wkcs = layout.pid, values[2], values[7::7]
        else:
            dgs = walk(data, ethernet.HEADER_BYTES)
            if not dgs:
                self.undecodable += 1
                return
            pattern = tuple(
                (c, -1, a | o << 16, n)
                if c in _LOGICAL
                else (c, a if c in _CONFIGURED else -1, o, n)
                for c, _, a, o, n, _, _ in dgs
            )
            known = self.patterns.get(pattern)
            if known is None:
                pid = self.patterns[pattern] = len(self.patterns)
                self.al_patterns.append(_touches_al(pattern))
                if len(dgs) >= _LAYOUT_MIN_DATAGRAMS and not self.al_patterns[pid]:
                    cached = _Layout.of(pid, dgs, data)
                    if cached is not None:
                        self.layouts[layout_key] = cached
            else:
                pid = known
            idx0, wkcs = dgs[0][1], tuple(d[6] for d in dgs)
        self.frames += 1
        bit = data[6] & RETURNED_MAC_BIT
        port = bytes((data[6] & ~RETURNED_MAC_BIT,)) + data[7:12]
        stream = self.streams.get((pid, port))
        if stream is None:
            stream = self.streams[(pid, port)] = _Stream(
                len(wkcs), self.series, self.window is not None
            )
        sends = self.pending.get((pid, idx0))
        if sends is None:
            sends = self.pending[(pid, idx0)] = {}
        al = self.al_patterns[pid]  # such patterns are never in self.layouts: dgs is walked
        before = sends.get(port)
        if before is not None and (
            before[2] != bit
            or before[3] != interface
            or (before[5] == wkcs and _forwarded(sends, port, before[0]))
        ):
            del sends[port]
            stream.returned += 1
            stream.round_trip_ns.append(time_ns - before[1])
            stream.back_frames.append(frame)
            stream.back_times.append(time_ns)
            stream.back_wkc.append(wkcs)
            if al:
                self._al_reads(dgs, data, frame, time_ns, True, before[4])
            return
        if before is not None:
            stream.unanswered.append(before[0])
        adps = tuple(d[2] for d in dgs) if al else ()
        sends[port] = (frame, time_ns, bit, interface, adps, wkcs)
        stream.frames += 1
        if stream.last_out_ns is not None:
            stream.period_ns.append(time_ns - stream.last_out_ns)
        stream.last_out_ns = time_ns
        stream.out_frames.append(frame)
        stream.out_times.append(time_ns)
        stream.out_wkc.append(wkcs)
        if al:
            self._al_writes(dgs, data, frame, time_ns)
            self._al_reads(dgs, data, frame, time_ns, False, adps)

    @staticmethod
    def _target(cmd: int, adp: int) -> str:
        if cmd in _CONFIGURED:
            return f"station {adp:#06x}"
        if cmd in _AUTO_INCREMENT:
            return f"position {(-adp) & 0xFFFF}"
        return "all"

    def _al_writes(self, dgs: list[_Walked], data: bytes, frame: int, time_ns: int) -> None:
        for cmd, _, adp, ado, n, at, _ in dgs:
            if cmd in _WRITES:
                value = _register(data, at, ado, n, AL_CONTROL)
                if value is not None:
                    self.requested.append(
                        AlStateChange(
                            frame,
                            time_ns,
                            "requested",
                            self._target(cmd, adp),
                            al_state_name(value),
                            value,
                        )
                    )

    def _al_reads(
        self,
        dgs: list[_Walked],
        data: bytes,
        frame: int,
        time_ns: int,
        returned: bool,
        adps: tuple[int, ...],
    ) -> None:
        for (cmd, _, _, ado, n, at, wkc), adp in zip(dgs, adps, strict=True):
            if cmd in _READS and wkc:
                value = _register(data, at, ado, n, AL_STATUS)
                if value is None:
                    continue
                target = self._target(cmd, adp)
                if self.al_last.get((returned, target)) != value:
                    self.al_last[(returned, target)] = value
                    self.reported[returned].append(
                        AlStateChange(
                            frame, time_ns, "reported", target, al_state_name(value), value
                        )
                    )

    def result(self) -> EcatAnalysis:
        """The statistics and events of everything fed so far."""
        by_id = {pid: p for p, pid in self.patterns.items()}
        ports = tuple(dict.fromkeys(port for _, port in self.streams))
        reports: list[PatternReport] = []
        deviations: list[WkcDeviation] = []
        any_returns = any(s.returned for s in self.streams.values())
        for index, ((pid, port), s) in enumerate(
            sorted(self.streams.items(), key=lambda kv: kv[0])
        ):
            pattern = by_id[pid]
            cyclic = any(cmd in _LOGICAL for cmd, *_ in pattern)
            use_back = s.returned > 0 or any_returns
            wkc = s.back_wkc if use_back else s.out_wkc
            steady = expected = _steady(wkc)
            if self.expected_wkc is not None:
                expected = tuple(
                    self.expected_wkc if cmd in _LOGICAL else e
                    for (cmd, *_), e in zip(pattern, expected, strict=True)
                )
            if isinstance(wkc, _WkcCounts):  # a window: how many, not which
                off = sum(
                    wkc.rows - counts[e] for counts, e in zip(wkc.columns, expected, strict=True)
                )
            else:
                off = self._deviations(wkc, s, use_back, index, expected, deviations)
            unanswered = s.unanswered.array() if s.returned else np.empty(0, np.int64)
            reports.append(
                PatternReport(
                    pattern=pattern,
                    text=pattern_text(pattern),
                    cyclic=cyclic,
                    port=_mac(port),
                    frames=s.frames,
                    returned=s.returned,
                    unanswered=tuple(int(x) for x in unanswered),
                    period=Summary.of(s.period_ns.array()),
                    period_ns=s.period_ns.array(),
                    round_trip=Summary.of(s.round_trip_ns.array()),
                    round_trip_ns=s.round_trip_ns.array(),
                    expected_wkc=tuple(expected),
                    steady_wkc=steady,
                    unanswered_count=s.unanswered.total if s.returned else 0,
                    wkc_deviation_count=off,
                )
            )
        deviations.sort(key=lambda d: (d.frame, d.datagram))
        al = sorted([*self.requested, *self.reported[any_returns]], key=lambda a: (a.frame, a.kind))
        return EcatAnalysis(
            frames=self.frames,
            undecodable=self.undecodable,
            patterns=tuple(reports),
            wkc_deviations=tuple(deviations),
            al_states=tuple(al),
            ports=tuple(_mac(p) for p in ports),
            al_current={
                target: al_state_name(value)
                for (returned, target), value in sorted(self.al_last.items())
                if returned == any_returns
            },
        )

    @staticmethod
    def _deviations(
        wkc: Rows,
        s: _Stream,
        use_back: bool,
        index: int,
        expected: tuple[int, ...],
        out: list[WkcDeviation],
    ) -> int:
        """Append the datagrams of ``wkc``'s frames off ``expected`` to ``out``; how many."""
        rows = wkc.array()
        if not len(rows):
            return 0
        numbers = s.back_frames.array() if use_back else s.out_frames.array()
        times = s.back_times.array() if use_back else s.out_times.array()
        bad_rows, bad_cols = np.nonzero(rows != np.asarray(expected, dtype=np.int64))
        for r, c in zip(bad_rows.tolist(), bad_cols.tolist(), strict=True):
            out.append(
                WkcDeviation(int(numbers[r]), int(times[r]), index, c, int(rows[r, c]), expected[c])
            )
        return len(bad_rows)


def _most_frequent(values: Sequence[int], counts: Sequence[int]) -> int:
    """The value counted most often, ties to the lower."""
    return min(zip(values, counts, strict=True), key=lambda vc: (-vc[1], vc[0]))[0]


def _steady(wkc: Rows | _WkcCounts) -> tuple[int, ...]:
    """Per datagram the most frequent working counter (ties to the lower); zeros for no frames."""
    if isinstance(wkc, _WkcCounts):
        return tuple(_most_frequent(list(c), list(c.values())) if c else 0 for c in wkc.columns)
    rows = wkc.array()
    if len(rows) == 0:
        return tuple(0 for _ in range(rows.shape[1]))
    out = []
    for column in rows.T:
        values, counts = np.unique(column, return_counts=True)
        out.append(_most_frequent(values.tolist(), counts.tolist()))
    return tuple(out)
