"""A line of emulated ESCs that processes whole Ethernet frames on the fly, as wired slaves do.

Each ESC processes the frame in its processing direction (port 0 -> EtherCAT processing unit ->
port 1) before the next one sees it: slave by slave, and in each slave datagram by datagram
(datasheet I 3.2, Table 10). The last ESC's port 1 has no link, so its loop is closed and the
frame returns through the chain's forwarding direction to the master unchanged. An ESC whose DL
control closes port 1 returns the frame early; one forced open without a link loses it.

The frame keeps its length: ESCs never add or remove bytes, so a request padded to the 60-byte
minimum comes back padded and an unpadded one (SOEM on veth) comes back unpadded. The
processing unit sets bit 0x02 of the first source-MAC octet when DL control bit 0 asks for it
(datasheet I 3, II 2.4.1). Datagrams are parsed with :func:`skinframes.ethercat.decode`; the
processing writes the data, ADP, IRQ and WKC fields in place.

One model serves two users: the live transport (:mod:`emulator.live`) feeds it frames from a
raw socket, and the timing engine (:mod:`emulator.net.ecat`) asks :meth:`EcatChain.frame_effect`
once per frame of a cycle what each ESC does to it, and applies that to the ESCs a frame reaches.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Container, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc.dc import DcTimebase
from emulator.esc.device import EscConfig, EscDevice, TraceCopy
from emulator.esc.sii import SlaveInfo, SyncManagerType
from emulator.esc.state_machine import AlState, SkinPatchApplication
from skinframes import ethercat, ethernet
from skinframes.errors import DecodeError
from skinframes.ethercat import Command, Datagram, EcatFrame

__all__ = [
    "MAX_SLAVES",
    "STATION_BASE",
    "EcatChain",
    "FrameEffect",
    "SlaveEffect",
    "configure_frames",
]

STATION_BASE: Final = (
    0x1001  # configured station address of position 0 (SOEM/ethercrab use 0x1001+)
)

MAX_SLAVES: Final = 0xFFFF  # auto-increment addresses are 16 bits
_VLAN_TPID: Final = 0x8100
_ETH_HEADER: Final = ethernet.HEADER_BYTES
_U16 = struct.Struct("<H")
# command classes (ETG.1000.4 Table 14) for the frame plan of EcatChain._run_planned
_AUTO_INCREMENT: Final = frozenset({1, 2, 3})
_CONFIGURED: Final = frozenset({4, 5, 6})
_LOGICAL: Final = frozenset({10, 11, 12})
_EVERYONE: Final = frozenset({7, 8, 9, 13, 14})  # broadcasts, ARMW, FRMW
_INCREMENTS: Final = frozenset({1, 2, 3, 7, 8, 9, 13})  # ADP + 1 at every ESC
_BWR: Final = int(Command.BWR)


def _frozen_clock() -> int:
    return 0


class EcatChain:
    """Emulated ESCs in a line, the first one's port 0 facing the master.

    Args:
        devices: the ESCs in wiring order.
    """

    def __init__(self, devices: Sequence[EscDevice]) -> None:
        if not 1 <= len(devices) <= MAX_SLAVES:
            raise TopologyError(f"EtherCAT chain: {len(devices)} slaves (1..{MAX_SLAVES})")
        self.devices = list(devices)
        self.timebase = DcTimebase(line_length=len(self.devices))  # distributed clocks (dc.py)
        # host time (ns) at which each frame arrives: frozen at 0 (deterministic, for the timing
        # engine and tests) until a live transport sets a real clock (emulator.live.serve)
        self.clock_ns: Callable[[], int] = _frozen_clock
        for i, dev in enumerate(self.devices):
            dev.position = i
            dev.set_port1_link(i < len(self.devices) - 1)
            dev.dc.timebase, dev.dc.position = self.timebase, i
        self.frames = 0
        self.dropped = 0

    @classmethod
    def skin(
        cls,
        nodes: int,
        input_bytes: int,
        *,
        config: EscConfig | None = None,
        mailbox: bool = False,
    ) -> EcatChain:
        """``nodes`` skin patches of ``input_bytes`` each, powered on (INIT, unconfigured).

        Serial numbers are the positions + 1; vendor, product and revision are equal, as for a
        batch of identical devices. ``mailbox``: patches with a CoE mailbox
        (:meth:`SlaveInfo.skin_patch`).
        """
        if not 1 <= nodes <= MAX_SLAVES:
            raise TopologyError(f"EtherCAT chain: {nodes} slaves (1..{MAX_SLAVES})")
        return cls(
            [
                EscDevice(
                    SlaveInfo.skin_patch(input_bytes, serial=i + 1, mailbox=mailbox),
                    config=config,
                )
                for i in range(nodes)
            ]
        )

    @classmethod
    def configured(
        cls,
        nodes: int,
        input_bytes: int,
        *,
        logical_base: int = 0,
        station_base: int = STATION_BASE,
    ) -> EcatChain:
        """Skin patches configured as a master leaves them, in OP.

        The configuration runs through frames (:func:`configure_frames`): station addresses
        ``station_base + position``, SM0 as in the SII, FMMU0 mapping each patch's inputs to
        ``logical_base + position * input_bytes``, then INIT -> PREOP -> SAFEOP -> OP.
        """
        chain = cls.skin(nodes, input_bytes)
        for frame in configure_frames(chain.devices[0].info, nodes, logical_base, station_base):
            if chain.process_frame(frame) is None:
                raise TopologyError("EtherCAT chain: a configuration frame was lost")
        for dev in chain.devices:
            if dev.al_status != AlState.OP:
                raise TopologyError(
                    f"slave {dev.position}: AL status {dev.al_status:#x}, code "
                    f"{dev.al_status_code:#06x} after configuration"
                )
        return chain

    # --- the application side ---------------------------------------------------------------
    @property
    def input_bytes(self) -> int:
        """Input bytes of the first slave (every skin patch of a chain has the same)."""
        return self.devices[0].info.input_bytes

    def publish(self, rows: npt.ArrayLike | Iterable[bytes]) -> None:
        """Each slave's application writes its next input buffer: one row per slave.

        Called between frames, so that every frame sees one consistent sample per slave.
        """
        if isinstance(rows, np.ndarray):
            arr = np.ascontiguousarray(rows, dtype=np.uint8)
            if arr.ndim != 2 or arr.shape[0] != len(self.devices):
                raise TopologyError(f"publish: rows of shape {arr.shape} for {len(self)} slaves")
            data: Iterable[bytes] = (arr[i].tobytes() for i in range(arr.shape[0]))
        else:
            data = rows  # type: ignore[assignment]
        for dev, row in zip(self.devices, data, strict=True):
            app = dev.app
            if not isinstance(app, SkinPatchApplication):
                raise TopologyError(f"slave {dev.position}: not a skin patch application")
            app.publish(dev, row)

    def __len__(self) -> int:
        return len(self.devices)

    # --- frames -----------------------------------------------------------------------------
    def process_frame(self, frame: bytes | bytearray) -> bytes | None:
        """Pass an Ethernet frame through the chain; the frame as it returns to the master.

        Returns:
            The returned frame (same length), or None when the ESCs destroy it: a non-EtherCAT
            frame at an ESC whose DL control forwarding rule destroys them, a malformed
            EtherCAT frame, or a port forced open without a link.
        """
        return self._run(frame, None)

    def _run(self, frame: bytes | bytearray, acted: list[int] | None) -> bytes | None:
        self.frames += 1
        self.timebase.frame_ns = self.clock_ns()
        buf = bytearray(frame)
        parsed = self._parse(buf)
        if parsed is None:
            return self._non_ecat(buf)
        if not parsed:
            self._drop(malformed=True)
            return None
        if acted is None:
            return self._run_planned(buf, parsed)
        mac_bit = False
        for dev in self.devices:
            self._pass(dev, buf, parsed, acted)
            mac_bit = mac_bit or dev.sets_mac
            onward = dev.onward  # loop changes wait for the end of the frame (II 2.4.1)
            dev.end_frame()
            if onward is None:
                self._drop(malformed=False)
                return None
            if not onward:
                break
        if mac_bit:
            buf[6] |= ethercat.RETURNED_MAC_BIT
        return bytes(buf)

    def _run_planned(
        self, buf: bytearray, layout: list[tuple[int, int, int, int, int, int]]
    ) -> bytes | None:
        """The same processing as :meth:`_pass` ESC by ESC, but each ESC is handed only the
        datagrams that can concern it: an auto-increment datagram the ESC whose position
        makes ADP 0, a configured-address one the ESCs with that station address (or alias), a
        logical one the ESCs whose FMMUs map part of it, broadcasts and read-multiple-writes
        every ESC. Work per frame is thus bounded by what the frame asks of each ESC."""
        devices = self.devices
        everyone: list[int] = []
        targets: dict[int, list[int]] = {}
        adps = [buf[d[1]] | buf[d[1] + 1] << 8 for d in layout]
        stations: dict[int, list[int]] | None = None
        spans: tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]] | None = None
        for k, (cmd, _, ado, _, n, _) in enumerate(layout):
            adp = adps[k]
            if cmd in _EVERYONE:
                everyone.append(k)
            elif cmd in _AUTO_INCREMENT:
                pos = -adp & 0xFFFF
                if pos < len(devices):
                    targets.setdefault(pos, []).append(k)
            elif cmd in _CONFIGURED:
                if stations is None:
                    stations = self._stations()
                for pos in stations.get(adp, ()):
                    targets.setdefault(pos, []).append(k)
            elif cmd in _LOGICAL and n:
                if spans is None:
                    spans = (
                        np.array([d.fmmu_span[0] for d in devices], dtype=np.int64),
                        np.array([d.fmmu_span[1] for d in devices], dtype=np.int64),
                    )
                lad = adp | ado << 16
                hit = np.flatnonzero((spans[0] < lad + n) & (spans[1] > lad))
                for pos in hit.tolist():
                    targets.setdefault(pos, []).append(k)
        inc = [cmd in _INCREMENTS for cmd, *_ in layout]
        # a BWR's data passes every ESC unchanged: one copy serves them all (datasheet I Table 7)
        written = [bytes(buf[d[3] : d[3] + d[4]]) if d[0] == _BWR else None for d in layout]
        irq_or = 0
        mac_bit = False
        passed = 0
        for p, dev in enumerate(devices):
            mine = targets.get(p)
            work = everyone if mine is None else sorted(everyone + mine) if everyone else mine
            process, broadcast_write = dev.process, dev.broadcast_write
            irq_before = dev.irq
            last = -1
            for k in work:
                cmd, adp_at, ado, data_at, n, irq_at = layout[k]
                data = written[k]
                if data is not None:
                    wkc_inc = broadcast_write(ado, data)
                else:
                    adp = (adps[k] + p) & 0xFFFF if inc[k] else adps[k]
                    _, wkc_inc = process(cmd, adp, ado, buf, data_at, n)
                if wkc_inc:
                    wkc_at = data_at + n
                    wkc = (buf[wkc_at] | buf[wkc_at + 1] << 8) + wkc_inc
                    buf[wkc_at] = wkc & 0xFF
                    buf[wkc_at + 1] = (wkc >> 8) & 0xFF
                irq = dev.irq
                if irq != irq_before:  # the event request changed: OR it where it applied
                    for j in range(last + 1, k):
                        self._or_irq(buf, layout[j][5], irq_before)
                    last, irq_before = k - 1, irq
                if irq:
                    self._or_irq(buf, irq_at, irq)
            if last >= 0 and irq_before:
                for j in range(last + 1, len(layout)):
                    self._or_irq(buf, layout[j][5], irq_before)
            else:
                irq_or |= irq_before
            mac_bit = mac_bit or dev.sets_mac
            onward = dev.onward  # loop changes wait for the end of the frame (II 2.4.1)
            dev.end_frame()
            passed += 1
            if onward is None:
                self._drop(malformed=False)
                return None
            if not onward:
                break
        for k, (_, adp_at, _, _, _, irq_at) in enumerate(layout):
            if inc[k]:
                adp = (adps[k] + passed) & 0xFFFF
                buf[adp_at] = adp & 0xFF
                buf[adp_at + 1] = adp >> 8
            if irq_or:
                self._or_irq(buf, irq_at, irq_or)
        if mac_bit:
            buf[6] |= ethercat.RETURNED_MAC_BIT
        return bytes(buf)

    @staticmethod
    def _or_irq(buf: bytearray, at: int, irq: int) -> None:
        buf[at] |= irq & 0xFF
        buf[at + 1] |= irq >> 8

    def _stations(self) -> dict[int, list[int]]:
        """Positions by configured station address, and by alias where DL control enables it."""
        out: dict[int, list[int]] = {}
        for p, dev in enumerate(self.devices):
            out.setdefault(dev.station, []).append(p)
            if dev.mem[0x0103] & 0x01:
                alias = dev.alias
                if alias != dev.station:
                    out.setdefault(alias, []).append(p)
        return out

    @staticmethod
    def _parse(buf: bytearray) -> list[tuple[int, int, int, int, int, int]] | None:
        """Where the ESC finds each datagram's fields: (cmd, ADP at, ADO, data at, length, IRQ
        at). None for a non-EtherCAT frame; an empty list for a malformed one."""
        if len(buf) < _ETH_HEADER + ethercat.FRAME_HEADER_BYTES:
            return []
        at = 12
        ethertype = buf[at] << 8 | buf[at + 1]
        if ethertype == _VLAN_TPID:  # ESCs process VLAN-tagged frames, tag untouched
            at += 4
            ethertype = buf[at] << 8 | buf[at + 1]
        if ethertype != ethernet.ETHERTYPE_ECAT:
            return None
        payload_at = at + 2
        try:
            ecat, _, _ = ethercat.decode(bytes(buf[payload_at:]), strict=False)
        except DecodeError:
            return []
        if ecat.frame_type != ethercat.FrameType.ECAT:
            return None
        layout = []
        pos = payload_at + ethercat.FRAME_HEADER_BYTES
        for d in ecat.datagrams:
            n = len(d.data)
            layout.append((int(d.cmd), pos + 2, d.ado, pos + 10, n, pos + 8))
            pos += ethercat.DATAGRAM_OVERHEAD_BYTES + n
        return layout

    @staticmethod
    def _pass(
        dev: EscDevice,
        buf: bytearray,
        layout: list[tuple[int, int, int, int, int, int]],
        acted: list[int] | None,
    ) -> None:
        """One ESC's processing unit executes every datagram of the frame in ``buf``, in place."""
        process = dev.process
        for cmd, adp_at, ado, data_at, n, irq_at in layout:
            adp = buf[adp_at] | buf[adp_at + 1] << 8
            new_adp, inc = process(cmd, adp, ado, buf, data_at, n)
            if new_adp != adp:
                buf[adp_at] = new_adp & 0xFF
                buf[adp_at + 1] = new_adp >> 8
            if inc:
                if acted is not None:
                    acted.append(dev.position)
                wkc_at = data_at + n
                wkc = (buf[wkc_at] | buf[wkc_at + 1] << 8) + inc
                buf[wkc_at] = wkc & 0xFF
                buf[wkc_at + 1] = (wkc >> 8) & 0xFF
            irq = dev.irq
            if irq:
                buf[irq_at] |= irq & 0xFF
                buf[irq_at + 1] |= irq >> 8

    def _non_ecat(self, buf: bytearray) -> bytes | None:
        for dev in self.devices:
            if dev.changes_source_mac:  # DL control bit 0 = 1: destroy non-EtherCAT frames
                self._drop(malformed=False)
                return None
            if not dev.forwards():
                break
        return bytes(buf)

    def _drop(self, *, malformed: bool) -> None:
        self.dropped += 1
        if malformed:
            self.devices[0].count_frame_error()
        return None

    # --- the timing emulator's view -----------------------------------------------------------
    def frame_effect(self, ecat: EcatFrame) -> FrameEffect:
        """What each ESC does to ``ecat`` as it passes in processing direction (processed for
        real, ESC by ESC, with end-of-frame effects): the form the timing engine caches.

        The chain's state moves on as for any frame (a skin patch's LRD changes nothing that a
        later LRD would see).
        """
        frame = ethercat.frame(ecat).to_bytes()
        buf = bytearray(frame)
        layout = self._parse(buf)
        if not layout:
            raise TopologyError("EtherCAT chain: not a well-formed EtherCAT frame")
        data_at = ethercat.data_offsets(ecat)
        slaves: list[SlaveEffect] = []
        marks: list[int] = []
        for dev in self.devices:
            copies: list[TraceCopy] = []
            dev.trace = copies
            before = bytes(buf)
            try:
                self._pass(dev, buf, layout, None)
            finally:
                dev.trace = None
            onward = dev.onward
            dev.end_frame()
            effect = _slave_effect(dev, ecat, data_at, before, buf, copies)
            if effect is not None:
                slaves.append(effect)
            if dev.sets_mac:
                marks.append(dev.position)
            if not onward:
                break
        return FrameEffect(ecat, tuple(slaves), frozenset(marks), self.input_bytes)

    def count(self, register: int, position: int, times: int = 1) -> None:
        """An error counter of the ESC at ``position`` counts ``times`` (saturating at 0xFF;
        datasheet II 2.6: 0x0300 + 2 x port invalid frames, 0x0308 + port forwarded errors,
        0x0310 + port lost links)."""
        self.devices[position].count_error(register, times)

    def counter(self, register: int, position: int) -> int:
        """The value of an 8-bit error counter register of the ESC at ``position``."""
        return self.devices[position].registers(register, 1)[0]


