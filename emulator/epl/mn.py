"""The emulated Managing Node: it boots real CNs as a CDC says and polls them (EPSG DS 301 V1.4.0).

:class:`EplMn` knows what to send and what the CNs' frames mean; when frames go out and how
long it waits for answers is the loop's (:mod:`.mn_live`). Each CN's boot (the MN's NMT
boot-up of a CN; the kit's README, "What the oPL MN sends a CN at boot") runs
through :class:`Step`:

1. the MN's NMTResetNode to all (ASnd NMTCommand 0x28 to 255, once, :meth:`EplMn.reset_all`);
2. ``IDENTIFY``: SoA IdentRequest until the CN's IdentResponse (its MAC is learnt from it);
3. ``STATUS``: SoA StatusRequest with ER (exception reset) set until its StatusResponse shows
   EC (exception clear), then with ER clear until EC is clear (the error signalling's reset;
   the kit's README, step 4), at most ``STATUS_REQUESTS`` times;
4. ``CONFIGURE``: the SDO writes of the node's 0x1F22 block (:class:`~.sdo_client.SdoClient`;
   only 0x1006 when the IdentResponse's ConfDate/ConfTime equal 0x1F26/0x1F27, as
   openPOWERLINK's MN skips the download then); then NMTResetConfiguration (0x2A), and the CN
   is identified again (2, 3);
5. ``START``: NMTEnableReadyToOperate (0x24) once the CN reports PreOperational2, NMTStartNode
   (0x21) once it reports ReadyToOperate; ``OPERATIONAL`` once it reports Operational.

An SDO abort or a broken connection sends NMTResetNode to that CN and starts its boot again
(counted as ``boot_restarts``), as openPOWERLINK's MN does.

The asynchronous slot of each cycle carries one frame: the MN's own ASnd
(an NMT command after SoA NMTRequestInvite, an SDO frame after SoA UnspecifiedInvite, both
addressed to the MN, 240, as openPOWERLINK sends them), or a CN's answer to SoA IdentRequest,
StatusRequest or UnspecifiedInvite; the CNs take turns (:meth:`EplMn.async_slot`). A CN is polled
(PReq) once it is identified; a PReq without a PRes within the CN's PRes timeout (0x1F92) is a
loss once the CN has answered one since it was identified, and DS 301's threshold counter of
losses is kept against 0x1C09 (reaching it is counted; openPOWERLINK's MN would reset the CN).
"""

from __future__ import annotations

import enum
import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Final

from emulator.epl.mn_config import MnConfig, NodeConfig
from emulator.epl.sdo_client import Phase, SdoClient
from skinframes import ethernet
from skinframes.dispatch import decode_frame
from skinframes.errors import DecodeError
from skinframes.powerlink import (
    BROADCAST_NODE_ID,
    MN_NODE_ID,
    ASnd,
    EplMessage,
    IdentResponse,
    NmtCommand,
    NmtCommandId,
    NmtState,
    PReq,
    PReqFlag,
    PRes,
    RequestedService,
    Sdo,
    SoA,
    SoAFlag,
    SoC,
    StatusResponse,
    frame,
    node_mac,
)
from skinframes.powerlink.cdc import CdcEntry

NS_PER_S: Final = 1_000_000_000
# A command the CN does not act on is sent again after this many cycles (a lost frame)
RESEND_CYCLES: Final = 20
# An SDO transfer whose answer has not come after this many invitations fails (the CN's boot
# starts again)
SDO_PATIENCE: Final = 50
STATUS_REQUESTS: Final = 20  # then the boot goes on without the error signalling's reset
EC_FLAG: Final = 0x08  # StatusResponse flags1: exception clear (DS 301 7.3.3.3.1)
LOSS_STEP: Final = 8  # DS 301 threshold counters: +8 per error, -1 per good cycle
KEEP_TIMES: Final = 200_000  # PReq -> PRes times kept per CN for the median and p99


class Step(enum.Enum):
    """Where the boot of one CN is, as the MN sees it."""

    IDENTIFY = "identify"
    STATUS = "status"
    CONFIGURE = "configure"
    START = "start"
    OPERATIONAL = "operational"


