"""One emulated skin patch as an EPL Controlled Node: its data link layer (DS 301 4.2.4, 4.6).

A :class:`SkinCn` owns its object dictionary (:mod:`.od`), its NMT state machine (:mod:`.nmt`)
and its SDO server (:mod:`.sdo_server`), and keeps the frames it answers with ready to send:

- ``pres_frame``: the PRes (DS 301 4.6.1.1.4) with the TPDO 0x1A00 mapping's objects, sent in
  PreOperational2, ReadyToOperate and Operational (DS 301 7.1.4), RD
  set only in Operational, PR/RS saying what waits in the asynchronous queue;
- ``ident_frame`` and ``status_frames``: IdentResponse (7.3.3.2.1) and StatusResponse
  (7.3.3.3.1, 72 frame bytes), answers to the SoA IdentRequest and StatusRequest, the latter
  with EC, EN and the error entries of :mod:`.errsig` (one frame per EC/EN pair, since a
  StatusRequest's ER can change EC and EN on the fast path);
- the asynchronous queue: SDO answers sent one per SoA UnspecifiedInvite to this node.

They are rebuilt (:meth:`SkinCn.rebuild`) when something they carry changes, so a live loop can
answer a PReq or SoA with a prepared frame before it does anything else; :meth:`SkinCn.after`
then lets the node react to the frame (state changes, SDO, PDO data).
"""

from __future__ import annotations

import ipaddress
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Final

from emulator.epl.errsig import E_DLL_LOSS_SOC_TH, ErrorSignalling
from emulator.epl.nmt import CYCLIC_STATES, CnStateMachine, Reset, addressed
from emulator.epl.od import (
    INPUTS_INDEX,
    MAP_INDEX_RX,
    MAP_INDEX_TX,
    OUTPUTS_INDEX,
    TAXELS_INDEX,
    Mapped,
    ObjectDictionary,
)
from emulator.epl.sdo_server import SdoServer
from emulator.errors import SdoAbortError
from skinframes import ethernet
from skinframes.powerlink import (
    ASnd,
    IdentResponse,
    NmtCommand,
    NmtState,
    PReq,
    PRes,
    PResFlag,
    RequestedService,
    Sdo,
    SoA,
    SoAFlag,
    StatusResponse,
    frame,
    pack_pres,
)
from skinframes.powerlink.enums import BROADCAST_NODE_ID, MN_NODE_ID

# PR of a waiting SDO answer: PRIO_GENERIC_REQUEST = 3 (DS 301 PR values; openPOWERLINK
# oplk/dll.h kDllAsyncReqPrioGeneric; its CN sends PR 3 with RS 1 for one, seen on the wire)
PRIO_GENERIC_REQUEST: Final = 3
# DS 301 threshold counters: +8 per error, -1 per cycle without (openPOWERLINK errhndk.c)
LOSS_STEP: Final = 8
MAX_RS: Final = 7  # RS is 3 bits
ASYNC_QUEUE_FRAMES: Final = 16  # frames beyond wait nowhere: dropped and counted
EC_FLAG: Final = 0x08  # IdentResponse/StatusResponse flags1 (DS 301 7.3.3.3.1)
EN_FLAG: Final = 0x10  # PRes and StatusResponse flags1 (DS 301 4.6.1.1.4, 7.3.3.3.1)
# DS 301 5.1.2: a CN's IP address is 192.168.100.<node id>/24, gateway 192.168.100.254
SUBNET: Final = ipaddress.IPv4Address("255.255.255.0")
GATEWAY: Final = ipaddress.IPv4Address("192.168.100.254")
PDO_STATES: Final = frozenset(
    {NmtState.PRE_OPERATIONAL_2, NmtState.READY_TO_OPERATE, NmtState.OPERATIONAL}
)
DLL_STATES: Final = PDO_STATES | {NmtState.PRE_OPERATIONAL_1, NmtState.STOPPED}


def ip_address(node_id: int) -> ipaddress.IPv4Address:
    """The node's IP address (DS 301 5.1.2: 192.168.100.<node id>)."""
    return ipaddress.IPv4Address(f"192.168.100.{node_id}")