@dataclass(frozen=True, slots=True)
class SlaveEffect:
    """What one ESC writes into a passing frame (datagram index ``d`` of the frame)."""

    position: int
    wkc: tuple[int, ...]  # working-counter increment per datagram
    adp: tuple[int, ...]  # ADP increment per datagram (auto-increment and broadcast commands)
    copies: tuple[tuple[int, int, int, int], ...]  # (d, offset in d's data, input offset, bytes)
    constant: tuple[tuple[int, int, bytes], ...]  # (d, offset in d's data, bytes) from registers


@dataclass(frozen=True, slots=True)
class FrameEffect:
    """A frame and what every ESC of the chain does to it in processing direction: the ESCs
    that change its datagrams (``slaves``) and those that mark its source MAC (DL control bit 0).
    """

    sent: EcatFrame
    slaves: tuple[SlaveEffect, ...]
    marks_mac: frozenset[int]
    input_bytes: int

    def wkc(self, acting: Container[int]) -> int:
        """The sum of the returned working counters when the ESCs in ``acting`` process it."""
        return sum(d.wkc for d in self.sent.datagrams) + sum(
            sum(s.wkc) for s in self.slaves if s.position in acting
        )

    def returned(
        self, acting: Container[int], taxels: npt.NDArray[np.uint8] | None
    ) -> tuple[EcatFrame, bool]:
        """The frame after the ESCs in ``acting`` processed it, and whether one marked its
        source MAC. ``taxels``: the chain's input image (position x input_bytes), or None to
        leave the input bytes as sent."""
        dgs = self.sent.datagrams
        data = [bytearray(d.data) for d in dgs]
        wkc = [d.wkc for d in dgs]
        adp = [d.adp for d in dgs]
        mac = any(p in acting for p in self.marks_mac)
        for s in self.slaves:
            if s.position not in acting:
                continue
            for k in range(len(dgs)):
                wkc[k] += s.wkc[k]
                adp[k] += s.adp[k]
            for k, off, value in s.constant:
                data[k][off : off + len(value)] = value
            if taxels is not None:
                base = s.position * self.input_bytes
                for k, off, src, n in s.copies:
                    data[k][off : off + n] = taxels[base + src : base + src + n].tobytes()
        back = tuple(
            replace(d, data=bytes(data[k]), wkc=wkc[k] & 0xFFFF, adp=adp[k] & 0xFFFF)
            for k, d in enumerate(dgs)
        )
        return EcatFrame(back, self.sent.frame_type), mac

    def taxel_runs(self, acting: Container[int]) -> list[tuple[int, int, int]]:
        """Where the input bytes go in the returned Ethernet frame: (offset in the frame,
        offset in the chain's input image, bytes)."""
        at = ethercat.data_offsets(self.sent)
        return [
            (at[k] + off, s.position * self.input_bytes + src, n)
            for s in self.slaves
            if s.position in acting
            for k, off, src, n in s.copies
        ]