@dataclass
class NodeRun:
    """One CN: its boot, what it reported, its PReq -> PRes times and losses."""

    config: NodeConfig
    mac: bytes = b""
    step: Step = Step.IDENTIFY
    configured: bool = False
    state: NmtState | None = None  # the NMT state it last reported
    rs: int = 0  # the requests to send its last PRes announced
    answered: bool = False  # a PRes came since it was identified
    sdo: SdoClient | None = None
    sdo_invites: int = 0
    exception_reset: bool = True  # the ER of its next StatusRequest
    status_requests: int = 0
    commands: list[int] = field(default_factory=list)  # NMT commands to send it
    sent_command: tuple[int, int] | None = None  # (command, cycle)
    operational_ns: int | None = None  # when it first reported Operational (MN clock)
    polls: int = 0
    responses: int = 0
    losses: int = 0
    late: int = 0
    loss_counter: int = 0  # DS 301's threshold counter of PRes losses
    response_ns: list[int] = field(default_factory=list)  # the first KEEP_TIMES
    worst_ns: int | None = None
    pres_payload: bytes = b""
    counts: Counter[str] = field(default_factory=Counter)

    def __post_init__(self) -> None:
        self.mac = node_mac(self.config.node_id)

    @property
    def node_id(self) -> int:
        """The CN's node id."""
        return self.config.node_id

    @property
    def polled(self) -> bool:
        """Whether the MN sends it a PReq each cycle: once identified (again after a reset)."""
        return self.step is not Step.IDENTIFY

    def restart(self, *, configured: bool) -> None:
        """Identify it again (after a reset command)."""
        self.step = Step.IDENTIFY
        self.configured = configured
        self.answered = False
        self.exception_reset = True
        self.status_requests = 0
        self.sdo = None
        self.sent_command = None


def percentile_us(times_ns: list[int], q: float) -> float | None:
    """The value at rank ceil(q * n) of the sorted times (the nearest-rank percentile), in us."""
    if not times_ns:
        return None
    ordered = sorted(times_ns)
    rank = max(1, math.ceil(q * len(ordered)))
    return round(ordered[rank - 1] / 1000, 1)