@dataclass
class SkinCn:
    """One skin patch as CN ``node_id`` with ``taxel_bytes`` taxel bytes (0x6100/1)."""

    node_id: int
    taxel_bytes: int
    od: ObjectDictionary = field(init=False)
    nmt: CnStateMachine = field(init=False)
    sdo: SdoServer = field(init=False)
    counts: Counter[str] = field(default_factory=Counter)
    pres_frame: bytes = b""
    ident_frame: bytes = b""
    status_frames: dict[tuple[bool, bool], bytes] = field(default_factory=dict)  # (EC, EN)
    errsig: ErrorSignalling = field(default_factory=ErrorSignalling)
    flags_stale: bool = False  # EN changed on the fast path: the PRes follows after the frame
    last_soc_net_ns: int = 0  # the last SoC's NetTime, and when it came (host clock)
    soc_seen_ns: int = 0
    queue: deque[bytes] = field(default_factory=deque)
    taxels: bytes = b""
    sample_number: int = 0
    last_soc_ns: int = 0
    _pres_header: bytes = b""
    _not_active_ns: int = 0
    _tpdo: tuple[Mapped, ...] = ()
    _rpdo: tuple[Mapped, ...] = ()

    def __post_init__(self) -> None:
        self._pres_header = frame(PRes(self.node_id)).to_bytes()[: ethernet.HEADER_BYTES]
        self.od = ObjectDictionary(self.node_id, self.taxel_bytes)
        self.taxels = bytes(self.taxel_bytes)
        self.sdo = SdoServer(self.od)
        self.nmt = CnStateMachine(on_reset=self._on_reset)
        self.nmt.power_on()
        self.rebuild()

    # --- resets and mappings -----------------------------------------------------------------
    def _on_reset(self, reset: Reset) -> None:
        """What each reset does to the node (DS 301 7.1.3.2)."""
        if reset is Reset.APPLICATION:
            self.od.reset_application()
        elif reset is Reset.COMMUNICATION:
            self.od.reset_communication()
        self.sdo.close()
        self.queue.clear()
        self.errsig.reset()
        self._publish_inputs()
        self._configure()  # NMT_GS_RESET_CONFIGURATION: the mappings take effect

    def _configure(self) -> None:
        try:
            self._tpdo = self.od.layout(MAP_INDEX_TX)
            self._rpdo = self.od.layout(MAP_INDEX_RX)
        except SdoAbortError:  # a limit lowered after the mapping was enabled: map nothing
            self.counts["pdo_mapping_invalid"] += 1
            self._tpdo = self._rpdo = ()

    def _publish_inputs(self) -> None:
        self.od.set_value(TAXELS_INDEX, 1, self.taxels)
        self.od.set_value(INPUTS_INDEX, 1, bytes((self.sample_number & 0xFF,)))

    def publish(self, taxels: bytes, number: int | None = None) -> None:
        """A new taxel sample: 0x6100/1, and its number (default: one more than the last) at
        0x6000/1; the PRes follows."""
        self.taxels = taxels
        self.sample_number = self.sample_number + 1 if number is None else number
        self._publish_inputs()
        self._build_pres()

    # --- the prepared frames -----------------------------------------------------------------
    def _flags2(self) -> int:
        rs = min(len(self.queue), MAX_RS)
        return (PRIO_GENERIC_REQUEST << 3 | rs) if rs else 0

    def _build_pres(self) -> None:
        state = self.nmt.state
        payload = b""
        if state in PDO_STATES and self._tpdo:
            size = max(m.offset_bytes + m.length_bytes for m in self._tpdo)
            buf = bytearray(size)
            for m in self._tpdo:
                value = self.od.entries[(m.index, m.subindex)].value
                buf[m.offset_bytes : m.offset_bytes + m.length_bytes] = value[: m.length_bytes]
            payload = bytes(buf)
        flags1 = PResFlag.RD if state == NmtState.OPERATIONAL else 0
        if self.errsig.en:
            flags1 |= EN_FLAG
        # The frame spans PResActPayloadLimit (0x1F98/5) payload bytes, zeros after the mapped
        # ones, and no more: an MN drops a PRes longer than its limit for the node (0x1F8D;
        # openPOWERLINK dllkframe.c checks the frame length too, Ethernet padding included), so
        # it is not padded to 60 bytes here (a NIC pads it on the wire; veth does not). Built by
        # the struct fast path (skinframes.powerlink.pack_pres, tested equal to pres_schema)
        # behind the Ethernet header, which never changes.
        fill = bytes(max(0, self.od.u(0x1F98, 5) - len(payload)))
        body = pack_pres(self.node_id, payload, BROADCAST_NODE_ID, state, flags1, self._flags2())
        self.pres_frame = self._pres_header + body + fill

    def rebuild(self) -> None:
        """Prepare PRes, IdentResponse and both StatusResponses from the present state."""
        self._build_pres()
        od, state, flags2 = self.od, self.nmt.state, self._flags2()
        ident = IdentResponse(
            nmt_status=state,
            flags2=flags2,
            feature_flags=od.u(0x1F82, 0),
            mtu=od.u(0x1F98, 8),
            poll_in_size=od.u(0x1F98, 4),
            poll_out_size=od.u(0x1F98, 5),
            response_time=od.u(0x1F98, 3),
            device_type=od.u(0x1000, 0),
            vendor_id=od.u(0x1018, 1),
            product_code=od.u(0x1018, 2),
            revision_number=od.u(0x1018, 3),
            serial_number=od.u(0x1018, 4),
            verify_conf_date=od.u(0x1020, 1),
            verify_conf_time=od.u(0x1020, 2),
            ip_address=ip_address(self.node_id),
            subnet_mask=SUBNET,
            default_gateway=GATEWAY,
            host_name=f"{self.node_id:02X}-{od.u(0x1018, 1):08X}".encode().ljust(32, b"\0"),
        )
        self.ident_frame = self._asnd(ident, BROADCAST_NODE_ID)
        entries = tuple(self.errsig.entries)
        self.status_frames = {
            (ec, en): self._asnd(
                StatusResponse(
                    nmt_status=state,
                    flags1=(EC_FLAG if ec else 0) | (EN_FLAG if en else 0),
                    flags2=flags2,
                    error_entries=entries,
                ),
                BROADCAST_NODE_ID,
            )
            for ec in (False, True)
            for en in (False, True)
        }

    def _asnd(self, service: IdentResponse | StatusResponse | Sdo, dest: int) -> bytes:
        return frame(ASnd(service, dest=dest, src=self.node_id)).to_bytes()

    @property
    def pres_frame_ready(self) -> bool:
        """Whether a PReq is answered: in PreOperational2, ReadyToOperate, Operational."""
        return self.nmt.state in PDO_STATES

    @property
    def dll_active(self) -> bool:
        """Whether the node answers SoA invitations: from PreOperational1 on (DS 301 7.1.4)."""
        return self.nmt.state in DLL_STATES

    def invited(self, service: int, soa_flags1: int) -> bytes | None:
        """The ASnd this node sends in the asynchronous slot a SoA gives it (or None).

        ``service`` is the SoA's RequestedServiceID, ``soa_flags1`` its flags (ER).
        """
        if service == RequestedService.IDENT_REQUEST:
            return self.ident_frame
        if service == RequestedService.STATUS_REQUEST:
            if self.errsig.status_request(bool(soa_flags1 & SoAFlag.ER)):
                self.flags_stale = True
            return self.status_frames[self.errsig.ec, self.errsig.en]
        if service == RequestedService.UNSPECIFIED_INVITE and self.queue:
            return self.queue.popleft()
        return None

    # --- reacting to frames (after the answer went out) --------------------------------------
    def after_soc(self) -> None:
        """A SoC passed: NMT_CT2/CT4/CT12."""
        self._state_event(lambda: self.nmt.soc_or_soa(soc=True))

    def after_soa(self, soa: SoA, answered: bool) -> None:
        """A SoA passed (``answered``: this node sent its invited frame)."""
        self._state_event(lambda: self.nmt.soc_or_soa(soc=False))
        if answered or self.flags_stale:
            self.flags_stale = False
            self.rebuild()  # the queue (RS) may have shrunk, EN changed

    def after_pdo(self, preq: PReq | None) -> None:
        """A PReq to this node (``preq``) or another node's PRes passed."""
        self._state_event(self.nmt.pdo_frame)
        if preq is not None and self._rpdo and self.od.u(0x1400, 1) == 0:
            for m in self._rpdo:  # RPDO from the PReq (0x1400/1 = 0: the MN's PReq)
                chunk = preq.payload[m.offset_bytes : m.offset_bytes + m.length_bytes]
                if len(chunk) == m.length_bytes:
                    self.od.set_value(m.index, m.subindex, chunk)
                else:
                    self.counts["preq_too_short"] += 1

    def after_asnd(self, asnd: ASnd) -> None:
        """An ASnd to this node or to all: NMT commands and SDO."""
        service = asnd.service
        if isinstance(service, NmtCommand):
            command, mine = addressed(service.command_id, service.data, self.node_id)
            if mine:
                self._state_event(lambda: self.nmt.command(command))
        elif isinstance(service, Sdo) and asnd.dest == self.node_id:
            for answer in self.sdo.receive(service):
                if len(self.queue) >= ASYNC_QUEUE_FRAMES:
                    self.counts["async_queue_full"] += 1
                    continue
                self.queue.append(self._asnd(answer, asnd.src or MN_NODE_ID))
            self.rebuild()
        else:
            self.counts["asnd_ignored"] += 1

    # --- loss of SoC (DS 301 4.7, DLL error handling; 0x1C0B DLL_CNLossSoC_REC) ------------
    def saw_soc(self, now_ns: int, net_time_ns: int = 0) -> None:
        """A SoC with NetTime ``net_time_ns`` arrived at ``now_ns``: a good cycle lowers the
        threshold counter by one."""
        self.last_soc_ns = self.soc_seen_ns = now_ns
        self.last_soc_net_ns = net_time_ns
        count = self.od.u(0x1C0B, 2)
        if count:
            self.od.set_value(0x1C0B, 2, (count - 1).to_bytes(4, "little"))

    def check_soc(self, now_ns: int) -> None:
        """Count a lost SoC for each cycle (0x1006, plus the tolerance 0x1C14) without one.

        Each loss raises the cumulative counter by 1 and the threshold counter by 8; reaching
        the threshold (0x1C0B/3; 0 = off) is a cycle error: NMT_CT11, back to PreOp1.
        """
        cycle_ns = self.od.u(0x1006, 0) * 1000
        if self.nmt.state not in CYCLIC_STATES or not cycle_ns or not self.last_soc_ns:
            return
        if now_ns - self.last_soc_ns <= cycle_ns + self.od.u(0x1C14, 0):
            return
        self.last_soc_ns += cycle_ns
        self.counts["loss_of_soc"] += 1
        cumulative = self.od.u(0x1C0B, 1) + 1
        self.od.set_value(0x1C0B, 1, (cumulative & 0xFFFFFFFF).to_bytes(4, "little"))
        count = self.od.u(0x1C0B, 2) + LOSS_STEP
        threshold = self.od.u(0x1C0B, 3)
        if threshold and count >= threshold:
            count = 0
            self.counts["cycle_errors"] += 1
            # the entry's time: the NetTime the MN last sent, moved on by the host's clock
            when_ns = self.last_soc_net_ns + (now_ns - self.soc_seen_ns)
            self.errsig.error(E_DLL_LOSS_SOC_TH, when_ns)
            self._state_event(self.nmt.cycle_error)
            self.rebuild()
        self.od.set_value(0x1C0B, 2, count.to_bytes(4, "little"))

    def check_basic_ethernet(self, now_ns: int, last_epl_ns: int) -> None:
        """NMT_CT3: NotActive with no EPL frame for 0x1F99 (us) -> BasicEthernet.

        The time counts from the later of the last EPL frame seen (``last_epl_ns``) and the
        first check that found the node NotActive.
        """
        if self.nmt.state != NmtState.NOT_ACTIVE:
            self._not_active_ns = 0
            return
        if not self._not_active_ns:
            self._not_active_ns = now_ns
        quiet_since = max(last_epl_ns, self._not_active_ns)
        if now_ns - quiet_since > self.od.u(0x1F99, 0) * 1000:
            self._state_event(self.nmt.basic_ethernet_timeout)

    def _state_event(self, event: Callable[[], object]) -> None:
        before = self.nmt.changes
        event()
        if self.nmt.changes != before:
            if self.nmt.state in PDO_STATES:
                self._configure()
            self.rebuild()

    @property
    def outputs(self) -> int:
        """0x6200/1, the digital outputs the MN last sent."""
        return self.od.u(OUTPUTS_INDEX, 1)