def _slave_effect(
    dev: EscDevice,
    ecat: EcatFrame,
    data_at: tuple[int, ...],
    before: bytes,
    after: bytearray,
    copies: list[TraceCopy],
) -> SlaveEffect | None:
    """The difference one ESC made to a frame, datagram by datagram."""
    wkc: list[int] = []
    adp: list[int] = []
    const: list[tuple[int, int, bytes]] = []
    runs: list[tuple[int, int, int, int]] = []
    for k, d in enumerate(ecat.datagrams):
        lo, n = data_at[k], len(d.data)
        adp_at = lo - ethercat.DATAGRAM_HEADER_BYTES + 2
        wkc.append(
            (_U16.unpack_from(after, lo + n)[0] - _U16.unpack_from(before, lo + n)[0]) & 0xFFFF
        )
        adp.append(
            (_U16.unpack_from(after, adp_at)[0] - _U16.unpack_from(before, adp_at)[0]) & 0xFFFF
        )
        copied = bytearray(n)
        for c in copies:
            if c.sm >= 0 and lo <= c.dst < lo + n:
                runs.append((k, c.dst - lo, c.src, c.length))
                copied[c.dst - lo : c.dst - lo + c.length] = b"\x01" * c.length
        if after[lo : lo + n] != before[lo : lo + n]:
            diff = np.frombuffer(after, np.uint8, n, lo) != np.frombuffer(before, np.uint8, n, lo)
            changed = np.flatnonzero(diff & (np.frombuffer(bytes(copied), np.uint8) == 0))
            if len(changed):  # register data the ESC wrote: one run, first to last change
                a, b = int(changed[0]), int(changed[-1]) + 1
                const.append((k, a, bytes(after[lo + a : lo + b])))
    if not any(wkc) and not any(adp) and not const and not runs:
        return None
    return SlaveEffect(dev.position, tuple(wkc), tuple(adp), tuple(runs), tuple(const))