class EplMn:
    """The MN of the CNs ``config`` names."""

    def __init__(self, config: MnConfig) -> None:
        self.config = config
        self.nodes = [NodeRun(n) for n in config.nodes]
        self.by_id = {n.node_id: n for n in self.nodes}
        self.counts: Counter[str] = Counter()
        self.isochronous = False
        self.cycles = 0
        self._turn = 0  # the CN whose turn it is in the asynchronous slot
        self._src_mac = node_mac(MN_NODE_ID)

    # --- frames ----------------------------------------------------------------------------
    @property
    def nmt_state(self) -> NmtState:
        """The MN's own state: PreOperational1 in the reduced cycle, then Operational (its CNs
        are not mandatory: it does not wait for them, as openPOWERLINK's MN with 0x1F81 = 7)."""
        return NmtState.OPERATIONAL if self.isochronous else NmtState.PRE_OPERATIONAL_1

    def soc(self, net_time_ns: int, relative_us: int) -> bytes:
        """The SoC of a cycle, with the MN's NetTime and RelativeTime."""
        s, ns = divmod(net_time_ns, NS_PER_S)
        rel = relative_us & 0xFFFFFFFFFFFFFFFF
        return frame(SoC(net_time_s=s, net_time_ns=ns, relative_time_us=rel)).to_bytes()

    def preq(self, node: NodeRun) -> bytes:
        """The PReq to ``node`` (to its MAC as its IdentResponse came from), its outputs zero,
        RD set since the MN is Operational."""
        flags = PReqFlag.RD if self.isochronous else 0
        message = PReq(node.node_id, bytes(node.config.preq_payload_bytes), flags1=flags)
        return ethernet.EthernetFrame(node.mac, self._src_mac, message).to_bytes()

    def _soa(self, service: int, target: int, flags1: int = 0) -> bytes:
        soa = SoA(service, target, nmt_status=self.nmt_state, flags1=flags1)
        return frame(soa).to_bytes()

    def _asnd(self, service: NmtCommand | Sdo, dest: int) -> bytes:
        return frame(ASnd(service, dest=dest)).to_bytes()

    def reset_all(self) -> tuple[bytes, bytes]:
        """SoA NMTRequestInvite to the MN and its ASnd NMTResetNode to every node."""
        command = NmtCommand(NmtCommandId.RESET_NODE)
        return (
            self._soa(RequestedService.NMT_REQUEST_INVITE, MN_NODE_ID),
            self._asnd(command, BROADCAST_NODE_ID),
        )

    # --- the asynchronous slot -------------------------------------------------------------
    def async_slot(self) -> tuple[bytes, bytes | None, int | None]:
        """This cycle's SoA, the MN's ASnd after it (or None), and the CN invited to send (or
        None): the first CN from this turn on that has something to do."""
        count = len(self.nodes)
        for k in range(count):
            node = self.nodes[(self._turn + k) % count]
            slot = self._node_slot(node)
            if slot is not None:
                self._turn = (self._turn + k + 1) % count
                return slot
        return self._soa(RequestedService.NO_SERVICE, 0), None, None

    def _node_slot(self, node: NodeRun) -> tuple[bytes, bytes | None, int | None] | None:
        self._plan_commands(node)
        if node.commands:
            command = node.commands.pop(0)
            node.sent_command = (command, self.cycles)
            asnd = self._asnd(NmtCommand(command), node.node_id)
            return self._soa(RequestedService.NMT_REQUEST_INVITE, MN_NODE_ID), asnd, None
        if node.step is Step.IDENTIFY:
            return self._soa(RequestedService.IDENT_REQUEST, node.node_id), None, node.node_id
        if node.step is Step.STATUS:
            node.status_requests += 1
            flags = SoAFlag.ER if node.exception_reset else 0
            soa = self._soa(RequestedService.STATUS_REQUEST, node.node_id, flags)
            return soa, None, node.node_id
        sdo = node.sdo
        if node.step is Step.CONFIGURE and sdo is not None:
            if sdo.waiting or node.rs:
                node.sdo_invites += 1
                if node.sdo_invites > SDO_PATIENCE:
                    self._restart(node, "sdo_timeouts")
                    return self._node_slot(node)
                invite = self._soa(RequestedService.UNSPECIFIED_INVITE, node.node_id)
                return invite, None, node.node_id
            out = sdo.next_frame()
            if out is not None:
                node.sdo_invites = 0
                asnd = self._asnd(out, node.node_id)
                return self._soa(RequestedService.UNSPECIFIED_INVITE, MN_NODE_ID), asnd, None
            self._configured(node)
            return self._node_slot(node)
        if node.rs:  # a request the CN announced, outside a transfer: let it send
            return self._soa(RequestedService.UNSPECIFIED_INVITE, node.node_id), None, node.node_id
        return None

    def _plan_commands(self, node: NodeRun) -> None:
        """The NMT command that moves a configured CN on, from the state it reports."""
        if node.step is not Step.START or node.commands:
            return
        if node.state == NmtState.PRE_OPERATIONAL_2:
            wanted = NmtCommandId.ENABLE_READY_TO_OPERATE
        elif node.state == NmtState.READY_TO_OPERATE:
            wanted = NmtCommandId.START_NODE
        else:
            return
        sent = node.sent_command
        if sent is None or sent[0] != wanted or self.cycles - sent[1] >= RESEND_CYCLES:
            if sent is not None and sent[0] == wanted:
                node.counts["nmt_commands_repeated"] += 1
            node.commands.append(wanted)

    def _configured(self, node: NodeRun) -> None:
        """The SDO transfers ended: NMTResetConfiguration on success, else a restart."""
        sdo = node.sdo
        assert sdo is not None
        node.counts["sdo_writes"] += sdo.done
        if sdo.phase is not Phase.DONE:
            if sdo.abort_code is not None:
                node.counts["sdo_aborts"] += 1
            self._restart(node, "sdo_failures")
            return
        node.restart(configured=True)
        node.commands.append(NmtCommandId.RESET_CONFIGURATION)

    def _restart(self, node: NodeRun, why: str) -> None:
        node.counts[why] += 1
        node.counts["boot_restarts"] += 1
        node.restart(configured=False)
        node.commands = [NmtCommandId.RESET_NODE]

    # --- what comes back -------------------------------------------------------------------
    def receive(self, data: bytes, now_ns: int) -> EplMessage | None:
        """Take one received frame; the EPL message it carries (None: not EPL, unreadable)."""
        if len(data) < ethernet.HEADER_BYTES or data[12:14] != b"\x88\xab":
            self.counts["not_epl"] += 1
            return None
        try:
            message = decode_frame(data).payload
        except DecodeError:
            self.counts["malformed"] += 1
            return None
        if isinstance(message, PRes):
            node = self.by_id.get(message.src)
            if node is None:
                self.counts["pres_unknown_node"] += 1
            else:
                self._reported(node, message.nmt_status, now_ns)
                node.rs = message.rs
                node.answered = True
                node.pres_payload = bytes(message.payload)
        elif isinstance(message, ASnd):
            self._asnd_received(message, data[6:12], now_ns)
        elif isinstance(message, SoC | SoA | PReq):
            self.counts["mn_frames_from_another"] += 1
        else:
            self.counts["epl_other"] += 1
        return message if isinstance(message, EplMessage) else None

    def _asnd_received(self, asnd: ASnd, src_mac: bytes, now_ns: int) -> None:
        node = self.by_id.get(asnd.src)
        if node is None:
            self.counts["asnd_unknown_node"] += 1
            return
        service = asnd.service
        if isinstance(service, IdentResponse):
            node.mac = src_mac
            self._reported(node, service.nmt_status, now_ns)
            if node.step is Step.IDENTIFY:
                node.step = Step.STATUS
                node.answered = False
                if not node.configured:
                    node.sdo = SdoClient(self._writes(node, service))
        elif isinstance(service, StatusResponse):
            self._reported(node, service.nmt_status, now_ns)
            if node.step is Step.STATUS:
                self._status(node, bool(service.flags1 & EC_FLAG))
        elif isinstance(service, Sdo):
            if node.sdo is not None and asnd.dest == MN_NODE_ID:
                node.sdo_invites = 0
                node.sdo.receive(service)
            else:
                node.counts["sdo_unexpected"] += 1
        else:
            node.counts["asnd_other"] += 1

    def _status(self, node: NodeRun, ec: bool) -> None:
        """A StatusResponse in the STATUS step: ER set until EC, then clear until EC clears."""
        if node.exception_reset and ec:
            node.exception_reset = False
            return
        if node.exception_reset or ec:
            if node.status_requests < STATUS_REQUESTS:
                return
            node.counts["error_signalling_not_reset"] += 1
        node.step = Step.START if node.configured else Step.CONFIGURE

    def _writes(self, node: NodeRun, ident: IdentResponse) -> list[CdcEntry]:
        """The node's 0x1F22 block; only its 0x1006 when its ConfDate/ConfTime are the CDC's."""
        c = node.config
        same = (ident.verify_conf_date, ident.verify_conf_time) == (c.conf_date, c.conf_time)
        if same:
            node.counts["configuration_kept"] += 1
            return [w for w in c.writes if (w.index, w.subindex) == (0x1006, 0)]
        return list(c.writes)

    def _reported(self, node: NodeRun, state: int, now_ns: int) -> None:
        try:
            node.state = NmtState(state)
        except ValueError:
            node.counts["unknown_nmt_state"] += 1
            return
        if node.step is Step.START and node.state == NmtState.OPERATIONAL:
            node.step = Step.OPERATIONAL
            if node.operational_ns is None:
                node.operational_ns = now_ns
        elif node.step is Step.OPERATIONAL and node.state != NmtState.OPERATIONAL:
            node.counts["left_operational"] += 1
            node.step = Step.START

    # --- PReq -> PRes ----------------------------------------------------------------------
    def polled(self) -> list[NodeRun]:
        """The CNs polled this cycle, in node order."""
        return [n for n in self.nodes if n.polled]

    def pres_answered(self, node: NodeRun, took_ns: int) -> None:
        """``node`` answered its PReq after ``took_ns``: a response, or past its PRes timeout
        (the loop may read it late) a loss and late; its time is kept either way."""
        node.polls += 1
        if len(node.response_ns) < KEEP_TIMES:
            node.response_ns.append(took_ns)
        node.worst_ns = max(took_ns, node.worst_ns or 0)
        if took_ns <= node.config.pres_timeout_ns:
            node.responses += 1
            node.loss_counter = max(0, node.loss_counter - 1)
        else:
            node.late += 1
            self._lost(node)

    def pres_late(self, node: NodeRun) -> None:
        """A PRes from ``node`` came after its timeout (counted as a loss then)."""
        node.late += 1

    def pres_missing(self, node: NodeRun) -> None:
        """No PRes from ``node`` within its timeout: a loss once it answered before."""
        node.polls += 1
        if node.answered:
            self._lost(node)

    @staticmethod
    def _lost(node: NodeRun) -> None:
        """A loss of PRes, and DS 301's threshold counter (0x1C09): where it reaches the
        threshold openPOWERLINK's MN resets the CN (E_DLL_LOSS_PRES_TH); this MN counts it."""
        node.losses += 1
        threshold = node.config.loss_of_pres_threshold
        if threshold:
            node.loss_counter += LOSS_STEP
            if node.loss_counter >= threshold:
                node.loss_counter = 0
                node.counts["loss_of_pres_threshold"] += 1

    def unidentified(self) -> bool:
        """Whether a CN waits to be identified."""
        return any(n.step is Step.IDENTIFY for n in self.nodes)

    def operational(self) -> bool:
        """Whether every CN reports Operational."""
        return all(n.step is Step.OPERATIONAL for n in self.nodes)

    def report(self, started_ns: int) -> dict[str, object]:
        """Per CN: the state reached, when, PReq -> PRes times, losses; what was counted."""
        cns = []
        for n in self.nodes:
            times = n.response_ns
            when = n.operational_ns
            cns.append(
                {
                    "node_id": n.node_id,
                    "state": n.state.name if n.state is not None else None,
                    "operational_s": None if when is None else round((when - started_ns) / 1e9, 3),
                    "polls": n.polls,
                    "responses": n.responses,
                    "losses": n.losses,
                    "late": n.late,
                    "response_us_median": percentile_us(times, 0.5),
                    "response_us_p99": percentile_us(times, 0.99),
                    "response_us_worst": None
                    if n.worst_ns is None
                    else round(n.worst_ns / 1000, 1),
                    "pres_payload": n.pres_payload.hex(),
                    "counts": dict(sorted(n.counts.items())),
                }
            )
        return {"counts": dict(sorted(self.counts.items())), "cns": cns}
