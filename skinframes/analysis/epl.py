"""EPL cycle analysis of a capture, frame by frame with state per node only.

What it measures (EPSG DS 301 V1.4.0 section 4.2.4, the isochronous cycle):

- the SoC period: the time from one SoC's timestamp to the next;
- the phases of each cycle (SoC to the next SoC), where the paper's model (eqs. 3-10) predicts
  them: the isochronous phase, from the SoC to the SoA (the polls); the asynchronous phase, from
  the SoA to the next SoC (ASnd, then idle); the part used, from the SoC to the cycle's last
  frame (what the model's cycle time predicts, but for that frame's own duration); and the
  headroom, from the last frame of the cycle to the next SoC (the part of the configured cycle
  length nothing used). Timestamps are the capture's, so each is measured from frame to frame as
  the capture stamped them;
- per CN, the response time: from a PReq's timestamp to the timestamp of the PRes from the
  node it polled. A PReq whose node sends no PRes before the MN's next frame (any message type
  from node 240) is a *missing* response; a PRes that comes after the PRes timeout (when the
  caller gives one, ``pres_timeout_ns``, measured like the response time) is a *late* one. The
  timeout is the MN's configuration (object 0x1F92 NMT_MNCNPResTimeout_AU32), not in the
  capture: without it no response is called late, and the response-time statistics show the
  outliers instead;
- the NMT state of every node over time: from each PRes and SoA (the MN's state) and from
  StatusResponse and IdentResponse (ASnd), every change with its frame and time;
- ASnd service counts, NMT commands and NMT requests, and the error entries of StatusResponses.

With a ``window`` (``skinframes watch``'s sliding window) the analyzer keeps only the last
``window`` values of each series and the last ``window`` events of each kind: the counts
(frames, polled, missing, late) still cover everything fed, the statistics and event lists the
window; memory then does not grow with the traffic.

Header fields are read at their offsets (DS 301 Table 22 common header, :mod:`.schemas`); the
few ASnd frames that carry events go through the full decoder.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Final

from skinframes import powerlink
from skinframes.analysis.stats import Series, Summary, Window
from skinframes.errors import DecodeError
from skinframes.powerlink.enums import (
    MessageType,
    NmtCommandId,
    NmtState,
    RequestedService,
    ServiceId,
)
from skinframes.powerlink.schemas import (
    ASND_HEADER_BYTES,
    ERROR_ENTRY_BYTES,
    PDO_SIZE_OFFSET,
    SRC_OFFSET,
    STATUS_RESPONSE_FIXED_BYTES,
)

__all__ = ["EplAnalysis", "EplAnalyzer", "EplEvent", "MissingResponse", "StateChange"]

MN: Final = powerlink.MN_NODE_ID
_MTYPE_MASK: Final = 0x7F  # MessageType bits 0-6; bit 7 reserved (DS 301 Table 23)
_DEST_OFFSET: Final = 1
_NMT_STATUS_OFFSET: Final = 3  # PRes and SoA: NMTStatus follows the common header
_SERVICE_ID_OFFSET: Final = 3  # ASnd: ServiceID follows the common header
_SOA_SERVICE_OFFSET: Final = 6  # SoA: RequestedServiceID (soa_schema)
_SOC: Final = int(MessageType.SOC)
_PREQ: Final = int(MessageType.PREQ)
_PRES: Final = int(MessageType.PRES)
_SOA: Final = int(MessageType.SOA)
_ASND: Final = int(MessageType.ASND)
# StatusResponse and IdentResponse: flags1, flags2, then NMTStatus (status_response_schema,
# ident_response_schema); a StatusResponse's error entries follow its fixed part.
_ASND_NMT_STATUS_OFFSET: Final = ASND_HEADER_BYTES + 2
_STATUS_RESPONSE: Final = int(ServiceId.STATUS_RESPONSE)
_IDENT_RESPONSE: Final = int(ServiceId.IDENT_RESPONSE)
_FIRST_ENTRY: Final = slice(
    STATUS_RESPONSE_FIXED_BYTES, STATUS_RESPONSE_FIXED_BYTES + ERROR_ENTRY_BYTES
)
_EVENT_SERVICES: Final = frozenset({ServiceId.NMT_REQUEST, ServiceId.NMT_COMMAND})


def state_name(value: int) -> str:
    """The NMT state's DS 301 name (``OPERATIONAL``), or its hex value when unknown."""
    try:
        return NmtState(value).name
    except ValueError:
        return f"{value:#04x}"