def configure_frames(
    info: SlaveInfo, nodes: int, logical_base: int = 0, station_base: int = STATION_BASE
) -> list[bytes]:
    """The frames a master sends to take ``nodes`` slaves described by ``info`` to OP.

    Station addresses by APWR, the mailbox SyncManagers (if the SII has them), the input
    SyncManager and FMMU0 by FPWR, then BWR AL control INIT+ack, PREOP, SAFEOP, OP: the
    essential steps of ETG.1000.6's start-up (5.4, 6.4).
    """
    sm_index = info.sm_of_type(SyncManagerType.INPUTS)
    if sm_index is None:
        raise TopologyError("configure: the slave has no input SyncManager")
    sm = info.sync_managers[sm_index]
    size = info.sm_bytes(sm_index)
    frames: list[Datagram] = []
    for p in range(nodes):
        frames.append(Datagram(Command.APWR, (-p) & 0xFFFF, 0x0010, _U16.pack(station_base + p)))
    frames.append(Datagram(Command.BWR, 0, 0x0120, _U16.pack(AlState.INIT | 0x10)))
    for p in range(nodes):
        station = station_base + p
        for i, mb in enumerate(info.sync_managers):  # mailbox SMs before PREOP (ETG.1000.6 5.6)
            if mb.type in (SyncManagerType.MAILBOX_OUT, SyncManagerType.MAILBOX_IN):
                regs = struct.pack("<HHBBBB", mb.start, mb.length, mb.control, 0, mb.enable, 0)
                frames.append(Datagram(Command.FPWR, station, 0x0800 + 8 * i, regs))
        sm_regs = struct.pack("<HHBBBB", sm.start, size, sm.control, 0, sm.enable, 0)
        frames.append(Datagram(Command.FPWR, station, 0x0800 + 8 * sm_index, sm_regs))
        fmmu = struct.pack(
            "<IHBBHBBBxxx", logical_base + p * size, size, 0, 7, sm.start, 0, 0x01, 0x01
        )
        frames.append(Datagram(Command.FPWR, station, 0x0600, fmmu))
    for state in (AlState.PREOP, AlState.SAFEOP, AlState.OP):
        frames.append(Datagram(Command.BWR, 0, 0x0120, _U16.pack(state)))
    return [ethercat.frame(EcatFrame((d,))).to_bytes() for d in frames]
