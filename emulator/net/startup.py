"""The start-up a master runs before the first cycle, on the emulated chain, timed.

The order is SOEM's (``ecx_config_init``, ``ecx_config_map_group``) and ETG.1000.6 5.4/6.4's:
count the slaves (BRD 0x0000), INIT with the error acknowledge, station addresses (APWR 0x0010),
the SII words a master needs from each slave (identity 0x08-0x0F, mailbox 0x18-0x1C; EEPROM
command 0x0502 and data 0x0508), the mailbox SyncManagers SM0/SM1 from the SII, PRE-OP, the CoE
reads of the identity 0x1018:01 and of the PDO assignment 0x1C12/0x1C13 (complete access), the
process-data SyncManager and FMMU, the distributed clocks as SOEM's ``ecx_configdc`` sets them up
(a BWR to 0x0900 latches every port's receive time; per slave FPRD of the processing unit's
receive time 0x0918 and the port times 0x0900, then FPWR of the system time offset 0x0920 and
the propagation delay 0x0928), SAFE-OP and OP, each state checked with BRD 0x0130. SYNC0 is not
activated: the emulated clocks of a timing run stand still (``EcatChain.clock_ns`` is 0).

Each frame carries one datagram, built by ``skinframes`` (:mod:`skinframes.ethercat`,
:mod:`skinframes.ecat_mailbox`), answered by the register-level ESC model
(:meth:`emulator.esc.chain.EcatChain.process_frame`) and timed by the engine's walk: the master
sends the next frame one IFG after the previous one is back, as a blocking master does. A master
polls the send mailbox (SM1 status 0x080D) until the answer is there.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Final

from emulator.configure import STATION_BASE, process_data_addresses, process_data_writes
from emulator.errors import TopologyError
from emulator.esc.chain import EcatChain
from emulator.esc.dc import REG_DC_DELAY, REG_DC_OFFSET, REG_DC_RECEIVE, REG_DC_RECEIVE_PU
from emulator.slave.sii import SlaveInfo, SyncManagerSpec, SyncManagerType
from emulator.slave.state_machine import ACK, AlState
from skinframes import ecat_mailbox as mb
from skinframes import ethercat
from skinframes.dispatch import decode_frame
from skinframes.ethercat import Command, Datagram, EcatFrame

__all__ = ["SII_WORDS", "StartupRecord", "run_startup"]

# SII words a master reads from each slave (ETG.2010 Table 2): vendor, product, revision, serial
# (8 bytes a read: two words at a time), the standard mailboxes and their protocols
SII_WORDS: Final = (0x08, 0x0C, 0x18, 0x1C)
EEPROM_READ: Final = 0x0100  # 0x0502 command bits 8-10 = 1 (datasheet II 2.11.3)
DC: Final = 0x0004  # ESC features 0x0008 bit 2: distributed clocks available (datasheet II 2.1)
MAILBOX_COE: Final = 0x0004  # SII word 0x1C, mailbox protocols: bit 2 CoE (ETG.2010 Table 2)
MAILBOX_POLLS: Final = 10  # SM1 status reads before the master gives up on an answer
SM1_STATUS: Final = 0x080D  # the send mailbox's status, bit 3 mailbox full (datasheet II 2.14)
_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")


@dataclass(frozen=True, slots=True)
class StartupRecord:
    """One frame of the start-up at the master's port 0."""

    time_ps: int
    outbound: bool
    frame: bytes
    wire_ps: int


@dataclass
class _Master:
    chain: EcatChain
    walk: Callable[[int], int]  # send time -> arrival time back at the master
    frame_ps: Callable[[int], int]  # frame length -> time on the wire
    ifg_ps: int
    t_ps: int = 0
    records: list[StartupRecord] = field(default_factory=list)

    def x(self, d: Datagram) -> Datagram:
        """Send one datagram, wait for it to return: the returned datagram."""
        sent = ethercat.frame(EcatFrame((d,))).to_bytes()
        wire = self.frame_ps(len(sent))
        self.records.append(StartupRecord(self.t_ps, True, sent, wire))
        back = self.chain.process_frame(sent)
        if back is None:
            raise TopologyError(f"start-up: the chain lost the frame {d.cmd!r} {d.ado:#06x}")
        arrive = self.walk(self.t_ps)
        self.records.append(StartupRecord(arrive, False, back, wire))
        self.t_ps = arrive + wire + self.ifg_ps
        ecat = decode_frame(back).payload
        if not isinstance(ecat, EcatFrame):
            raise TopologyError("start-up: the chain returned a frame that is not EtherCAT")
        return ecat.datagrams[0]

    def state(self, state: int, nodes: int) -> None:
        """Request ``state`` from everyone (BWR 0x0120), check it (BRD 0x0130)."""
        self.x(Datagram(Command.BWR, 0, 0x0120, _U16.pack(state)))
        got = self.x(Datagram(Command.BRD, 0, 0x0130, bytes(2)))
        if got.wkc != nodes or _U16.unpack(got.data)[0] != state & 0x0F:
            raise TopologyError(f"start-up: state {state:#x} not reached ({got.data.hex()})")