def _name(enum: type[ServiceId] | type[NmtCommandId], value: int) -> str:
    try:
        return enum(value).name
    except ValueError:
        return f"{value:#04x}"


@dataclass(frozen=True, slots=True)
class StateChange:
    """A node's NMT state as first seen, or changed (``before`` None: the first sighting)."""

    node: int
    frame: int  # Wireshark's frame number (1-based)
    time_ns: int
    before: str | None
    after: str
    source: str  # the message that carried it: PRes, SoA, StatusResponse, IdentResponse


@dataclass(frozen=True, slots=True)
class MissingResponse:
    """A PReq that got no PRes (or, with ``late``, a PRes after the timeout)."""

    node: int
    frame: int  # the PReq's frame number
    time_ns: int  # the PReq's time
    response_ns: int | None = None  # late responses: the response time


@dataclass(frozen=True, slots=True)
class EplEvent:
    """An NMT command or request, or a StatusResponse error entry."""

    frame: int
    time_ns: int
    node: int  # the node the event concerns (NMT command: its target; error entry: the sender)
    kind: str  # "nmt_command", "nmt_request", "error_entry"
    detail: str


@dataclass(slots=True)
class _Node:
    """What the analyzer keeps per CN."""

    response_ns: Series | Window
    sizes: Counter[int] = field(default_factory=Counter)
    polled: int = 0
    missing: int = 0
    late: int = 0
    unexpected: int = 0  # PRes without a PReq waiting for it


