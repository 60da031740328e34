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
raw socket, and the timing emulator can ask :meth:`EcatChain.effect` what a datagram does, in
the :class:`emulator.esc.DatagramEffect` form that :mod:`emulator.ecat_cycle` consumes.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc import STATION_BASE, ByteCopy, DatagramEffect
from emulator.esc_device import EscConfig, EscDevice, TraceCopy
from emulator.esm import AlState, SkinPatchApplication
from emulator.sii import SlaveInfo
from skinframes import ethercat, ethernet
from skinframes.errors import DecodeError
from skinframes.ethercat import Command, Datagram, EcatFrame

__all__ = ["MAX_SLAVES", "EcatChain", "configure_frames"]

MAX_SLAVES: Final = 0xFFFF  # auto-increment addresses are 16 bits
_VLAN_TPID: Final = 0x8100
_ETH_HEADER: Final = ethernet.HEADER_BYTES
_U16 = struct.Struct("<H")


class EcatChain:
    """Emulated ESCs in a line, the first one's port 0 facing the master.

    Args:
        devices: the ESCs in wiring order.
    """

    def __init__(self, devices: Sequence[EscDevice]) -> None:
        if not 1 <= len(devices) <= MAX_SLAVES:
            raise TopologyError(f"EtherCAT chain: {len(devices)} slaves (1..{MAX_SLAVES})")
        self.devices = list(devices)
        for i, dev in enumerate(self.devices):
            dev.position = i
            dev.set_port1_link(i < len(self.devices) - 1)
        self.frames = 0
        self.dropped = 0

    @classmethod
    def skin(cls, nodes: int, input_bytes: int, *, config: EscConfig | None = None) -> EcatChain:
        """``nodes`` skin patches of ``input_bytes`` each, powered on (INIT, unconfigured).

        Serial numbers are the positions + 1; vendor, product and revision are equal, as for a
        batch of identical devices.
        """
        if not 1 <= nodes <= MAX_SLAVES:
            raise TopologyError(f"EtherCAT chain: {nodes} slaves (1..{MAX_SLAVES})")
        return cls(
            [
                EscDevice(SlaveInfo.skin_patch(input_bytes, serial=i + 1), config=config)
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
        buf = bytearray(frame)
        if len(buf) < _ETH_HEADER + ethercat.FRAME_HEADER_BYTES:
            self._drop(malformed=True)
            return None
        at = 12
        ethertype = buf[at] << 8 | buf[at + 1]
        if ethertype == _VLAN_TPID:  # ESCs process VLAN-tagged frames, tag untouched
            at += 4
            ethertype = buf[at] << 8 | buf[at + 1]
        if ethertype != ethernet.ETHERTYPE_ECAT:
            return self._non_ecat(buf)
        payload_at = at + 2
        try:
            ecat, _, _ = ethercat.decode(bytes(buf[payload_at:]), strict=False)
        except DecodeError:
            self._drop(malformed=True)
            return None
        if ecat.frame_type != ethercat.FrameType.ECAT:
            return self._non_ecat(buf)
        layout = []
        pos = payload_at + ethercat.FRAME_HEADER_BYTES
        for d in ecat.datagrams:
            n = len(d.data)
            layout.append((int(d.cmd), pos + 2, d.ado, pos + 10, n, pos + 8))
            pos += ethercat.DATAGRAM_OVERHEAD_BYTES + n
        mac_bit = False
        for dev in self.devices:
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
    def effect(self, d: Datagram) -> DatagramEffect:
        """What the chain does to datagram ``d`` sent alone in a frame (processed for real).

        The result has the form of :meth:`emulator.esc.EscChain.effect`: the returned ADP, the
        working-counter increment, each slave's input bytes as :class:`ByteCopy` runs (source:
        offset in the slave's input SyncManager buffer), the other data the chain wrote, and the
        positions that executed the datagram.
        """
        frame = ethercat.frame(EcatFrame((d,))).to_bytes()
        traces: list[TraceCopy] = []
        for dev in self.devices:
            dev.trace = traces
        acted: list[int] = []
        try:
            back = self._run(frame, acted)
        finally:
            for dev in self.devices:
                dev.trace = None
        if back is None:
            raise TopologyError("EtherCAT chain: the frame was lost")
        ecat, _, _ = ethercat.decode(back[_ETH_HEADER:], strict=False)
        out = ecat.datagrams[0]
        data_at = _ETH_HEADER + ethercat.FRAME_HEADER_BYTES + ethercat.DATAGRAM_HEADER_BYTES
        copies = tuple(
            ByteCopy(t.position, t.src, t.dst - data_at, t.length) for t in traces if t.sm >= 0
        )
        constant = bytearray(out.data)
        for c in copies:
            constant[c.dst : c.dst + c.length] = d.data[c.dst : c.dst + c.length]
        const: tuple[tuple[int, bytes], ...] = ()
        if bytes(constant) != d.data:
            const = ((0, bytes(constant)),)
        return DatagramEffect(
            out.adp, (out.wkc - d.wkc) & 0xFFFF, copies, const, tuple(sorted(set(acted)))
        )


def configure_frames(
    info: SlaveInfo, nodes: int, logical_base: int = 0, station_base: int = STATION_BASE
) -> list[bytes]:
    """The frames a master sends to take ``nodes`` slaves described by ``info`` to OP.

    Station addresses by APWR, the input SyncManager and FMMU0 by FPWR, then BWR AL control
    INIT+ack, PREOP, SAFEOP, OP: the essential steps of ETG.1000.6's start-up (5.4, 6.4).
    """
    sm_index = next((i for i, sm in enumerate(info.sync_managers) if not sm.ecat_writes), None)
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
        sm_regs = struct.pack("<HHBBBB", sm.start, size, sm.control, 0, sm.enable, 0)
        frames.append(Datagram(Command.FPWR, station, 0x0800 + 8 * sm_index, sm_regs))
        fmmu = struct.pack(
            "<IHBBHBBBxxx", logical_base + p * size, size, 0, 7, sm.start, 0, 0x01, 0x01
        )
        frames.append(Datagram(Command.FPWR, station, 0x0600, fmmu))
    for state in (AlState.PREOP, AlState.SAFEOP, AlState.OP):
        frames.append(Datagram(Command.BWR, 0, 0x0120, _U16.pack(state)))
    return [ethercat.frame(EcatFrame((d,))).to_bytes() for d in frames]