def run_startup(
    chain: EcatChain,
    walk: Callable[[int], int],
    frame_ps: Callable[[int], int],
    ifg_ps: int,
    *,
    logical_base: int = 0,
    station_base: int = STATION_BASE,
) -> list[StartupRecord]:
    """Take ``chain`` (powered on: skin patches with a mailbox, ESI slaves) to OP; the frames,
    timed. Each slave gets what its own SII describes: the mailbox steps only with a mailbox
    (on SM0/SM1), the CoE reads only with CoE, its process-data SyncManagers and FMMUs
    (:func:`emulator.esc.chain.process_data_writes`, at
    :func:`~emulator.esc.chain.process_data_addresses`), the clocks only with DC."""
    m = _Master(chain, walk, frame_ps, ifg_ps)
    nodes = len(chain)
    infos = [dev.info for dev in chain.devices]
    found = m.x(Datagram(Command.BRD, 0, 0x0000, bytes(2)))
    if found.wkc != nodes:
        raise TopologyError(f"start-up: {found.wkc} slaves answer, {nodes} expected")
    m.x(Datagram(Command.BWR, 0, 0x0120, _U16.pack(AlState.INIT | ACK)))
    stations = [station_base + p for p in range(nodes)]
    for p, s in enumerate(stations):
        m.x(Datagram(Command.APWR, (-p) & 0xFFFF, 0x0010, _U16.pack(s)))
    for s in stations:
        for word in SII_WORDS:
            m.x(Datagram(Command.FPWR, s, 0x0502, struct.pack("<HI", EEPROM_READ, word)))
            m.x(Datagram(Command.FPRD, s, 0x0508, bytes(8)))
    mailboxes = [_mailbox(info) for info in infos]
    for s, mbx in zip(stations, mailboxes, strict=True):
        if mbx is not None:
            regs = (struct.pack("<HHBBBB", x.start, x.length, x.control, 0, 1, 0) for x in mbx)
            m.x(Datagram(Command.FPWR, s, 0x0800, b"".join(regs)))
    m.state(AlState.PREOP, nodes)
    requests = (
        mb.sdo_upload_request(0x1018, 1),
        mb.sdo_upload_request(0x1C12, 0, complete_access=True),
        mb.sdo_upload_request(0x1C13, 0, complete_access=True),
    )
    for s, mbx, info in zip(stations, mailboxes, infos, strict=True):
        if mbx is None or not info.mailbox_protocols & MAILBOX_COE:
            continue
        counter = 0
        for body in requests:
            counter = mb.next_counter(counter)
            message = mb.mailbox(mb.MailboxType.COE, body, counter, size=mbx[0].length)
            if m.x(Datagram(Command.FPWR, s, mbx[0].start, message)).wkc != 1:
                raise TopologyError(f"start-up: station {s:#x} refused a mailbox write")
            for _ in range(MAILBOX_POLLS):
                if m.x(Datagram(Command.FPRD, s, SM1_STATUS, bytes(1))).data[0] & 0x08:
                    break
            else:
                raise TopologyError(f"start-up: station {s:#x} did not answer over CoE")
            m.x(Datagram(Command.FPRD, s, mbx[1].start, bytes(mbx[1].length)))
    addresses = process_data_addresses(infos, logical_base)
    for p, (s, info) in enumerate(zip(stations, infos, strict=True)):
        if info.sm_of_type(SyncManagerType.INPUTS) is None:
            raise TopologyError(f"start-up: station {s:#x} has no input SyncManager")
        for d in process_data_writes(info, *addresses[p]):
            m.x(replace(d, adp=s))
    clocks = [s for s, dev in zip(stations, chain.devices, strict=True) if dev.config.features & DC]
    if clocks:
        _config_dc(m, clocks)
    m.state(AlState.SAFEOP, nodes)
    m.state(AlState.OP, nodes)
    return m.records


def _mailbox(info: SlaveInfo) -> tuple[SyncManagerSpec, SyncManagerSpec] | None:
    """The receive and send mailbox SyncManagers of a slave with a mailbox (SM0, SM1), else
    None; a mailbox elsewhere is refused (TopologyError)."""
    rx = info.sm_of_type(SyncManagerType.MAILBOX_OUT)
    tx = info.sm_of_type(SyncManagerType.MAILBOX_IN)
    if rx is None and tx is None:
        return None
    if (rx, tx) != (0, 1):
        raise TopologyError("start-up: a slave's mailbox is not on SM0/SM1")
    return info.sync_managers[0], info.sync_managers[1]


def _config_dc(m: _Master, stations: list[int]) -> None:
    """Distributed clocks on a line (ETG.1000.4 6.8, SOEM ``ecx_configdc``): latch the receive
    times, read them, and give every slave the offset of its clock from the reference's (the
    first slave) and its propagation delay from the reference: the difference of the port-0
    receive times of the latching frame, which passes every slave on its way out."""
    m.x(Datagram(Command.BWR, 0, REG_DC_RECEIVE, bytes(4)))
    local_pu: list[int] = []
    port0: list[int] = []
    for s in stations:
        local_pu.append(
            _U64.unpack(m.x(Datagram(Command.FPRD, s, REG_DC_RECEIVE_PU, bytes(8))).data)[0]
        )
        port0.append(
            _U32.unpack_from(m.x(Datagram(Command.FPRD, s, REG_DC_RECEIVE, bytes(16))).data)[0]
        )
    for p, s in enumerate(stations):
        delay = (port0[p] - port0[0]) & 0xFFFFFFFF
        offset = (local_pu[0] - local_pu[p] + delay) & 0xFFFFFFFFFFFFFFFF
        m.x(Datagram(Command.FPWR, s, REG_DC_OFFSET, _U64.pack(offset)))
        m.x(Datagram(Command.FPWR, s, REG_DC_DELAY, _U32.pack(delay)))