@dataclass(frozen=True, slots=True)
class EplAnalysis:
    """The EPL part of ``analyze``: statistics and events."""

    frames: int
    message_counts: dict[str, int]
    soc_period: Summary
    soc_period_ns: Any  # the periods themselves (int64 array), for plots and CSV
    responses: dict[int, Summary]
    response_ns: dict[int, Any]
    polled: dict[int, int]
    missing: tuple[MissingResponse, ...]
    late: tuple[MissingResponse, ...]
    missing_count: dict[int, int]  # per CN
    late_count: dict[int, int]
    unexpected: dict[int, int]
    pres_bytes: dict[int, int]
    states: tuple[StateChange, ...]
    asnd_services: dict[str, int]
    events: tuple[EplEvent, ...]
    asnd_invites: int
    soas: int
    pres_timeout_ns: int | None
    isochronous: Summary  # SoC to SoA, each whole cycle
    asynchronous: Summary  # SoA to the next SoC
    headroom: Summary  # the cycle's last frame to the next SoC
    used: Summary  # the SoC to the cycle's last frame
    # each node's NMT state now (the last one seen), by its DS 301 name
    current_states: dict[int, str] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The ``epl`` object of ``analyze --json`` (docs/interface.md)."""
        return {
            "frames": self.frames,
            "message_counts": self.message_counts,
            "soc_period": self.soc_period.to_json(),
            "phases": {
                "isochronous": self.isochronous.to_json(),
                "asynchronous": self.asynchronous.to_json(),
                "headroom": self.headroom.to_json(),
                "used": self.used.to_json(),
            },
            "pres_timeout_ns": self.pres_timeout_ns,
            "nodes": [
                {
                    "node": n,
                    "polled": self.polled.get(n, 0),
                    "pres_bytes": self.pres_bytes.get(n),
                    "response": self.responses[n].to_json(),
                    "missing": self.missing_count.get(n, 0),
                    "late": self.late_count.get(n, 0),
                    "unexpected": self.unexpected.get(n, 0),
                }
                for n in sorted(self.responses)
            ],
            "missing": [
                {"node": m.node, "frame": m.frame, "time_ns": m.time_ns} for m in self.missing
            ],
            "late": [
                {
                    "node": m.node,
                    "frame": m.frame,
                    "time_ns": m.time_ns,
                    "response_ns": m.response_ns,
                }
                for m in self.late
            ],
            "nmt_states": [
                {
                    "node": s.node,
                    "frame": s.frame,
                    "time_ns": s.time_ns,
                    "before": s.before,
                    "after": s.after,
                    "source": s.source,
                }
                for s in self.states
            ],
            "asnd_services": self.asnd_services,
            "events": [
                {
                    "frame": e.frame,
                    "time_ns": e.time_ns,
                    "node": e.node,
                    "kind": e.kind,
                    "detail": e.detail,
                }
                for e in self.events
            ],
        }


class EplAnalyzer:
    """Feed EPL frames in capture order (:meth:`feed`), then read :meth:`result` (at any time).

    ``window``: keep only the last ``window`` values of each series and events of each kind
    (module docstring); None keeps everything (``analyze``).
    """

    def __init__(self, pres_timeout_ns: int | None = None, *, window: int | None = None) -> None:
        self.pres_timeout_ns = pres_timeout_ns
        self.series: Callable[[], Series | Window] = (
            Series if window is None else lambda: Window(window)
        )
        self.frames = 0
        self.mtypes: Counter[int] = Counter()
        self.soc_period = self.series()
        self.last_soc_ns: int | None = None
        self.nodes: dict[int, _Node] = {}
        self.pending: tuple[int, int, int] | None = None  # (node, frame, time_ns) of a PReq
        self.missing: deque[MissingResponse] = deque(maxlen=window)
        self.late: deque[MissingResponse] = deque(maxlen=window)
        self.state: dict[int, int] = {}
        self.states: deque[StateChange] = deque(maxlen=window)
        self.services: Counter[int] = Counter()
        self.events: deque[EplEvent] = deque(maxlen=window)
        self.soas = 0
        self.invites = 0
        # the cycle under way: its SoA's time (None before it), the last frame's time
        self.soa_ns: int | None = None
        self.last_ns: int | None = None
        self.isochronous = self.series()
        self.asynchronous = self.series()
        self.headroom = self.series()
        self.used = self.series()

    def _node(self, node: int) -> _Node:
        n = self.nodes.get(node)
        if n is None:
            n = self.nodes[node] = _Node(self.series())
        return n

    def _observe(self, node: int, value: int, frame: int, time_ns: int, source: str) -> None:
        before = self.state.get(node)
        if before != value:
            self.state[node] = value
            self.states.append(
                StateChange(
                    node,
                    frame,
                    time_ns,
                    None if before is None else state_name(before),
                    state_name(value),
                    source,
                )
            )

    def feed(self, frame: int, time_ns: int, epl: bytes) -> None:
        """One EPL message (the bytes after the EtherType) with its frame number and time."""
        if len(epl) <= _NMT_STATUS_OFFSET:
            self.mtypes[-1] += 1  # too short for the header: counted, not analysed
            return
        self.frames += 1
        mtype = epl[0] & _MTYPE_MASK
        src = epl[SRC_OFFSET]
        self.mtypes[mtype] += 1
        last_ns, self.last_ns = self.last_ns, time_ns
        if src == MN and self.pending is not None:
            node, f, t = self.pending
            self.pending = None
            self.nodes[node].missing += 1
            self.missing.append(MissingResponse(node, f, t))
        if mtype == _PRES:
            if src == MN:
                return
            n = self.nodes.get(src) or self._node(src)
            if len(epl) >= PDO_SIZE_OFFSET + 2:
                n.sizes[epl[PDO_SIZE_OFFSET] | epl[PDO_SIZE_OFFSET + 1] << 8] += 1
            if self.state.get(src) != epl[_NMT_STATUS_OFFSET]:
                self._observe(src, epl[_NMT_STATUS_OFFSET], frame, time_ns, "PRes")
            if self.pending is not None and self.pending[0] == src:
                response_ns = time_ns - self.pending[2]
                n.response_ns.append(response_ns)
                if self.pres_timeout_ns is not None and response_ns > self.pres_timeout_ns:
                    n.late += 1
                    self.late.append(
                        MissingResponse(src, self.pending[1], self.pending[2], response_ns)
                    )
                self.pending = None
            else:
                n.unexpected += 1
        elif mtype == _SOC:
            if self.last_soc_ns is not None:
                self.soc_period.append(time_ns - self.last_soc_ns)
                if self.soa_ns is not None and last_ns is not None:  # a whole cycle
                    self.isochronous.append(self.soa_ns - self.last_soc_ns)
                    self.asynchronous.append(time_ns - self.soa_ns)
                    self.headroom.append(time_ns - last_ns)
                    self.used.append(last_ns - self.last_soc_ns)
            self.last_soc_ns = time_ns
            self.soa_ns = None
        elif mtype == _PREQ:
            dest = epl[_DEST_OFFSET]
            (self.nodes.get(dest) or self._node(dest)).polled += 1
            self.pending = (dest, frame, time_ns)
        elif mtype == _SOA:
            self.soas += 1
            if self.last_soc_ns is not None and self.soa_ns is None:
                self.soa_ns = time_ns  # the cycle's (a reduced cycle has no SoC: none)
            if self.state.get(src) != epl[_NMT_STATUS_OFFSET]:
                self._observe(src, epl[_NMT_STATUS_OFFSET], frame, time_ns, "SoA")
            if len(epl) > _SOA_SERVICE_OFFSET and epl[_SOA_SERVICE_OFFSET] not in (
                RequestedService.NO_SERVICE,
            ):
                self.invites += 1
        elif mtype == _ASND:
            service = epl[_SERVICE_ID_OFFSET]
            self.services[service] += 1
            if service in (_STATUS_RESPONSE, _IDENT_RESPONSE):
                if len(epl) > _ASND_NMT_STATUS_OFFSET:
                    source = "StatusResponse" if service == _STATUS_RESPONSE else "IdentResponse"
                    self._observe(src, epl[_ASND_NMT_STATUS_OFFSET], frame, time_ns, source)
                if service == _STATUS_RESPONSE and any(epl[_FIRST_ENTRY]):
                    self._asnd(frame, time_ns, epl)  # error entries: the full decoder reads them
            elif service in _EVENT_SERVICES:
                self._asnd(frame, time_ns, epl)

    def _asnd(self, frame: int, time_ns: int, epl: bytes) -> None:
        """The rare ASnd frames that carry events, through the full decoder."""
        try:
            message, _, _ = powerlink.decode(epl, strict=False)
        except DecodeError:
            return
        if not isinstance(message, powerlink.ASnd):
            return
        service = message.service
        src, dest = message.src, message.dest
        if isinstance(service, powerlink.StatusResponse):
            for e in service.error_entries:
                self.events.append(
                    EplEvent(
                        frame,
                        time_ns,
                        src,
                        "error_entry",
                        f"entry type {e.entry_type:#06x}, error code {e.error_code:#06x}",
                    )
                )
        elif isinstance(service, powerlink.NmtCommand):
            name = _name(NmtCommandId, service.command_id)
            self.events.append(EplEvent(frame, time_ns, dest, "nmt_command", name))
        elif isinstance(service, powerlink.NmtRequest):
            name = _name(NmtCommandId, service.requested_command_id)
            self.events.append(
                EplEvent(
                    frame,
                    time_ns,
                    service.requested_command_target,
                    "nmt_request",
                    f"{name} requested by node {src}",
                )
            )

    def result(self) -> EplAnalysis:
        """The statistics and events of everything fed so far."""
        names = {int(m): m.name for m in MessageType}
        arrays = {n: s.response_ns.array() for n, s in self.nodes.items()}
        return EplAnalysis(
            frames=self.frames,
            message_counts={
                names.get(k, f"{k:#04x}" if k >= 0 else "short"): v
                for k, v in sorted(self.mtypes.items())
            },
            soc_period=Summary.of(self.soc_period.array()),
            soc_period_ns=self.soc_period.array(),
            responses={n: Summary.of(a) for n, a in arrays.items()},
            response_ns=arrays,
            polled={n: s.polled for n, s in self.nodes.items()},
            missing=tuple(self.missing),
            late=tuple(self.late),
            missing_count={n: s.missing for n, s in self.nodes.items()},
            late_count={n: s.late for n, s in self.nodes.items()},
            unexpected={n: s.unexpected for n, s in self.nodes.items() if s.unexpected},
            pres_bytes={n: s.sizes.most_common(1)[0][0] for n, s in self.nodes.items() if s.sizes},
            states=tuple(self.states),
            asnd_services={_name(ServiceId, k): v for k, v in sorted(self.services.items())},
            events=tuple(self.events),
            asnd_invites=self.invites,
            soas=self.soas,
            pres_timeout_ns=self.pres_timeout_ns,
            isochronous=Summary.of(self.isochronous.array()),
            asynchronous=Summary.of(self.asynchronous.array()),
            headroom=Summary.of(self.headroom.array()),
            used=Summary.of(self.used.array()),
            current_states={n: state_name(v) for n, v in sorted(self.state.items())},
        )
