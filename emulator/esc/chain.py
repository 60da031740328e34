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

The slaves' applications (their firmware: the ESM, the mailbox) react to a frame once it has
passed, as firmware sees the events its ESC raised (:meth:`EcatChain.run_firmware`):
:meth:`EcatChain.process_frame` returns the frame and then runs them; :meth:`EcatChain.answer`
returns the frame and leaves them until the live transport has sent it.

One model serves two users: the live transport (:mod:`emulator.live`) feeds it frames from a
raw socket, and the timing engine (:mod:`emulator.net.ecat`) asks :meth:`EcatChain.frame_effect`
once per frame of a cycle what each ESC does to it, and applies that to the ESCs a frame reaches.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Container, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Final, NamedTuple, cast

import numpy as np
import numpy.typing as npt

from emulator.configure import (
    STATION_BASE,
    configure_frames,
    configure_line_frames,
    process_data_addresses,
    process_data_writes,
)
from emulator.errors import TopologyError
from emulator.esc.commands import (
    APWR,
    ARMW,
    AUTO_INCREMENT,
    BRD,
    BRW,
    BWR,
    CONFIGURED,
    EVERYONE,
    INCREMENTS,
    LOGICAL,
)
from emulator.esc.dc import DcTimebase
from emulator.esc.device import (
    LRD_OR_LRW,
    EscConfig,
    EscDevice,
    TraceCopy,
    commit_apart,
    consecutive,
    finish_reads,
    latches,
    pdi_write_rows,
    react_together,
    read_buffers,
)
from emulator.esc.mapping import (
    PLAN_CACHE_ENTRIES,
    Access,
    Caches,
    LogicalOp,
    LogicalPlan,
    remember,
)
from emulator.esc.registers import (
    ADDRESS_SPACE,
    DC_SYNC0_ACTIVE,
    REG_ALIAS,
    REG_DC_ACTIVATION,
    REG_DL_CONTROL,
    REG_ECAT_EVENT,
    REG_FORWARDED_ERRORS,
    REG_RESET_ECAT,
    REG_RW_OFFSET,
    REG_STATION,
    REGISTER_END,
    cleared_events,
    reads_dc,
)
from emulator.esc.syncmanagers import SmRun
from emulator.esc.together import (
    LOGICAL_TOGETHER_MIN,
    TOGETHER_MIN,
    commit_together,
    finish_together,
    logical_together,
)
from emulator.slave.sii import SlaveInfo, SyncManagerType
from emulator.slave.state_machine import AlState, SkinPatchApplication
from skinframes import ethercat, ethernet
from skinframes.errors import DecodeError
from skinframes.ethercat import EcatFrame

__all__ = [
    "MAX_SLAVES",
    "STATION_BASE",
    "EcatChain",
    "FrameEffect",
    "SlaveEffect",
    "configure_frames",
    "configure_line_frames",
    "process_data_addresses",
    "process_data_writes",
    "skin_devices",
]

MAX_SLAVES: Final = 0xFFFF  # auto-increment addresses are 16 bits
_VLAN_TPID: Final = 0x8100
# the values of DC activation 0x0981 without both SYNC0 bits (0 and 1): deleted from a column
# of them, what is left are the ESCs that sample at SYNC0 (EscDevice.dc_sampling)
_NOT_SAMPLING: Final = bytes(b for b in range(256) if b & DC_SYNC0_ACTIVE != DC_SYNC0_ACTIVE)
_ETH_HEADER: Final = ethernet.HEADER_BYTES
_U16 = struct.Struct("<H")
_UNTOUCHED: Final[LogicalPlan] = ((), ())  # the cut plan of an access that does nothing


def _register_read(lo: int, hi: int) -> bool:
    """A read of registers [lo, hi) below 0x0F80 that does not read DC times (which run with
    the clock): it reads bytes, and may clear event bits (:func:`cleared_events`)."""
    return (
        lo < REGISTER_END  # an empty access at 0x0F80 or beyond touches no register: no count
        and hi <= REGISTER_END
        and not reads_dc(lo, hi)
    )


def _registers(lo: int, hi: int) -> bool:
    """An access of registers [lo, hi), all below 0x0F80 (an empty one at 0x0F80 or beyond
    touches no register: no count)."""
    return lo < REGISTER_END and hi <= REGISTER_END


def _plain_read(lo: int, hi: int) -> bool:
    """A read of registers [lo, hi) that changes nothing: a register read that clears no event."""
    return _register_read(lo, hi) and not cleared_events(lo, hi)


def _plain_write(lo: int, hi: int) -> bool:
    """A write of registers [lo, hi) that only waits for the end of the frame: below 0x0F80 and
    not the reset register (whose sequence each ESC follows, datasheet II 2.3)."""
    return lo < REGISTER_END and hi <= REGISTER_END and not lo <= REG_RESET_ECAT < hi


def _or_accumulate(rows: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """Row i: the OR of ``rows[0..i]`` (``np.bitwise_or.accumulate(rows, axis=0)``), 8 bytes
    at a time (a one-off measurement: 160 rows of 1,386 bytes in 40 us, bytewise 580 us)."""
    count, width = rows.shape
    words = np.zeros((count, -(-width // 8)), np.uint64)
    words.view(np.uint8)[:, :width] = rows
    return np.bitwise_or.accumulate(words, axis=0).view(np.uint8)[:, :width]


def _frozen_clock() -> int:
    return 0


class _Loop(NamedTuple):
    """How far a frame goes along the line (:meth:`EcatChain._run_planned`), while the ESCs'
    forwarding and MAC marking stay (:attr:`Caches.links`)."""

    links: int  # Caches.links when worked out
    reach: int  # the ESCs the frame reaches
    lost: bool  # it is lost at the last of them (forced open without a link), not returned
    mac: bool  # one of them marks the source MAC (DL control bit 0)


def _loop(devices: list[EscDevice], links: int) -> _Loop:
    """:class:`_Loop` of ``devices`` now: the frame returns from the first ESC whose port 1 is
    closed (False) and is lost at one forced open without a link (None)."""
    reach, lost = len(devices), False
    for p, dev in enumerate(devices):
        onward = dev.onward
        if not onward:
            reach, lost = p + 1, onward is None
            break
    mac = False
    for k in range(reach):
        mac = mac or devices[k].sets_mac
    return _Loop(links, reach, lost, mac)


def _ored_irq(line: list[EscDevice]) -> int:
    """The event requests of the ESCs of ``line`` ORed (datasheet I Table 3)."""
    irq = 0
    for dev in line:
        irq |= dev.irq
    return irq


class _Reads(NamedTuple):
    """Whole buffers of one SyncManager index, start and length read over rows
    (:func:`read_buffers`), exchanged at the end of the frame (:func:`finish_reads`)."""

    devices: list[EscDevice]
    sms: list[SmRun]  # each one's read SyncManager
    offsets: list[int]  # each one's buffer in the datagram's data, ascending, apart
    rows: npt.NDArray[np.intp] | slice  # each one's row of the chain's memory


class _ImageRead(NamedTuple):
    """An LRD (or LRW) every ESC it reaches reads as one whole buffer
    (:meth:`EcatChain._image_read`)."""

    layouts: int  # Caches.layouts when planned: the plan holds while it stays
    groups: list[_Reads] | None  # the ESCs, by runs of one SyncManager; None: not such a datagram
    escs: int  # how many ESCs
    sync0: npt.NDArray[np.intp] | slice | None  # the rows whose applications sample at SYNC0


# where the ESCs find each datagram's fields in a frame (EcatChain._parse): (command, ADP at, ADO,
# data at, data length, IRQ at), in frame order; destructured where used
_Layout = list[tuple[int, int, int, int, int, int]]


def _plan_image(
    devices: list[EscDevice], targets: list[int], cmd: int, lad: int, n: int, layouts: int
) -> _ImageRead:
    """:meth:`EcatChain._image_read`'s plan for ``devices`` at ``targets``: runs of ESCs whose
    buffers have one SyncManager index, start and length, all buffers apart in the frame."""
    none = _ImageRead(layouts, None, 0, None)
    groups: list[_Reads] = []
    end = 0  # where the buffer before ends in the data
    for dev in devices:
        plan = dev._whole_plan(lad, n, cmd)
        if plan is None:
            return none
        at, sm = plan
        if at < end:
            return none
        end = at + sm.length
        last = groups[-1] if groups else None
        if last is None or (sm.index, sm.start, sm.length) != (
            last.sms[0].index,
            last.sms[0].start,
            last.sms[0].length,
        ):
            last = _Reads([], [], [], slice(0))  # (its rows below, once the runs are known)
            groups.append(last)
        last.devices.append(dev)
        last.sms.append(sm)
        last.offsets.append(at)
    if not groups:
        return none
    at = 0
    for k, group in enumerate(groups):
        size = len(group.devices)
        groups[k] = group._replace(rows=consecutive(np.array(targets[at : at + size], np.intp)))
        at += size
    sampling = [p for p, dev in zip(targets, devices, strict=True) if hasattr(dev.app, "sync0")]
    sync0 = consecutive(np.array(sampling, np.intp)) if sampling else None
    return _ImageRead(layouts, groups, len(devices), sync0)


class EcatChain:
    """Emulated ESCs in a line, the first one's port 0 facing the master.

    Args:
        devices: the ESCs in wiring order.
    """

    def __init__(self, devices: Sequence[EscDevice]) -> None:
        if not 1 <= len(devices) <= MAX_SLAVES:
            raise TopologyError(f"EtherCAT chain: {len(devices)} slaves (1..{MAX_SLAVES})")
        self.devices = list(devices)
        # every ESC's 64 KiB, one a row: a broadcast reads and commits them all at once
        self.memory = np.zeros((len(self.devices), ADDRESS_SPACE), np.uint8)
        for p, (row, dev) in enumerate(zip(self.memory, self.devices, strict=True)):
            dev._use_memory(row.data, line=self.memory, index=p)
        # what the ESCs decode and plan once, this chain's own (no other chain sees it)
        self.caches = Caches()
        for dev in self.devices:
            dev._use_caches(self.caches)
        # every ESC's EscDevice.fmmu_span, one a row, which it keeps up to date: the ESCs a
        # logical datagram may concern are found at once
        self.fmmu_spans = np.zeros((len(self.devices), 2), np.int64)
        for spans, dev in zip(self.fmmu_spans, self.devices, strict=True):
            dev._use_span_row(spans)
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
        self._input_widths = [dev.info.input_bytes for dev in self.devices]  # (publish)
        # the slave applications' reactions to the frame that just passed (AL control, mailbox
        # events), run once it has passed (run_firmware), as a slave's firmware reacts to the
        # events its ESC signals
        self.firmware: list[tuple[EscDevice, int]] = []
        # the positions by configured address (_addressed), and the register bytes it is of
        self._address_key = b""
        self._address_index: dict[int, list[int]] = {}
        for dev in self.devices:
            dev.firmware_queue = self.firmware
        # LRDs of whole input buffers planned (_image_read), by command, address, length and
        # the ESCs the frame reaches
        self._image_reads: dict[tuple[int, int, int, int], _ImageRead] = {}
        # whole buffers read over rows in this frame, exchanged at its end (_end_frames)
        self._exchanges: list[_Reads] = []
        # how far frames go and whether they are marked (_run_planned), and the event requests
        # ORed, as of the Caches.links and Caches.events they were worked out at
        self._loop = _Loop(-1, 0, False, False)
        self._irq_seen = (-1, -1)
        self._irq_all = 0
        # where a well-formed frame's datagrams lie, with their length words (_parse)
        self._layouts: dict[tuple[int, int, int], list[tuple[int, int]]] = {}

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
        return cls(skin_devices(nodes, input_bytes, config=config, mailbox=mailbox))

    @classmethod
    def configured(
        cls,
        nodes: int,
        input_bytes: int,
        *,
        logical_base: int = 0,
        station_base: int = STATION_BASE,
        devices: Sequence[EscDevice] = (),
    ) -> EcatChain:
        """Skin patches, then ``devices`` (ESI slaves, for example), configured as a master
        leaves them, in OP.

        The configuration runs through frames (:func:`configure_line_frames`): station
        addresses ``station_base + position``, the mailbox SyncManagers as in the SII, each
        slave's process-data SyncManagers with an FMMU each, the inputs at ``logical_base``
        plus the input bytes of the slaves before it (a line of patches: ``position *
        input_bytes``), the outputs after every input, then INIT -> PREOP -> SAFEOP -> OP.
        """
        line = skin_devices(nodes, input_bytes) + list(devices)
        if not 1 <= len(line) <= MAX_SLAVES:
            raise TopologyError(f"EtherCAT chain: {len(line)} slaves (1..{MAX_SLAVES})")
        chain = cls(line)
        infos = [dev.info for dev in chain.devices]
        for frame in configure_line_frames(infos, logical_base, station_base):
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

    @property
    def input_offsets(self) -> tuple[int, ...]:
        """Where each slave's inputs start in the line's input image: the logical address the
        configuration maps them to (:func:`process_data_addresses`; a line of patches:
        position x input bytes)."""
        return tuple(at for at, _ in process_data_addresses([d.info for d in self.devices]))

    def publish(self, rows: npt.ArrayLike | Iterable[bytes]) -> None:
        """Each slave's application writes its next input buffer: one row per slave.

        Called between frames, so that every frame sees one consistent sample per slave; rows
        of other lengths than the slaves' inputs change nothing (TopologyError). What each
        patch's :meth:`SkinPatchApplication.publish` does, for the line at once: each patch
        holds its row (:meth:`~SkinPatchApplication.hold_inputs`) and, unless it samples at
        SYNC0 (:attr:`EscDevice.dc_sampling`), writes it; those whose inputs are their image
        all at once, through the rows of :attr:`memory` (:func:`pdi_write_rows`). Patch by
        patch, publishing had set serve's round-trip p99 at 160 patches (benchmarks/README).
        """
        arr: npt.NDArray[np.uint8] | None = None
        if isinstance(rows, np.ndarray):
            arr = np.ascontiguousarray(rows, dtype=np.uint8)
            if arr.ndim != 2 or arr.shape[0] != len(self.devices):
                raise TopologyError(f"publish: rows of shape {arr.shape} for {len(self)} slaves")
            blob, width = arr.tobytes(), arr.shape[1]  # (one copy: a row's tobytes costs 0.1 us)
            data = [blob[at : at + width] for at in range(0, len(blob), width)]
        else:  # rows of bytes, or of what an array of bytes takes (lists of ints, bytearrays)
            data = [_row_bytes(p, row) for p, row in enumerate(cast("Iterable[object]", rows))]
            if len(data) != len(self.devices):
                raise TopologyError(f"publish: {len(data)} rows for {len(self)} slaves")
        widths = self._input_widths
        if [len(row) for row in data] != widths:  # (before any patch holds its row)
            p = next(p for p, row in enumerate(data) if len(row) != widths[p])
            raise TopologyError(f"publish: {len(data[p])} bytes for slave {p}, of {widths[p]}")
        devices, where = self.devices, []  # those whose inputs go as they are, all at start
        start: int | None = None
        for p, dev in enumerate(devices):
            app = dev.app
            if not isinstance(app, SkinPatchApplication):
                raise TopologyError(f"slave {dev.position}: not a skin patch application")
            at = app.hold_inputs(data[p])
            if dev.dc_sampling:
                continue  # sampled at the next SYNC0 pulse
            if at is None:  # laid out by the PDO assignment: as the patch alone publishes
                app.publish(dev, data[p])
            elif at == start or start is None:
                start = at
                where.append(p)
            else:  # (another start: patches made apart)
                dev.pdi_write(at, data[p])
        if start is None:
            return
        if len(where) == len(devices):
            block = arr if arr is not None else _rows_of(data)
            pdi_write_rows(devices, self.memory, slice(0, len(devices)), start, block)
        else:
            block = arr[where] if arr is not None else _rows_of([data[p] for p in where])
            at_rows = np.array(where, np.intp)
            pdi_write_rows([devices[p] for p in where], self.memory, at_rows, start, block)

    def __len__(self) -> int:
        return len(self.devices)

    # --- frames -----------------------------------------------------------------------------
    def process_frame(self, frame: bytes | bytearray) -> bytes | None:
        """Pass an Ethernet frame through the chain; the frame as it returns to the master,
        after which the slaves' applications have reacted to it (:meth:`run_firmware`).

        Returns:
            The returned frame (same length), or None when the ESCs destroy it: a non-EtherCAT
            frame at an ESC whose DL control forwarding rule destroys them, a malformed
            EtherCAT frame, or a port forced open without a link.
        """
        back = self._run(frame)
        self.run_firmware()
        return back

    def answer(self, frame: bytes | bytearray) -> bytes | None:
        """:meth:`process_frame` up to the returned frame: the ESCs' work, the applications'
        reactions still to come (:meth:`run_firmware`; the next frame runs them first if
        nobody did). A live transport answers the master first, as a slave's ESC returns the
        frame while its firmware is yet to see the events (AL control, mailbox) it raised."""
        return self._run(frame)

    def run_firmware(self) -> None:
        """The slaves' applications react to the frames that passed (the ESM to AL control, the
        mailbox to its SyncManager events, ETG.1000.6 6.4, 5.6), slave by slave in chain order:
        what :meth:`EscDevice.end_frame` left for them. The event requests the applications
        changed (0x0210 through AL status, SyncManager events) are brought up to date once all
        reacted, over the rows of those whose request changed (:func:`react_together`).
        """
        queue = self.firmware
        while queue:
            work = sorted(queue, key=lambda w: w[0].position)  # stable: each slave's in order
            queue.clear()
            react_together(work, self.memory)

    def _run(self, frame: bytes | bytearray) -> bytes | None:
        if self.firmware:  # reactions to the frame before, not yet run: first them
            self.run_firmware()
        self.frames += 1
        self.timebase.frame_ns = self.clock_ns()
        buf = bytearray(frame)
        parsed = self._parse(buf)
        if parsed is None:
            return self._non_ecat(buf)
        if not parsed:
            self._drop(malformed=True)
            return None
        return self._run_planned(buf, parsed)

    def _run_planned(self, buf: bytearray, layout: _Layout) -> bytes | None:
        """The processing of :meth:`_pass` ESC by ESC, in an order that gives the same bytes:
        datagram by datagram, each through the ESCs it reaches.

        An ESC's work on a datagram depends only on its own earlier datagrams of the frame and
        on the datagram's bytes as the ESCs before it left them, and a loop change waits for the
        end of the frame (datasheet II 2.4.1), so how far the frame goes is known when it
        arrives. A datagram goes only to the ESCs it can concern: an auto-increment one to the
        ESC whose position makes ADP 0, a configured-address one to the ESCs with that station
        address (or alias), a logical one to the ESCs whose FMMUs map part of it. A broadcast or
        read-multiple-write of plain registers is read or written at every ESC at once through
        the rows of :attr:`memory` (:meth:`_everyone`), and the ESCs whose frame left the same
        register writes commit them together (:meth:`_end_frames`). Work per frame is thus
        bounded by what the frame asks of each ESC, mostly by the frame alone.
        """
        devices = self.devices
        self._exchanges.clear()  # (none left by a frame before)
        caches = self.caches
        loop = self._line_loop()
        links, reach, lost, mac_bit = loop.links, loop.reach, loop.lost, loop.mac
        line = devices[:reach] if reach < len(devices) else devices
        adps = [buf[adp_at] | buf[adp_at + 1] << 8 for _, adp_at, _, _, _, _ in layout]
        # the ESCs' event requests ORed into every IRQ field (datasheet I Table 3), again where
        # an ESC's changed (Caches.events) or the frame reaches others
        if self._irq_seen != (caches.events, links):
            self._irq_seen, self._irq_all = (caches.events, links), _ored_irq(line)
        irq_all = self._irq_all
        images_only = True  # every datagram an image read (_read_image): nothing else to end
        for k, (cmd, _, ado, data_at, n, irq_at) in enumerate(layout):
            adp = adps[k]
            image: _ImageRead | None = None
            if cmd in EVERYONE:
                wkc_inc, changed = self._everyone(line, cmd, adp, ado, buf, data_at, n)
            else:
                targets: list[int] = []
                wkc_inc, changed = 0, False
                if cmd in AUTO_INCREMENT:
                    pos = -adp & 0xFFFF
                    if pos < reach:
                        targets.append(pos)
                        adp = 0
                elif cmd in CONFIGURED:
                    targets = self._addressed(reach, adp)
                elif cmd in LOGICAL and n:
                    lad = adp | ado << 16
                    if cmd in LRD_OR_LRW:
                        image = self._image_read(line, cmd, lad, n)
                    if image is not None:  # (the chain's plan: every ESC reads a whole buffer)
                        wkc_inc, changed = self._read_image(image, buf, data_at)
                    else:
                        hit = self._reached(line, lad, n)
                        wkc_inc, changed = self._logical(line, hit, cmd, adp, ado, buf, data_at, n)
                for p in targets:
                    dev = line[p]
                    before = dev.irq
                    wkc_inc += dev.process(cmd, adp, ado, buf, data_at, n)[1]
                    changed = changed or dev.irq != before
            images_only = images_only and image is not None
            if changed:
                irq_all = _ored_irq(line)
            if wkc_inc:
                wkc_at = data_at + n
                wkc = (buf[wkc_at] | buf[wkc_at + 1] << 8) + wkc_inc
                buf[wkc_at] = wkc & 0xFF
                buf[wkc_at + 1] = (wkc >> 8) & 0xFF
            if irq_all:
                self._or_irq(buf, irq_at, irq_all)
        for k, (cmd, adp_at, *_) in enumerate(layout):
            if cmd in INCREMENTS:
                adp = (adps[k] + reach) & 0xFFFF
                buf[adp_at] = adp & 0xFF
                buf[adp_at + 1] = adp >> 8
        if caches.links != links:  # (the loop settings change at the end of a frame only)
            mac_bit = any(dev.sets_mac for dev in line)
        self._end_frames(line, images_only=images_only)
        if lost:
            self._drop(malformed=False)
            return None
        if mac_bit:
            buf[6] |= ethercat.RETURNED_MAC_BIT
        return bytes(buf)

    def _logical(
        self,
        line: list[EscDevice],
        targets: list[int],
        cmd: int,
        adp: int,
        ado: int,
        buf: bytearray,
        at: int,
        n: int,
    ) -> tuple[int, bool]:
        """A logical datagram through the ESCs of ``line`` at ``targets`` (those whose FMMUs
        map part of it), in chain order: (the working counter's increment, whether an ESC's
        event request changed). An LRD of a whole input buffer, or an LRW there that the ESC
        does not write, is one call (:meth:`EscDevice._read_buffered`); consecutive ESCs that
        map the datagram onto plain memory with one plan cut (:meth:`EscDevice._access`;
        idle mailboxes are holes in it, :meth:`EscDevice._row_cut`) are done at once over their
        rows (:func:`logical_together`), fewer than :data:`LOGICAL_TOGETHER_MIN` each on its own
        (:meth:`EscDevice._logical`: the per-ESC path, which the rows are proven equal to);
        those of them that read DC
        registers bring them up to the frame's time first (:meth:`EscDevice._refresh_dc`), and
        those that read DL or AL status clear its event afterwards
        (:meth:`EscDevice._clear_read_events`); any other ESC on its own, as
        :meth:`EscDevice.process`.
        """
        lad = adp | ado << 16
        wkc_inc, changed = 0, False
        run: list[int] = []  # consecutive targets whose plan cut is run_plan, not done yet
        run_plan: LogicalPlan = _UNTOUCHED
        run_shadow: tuple[LogicalOp, ...] = ()  # and whose register writes (Access.shadow)
        events: list[tuple[int, int]] = []  # (target, the events its reads clear) of the run
        clocks: list[tuple[int, tuple[tuple[int, int], ...]]] = []  # (target, DC registers read)

        def plain() -> tuple[int, bool]:  # the run: over its rows when long enough
            if len(run) < LOGICAL_TOGETHER_MIN:  # else each ESC as on its own
                inc, cleared = 0, False
                for q in run:
                    dev = line[q]
                    before = dev.irq
                    inc += dev._logical(cmd, lad, buf, at, n)
                    cleared = cleared or dev.irq != before
                return inc, cleared
            for q, registers in clocks:  # DC registers at the frame's time, then the reads
                line[q]._refresh_dc(registers)
            devices = [line[q] for q in run] if run_shadow else []
            inc = logical_together(self.memory, run, run_plan, cmd, buf, at, n, run_shadow, devices)
            cleared = False  # then each ESC's reads of DL or AL status clear their events
            for q, bits in events:
                cleared = line[q]._clear_read_events(bits) or cleared
            return inc, cleared

        # what _access gave the last ESC asked (None: ask), and what it follows from: the
        # next ESC with the same decoded FMMU and SyncManager tables, PDI state and register
        # write plans gets it (an Access holds what it worked out for the tables last asked:
        # an ESC on its own may ask it for others, so then it is asked again)
        found: Access | None = None
        fmmus: object = None
        areas: object = None
        pdi = False
        writes: object = None
        for p in targets:
            dev = line[p]
            if run:
                if found is None or not (
                    dev.fmmu_decoded is fmmus
                    and dev.sm_areas is areas
                    and dev.pdi_operational == pdi
                    and dev.write_plans is writes
                ):
                    found = dev._access(cmd, lad, n)
                    fmmus, areas = dev.fmmu_decoded, dev.sm_areas
                    pdi, writes = dev.pdi_operational, dev.write_plans
                cut = dev._row_cut(found)  # where it holds at this ESC now
                if cut == _UNTOUCHED:
                    continue  # it does nothing with the datagram's bytes
                if cut == run_plan and found.shadow == run_shadow:
                    run.append(p)
                    if found.events:
                        events.append((p, found.events))
                    if found.dc:
                        clocks.append((p, found.dc))
                    continue
                inc, cleared = plain()
                wkc_inc, changed = wkc_inc + inc, changed or cleared
                run, events, clocks = [], [], []  # the ESCs before this one are done
            before = dev.irq
            done = dev._logical_unless_rows(cmd, lad, buf, at, n)
            found = None
            if isinstance(done, int):
                wkc_inc += done
                changed = changed or dev.irq != before
            else:  # a run starts, even one that does nothing: the next are asked _access
                assert done.cut is not None  # and it holds here (row_cut)
                run, run_plan, run_shadow = [p], done.cut, done.shadow
                if done.events:
                    events.append((p, done.events))
                if done.dc:
                    clocks.append((p, done.dc))
        if run:
            inc, cleared = plain()
            wkc_inc, changed = wkc_inc + inc, changed or cleared
        return wkc_inc, changed

    def _reached(self, line: list[EscDevice], lad: int, n: int) -> list[int]:
        """The positions in ``line`` whose FMMUs map part of ``n`` logical bytes at ``lad``
        (their spans, :attr:`fmmu_spans`)."""
        spans = self.fmmu_spans[: len(line)]
        return ((spans[:, 0] < lad + n) & (spans[:, 1] > lad)).nonzero()[0].tolist()

    def _image_read(self, line: list[EscDevice], cmd: int, lad: int, n: int) -> _ImageRead | None:
        """An LRD (or LRW) of ``n`` bytes at ``lad`` that every ESC it reaches reads as one
        whole buffer (:meth:`EscDevice._whole_plan`), all of one SyncManager index, start and
        length and apart in the frame (a master's read of the process image): its plan, worked
        out once while the ESCs' FMMUs and SyncManagers stay (:attr:`Caches.layouts`), unless an
        ESC samples its inputs at SYNC0 now (:attr:`EscDevice.dc_sampling`); else None."""
        key = (cmd, lad, n, len(line))
        found = self._image_reads.get(key)
        if found is None or found.layouts != self.caches.layouts:
            reached = self._reached(line, lad, n)
            devices = [line[p] for p in reached]
            plan = _plan_image(devices, reached, cmd, lad, n, self.caches.layouts)
            found = remember(self._image_reads, key, plan, PLAN_CACHE_ENTRIES)
        if found.groups is None:
            return None
        sync0 = found.sync0  # 0x0981 bits 0-1 both set at one of them (dc_sampling)?
        if sync0 is not None and self.memory[sync0, REG_DC_ACTIVATION].tobytes().translate(
            None, _NOT_SAMPLING
        ):
            return None
        return found

    def _read_image(self, image: _ImageRead, buf: bytearray, at: int) -> tuple[int, bool]:
        """The whole buffers of ``image`` read into the datagram's data at ``buf[at:]``, over
        the rows (:func:`read_buffers`), exchanged at the end of the frame: (the working
        counter's increment, whether an ESC's event request changed)."""
        assert image.groups is not None
        changed = False
        for reads in image.groups:
            changed = (
                read_buffers(
                    reads.devices, reads.sms, at, reads.offsets, self.memory, reads.rows, buf
                )
                or changed
            )
        self._exchanges.extend(image.groups)
        return image.escs, changed

    def _everyone(
        self, line: list[EscDevice], cmd: int, adp: int, ado: int, buf: bytearray, at: int, n: int
    ) -> tuple[int, bool]:
        """A broadcast, ARMW or FRMW datagram at every ESC of ``line``: (the working counter's
        increment, whether an ESC's event request changed).

        On registers below 0x0F80 it is done for all ESCs at once: a BRD ORs their rows (and
        clears the DL and AL status events, datasheet I Table 3), a BRW of registers too, each
        ESC bringing DC registers it reads up to the frame's time first
        (:meth:`_refresh_dc`) and writing at its read/write offset (0x0108) in registers or,
        where that offset puts the write, ESC by ESC in user or process RAM; a write that only
        waits for the end of the frame (not the reset register) is one (address, data) in each
        ESC's shadow writes (datasheet I 3.4, Table 7), and the ESCs an ARMW/FRMW addresses read
        in turn. One of no bytes beyond the registers (a BRW's write too, at the read/write
        offset) does nothing at any ESC. Elsewhere (user and process RAM, the reset register, a
        BRW whose write meets the reset register or straddles 0x0F80) each ESC in turn
        (:meth:`EscDevice.process`).
        """
        end, reach, memory = ado + n, len(line), self.memory
        if not n and ado >= REGISTER_END and (cmd != BRW or self._writes_beyond(line, ado)):
            return 0, False  # no byte, no register: no ESC reads or writes
        if cmd == BWR:
            if _plain_write(ado, end):
                # the one (address, data) in a list, which each ESC's extends: compiled, a
                # tuple appended is boxed anew at each ESC (a tuple is a C struct to mypyc)
                entry = [(ado, bytes(buf[at : at + n]))]
                due = latches(ado, n)
                for dev in line:
                    dev.pending.extend(entry)
                    dev.latch_due = dev.latch_due or due
                return reach, False
        elif cmd == BRD:
            if _registers(ado, end):
                if reads_dc(ado, end):  # each ESC's DC registers at the frame's time first
                    self._refresh_dc(line, ado, end)
                ored = np.bitwise_or.reduce(memory[:reach, ado:end])
                buf[at : at + n] = (ored | np.frombuffer(buf, np.uint8, n, at)).tobytes()
                events = cleared_events(ado, end)
                return reach, bool(events) and self._clear_events(line, events)
        elif cmd == BRW:
            if _registers(ado, end):
                frame = np.frombuffer(buf, np.uint8, n, at).copy()
                offsets = memory[:reach, REG_RW_OFFSET : REG_RW_OFFSET + 2]
                to: int | list[int]  # where the ESCs write
                if (offsets == offsets[0]).all():  # one offset, as a master leaves it
                    to = (ado + (int(offsets[0, 0]) | int(offsets[0, 1]) << 8)) & 0xFFFF
                    where = {to}
                else:  # read/write offsets that differ (hostile writes): each ESC's own
                    tos = (ado + (offsets[:, 0] | offsets[:, 1].astype(np.int64) << 8)) & 0xFFFF
                    to = each = tos.tolist()
                    where = set(each)
                if all(_plain_write(t, t + n) or t >= REGISTER_END for t in where):
                    if reads_dc(ado, end):
                        self._refresh_dc(line, ado, end)
                    writes, changed = self._read_write(line, to, buf, at, frame, ado)
                    events = cleared_events(ado, end)  # once each ESC read them
                    changed = (bool(events) and self._clear_events(line, events)) or changed
                    return reach + 2 * writes, changed
        elif _plain_write(ado, end):  # ARMW, FRMW: read at the addressed ESCs, write at the others
            return self._read_multiple_write(line, cmd, adp, ado, buf, at, n)
        total, changed = 0, False
        step = 1 if cmd in INCREMENTS else 0
        for p, dev in enumerate(line):
            before = dev.irq
            total += dev.process(cmd, (adp + step * p) & 0xFFFF, ado, buf, at, n)[1]
            changed = changed or dev.irq != before
        return total, changed

    def _writes_beyond(self, line: list[EscDevice], ado: int) -> bool:
        """Whether every ESC of ``line`` writes a BRW at ``ado`` beyond the registers: at
        ``ado`` plus its read/write offset (0x0108), from 0x0F80 on."""
        offsets = self.memory[: len(line), REG_RW_OFFSET : REG_RW_OFFSET + 2].astype(np.int64)
        return bool(((ado + (offsets[:, 0] | offsets[:, 1] << 8)) & 0xFFFF >= REGISTER_END).all())

    @staticmethod
    def _refresh_dc(line: list[EscDevice], lo: int, hi: int) -> None:
        """Every ESC of ``line`` brings its DC registers among [lo, hi) up to the frame's time,
        as before a read of them (:meth:`EscDevice._refresh_dc`)."""
        registers = ((lo, hi),)
        for dev in line:
            dev._refresh_dc(registers)

    def _clear_events(self, line: list[EscDevice], events: int) -> bool:
        """The ESCs of ``line`` read the registers that clear ``events`` (0x0210 bits); whether
        an ESC's event request changed."""
        column = self.memory[: len(line), REG_ECAT_EVENT]
        hit = (column & events).nonzero()[0].tolist()
        if hit:
            column &= ~events & 0xFF
        if not hit:
            return False
        changed = False
        for p in hit:
            dev = line[p]
            before = dev.irq
            dev.update_irq()
            changed = changed or dev.irq != before
        return changed

    def _read_multiple_write(
        self, line: list[EscDevice], cmd: int, adp: int, ado: int, buf: bytearray, at: int, n: int
    ) -> tuple[int, bool]:
        """An ARMW or FRMW whose write is plain (:func:`_plain_write`): the addressed ESCs read
        (each in turn, with whatever side effects their read has), every other ESC puts the
        data as it arrives among its shadow writes (datasheet I Table 7)."""
        reach = len(line)
        readers = [-adp & 0xFFFF] if cmd == ARMW else self._addressed(reach, adp)
        plain = _plain_read(ado, ado + n)
        entry = [(ado, bytes(buf[at : at + n]))]  # (in a list, as _everyone's BWR has it)
        first, total, changed = 0, 0, False
        for p in readers:
            if p >= reach:
                break
            for dev in line[first:p]:
                dev.pending.extend(entry)
            total += p - first
            dev = line[p]
            if plain:
                buf[at : at + n] = self.memory[p, ado : ado + n].tobytes()
                total += 1
            else:
                before = dev.irq
                total += dev.process(cmd, 0 if cmd == ARMW else adp, ado, buf, at, n)[1]
                changed = changed or dev.irq != before
            entry, first = [(ado, bytes(buf[at : at + n]))], p + 1
        for dev in line[first:]:
            dev.pending.extend(entry)
        return total + reach - first, changed

    def _read_write(
        self,
        line: list[EscDevice],
        to: int | list[int],
        buf: bytearray,
        at: int,
        frame: npt.NDArray[np.uint8],
        ado: int,
    ) -> tuple[int, bool]:
        """A BRW of plain registers: each ESC writes at ``to`` (one address for all, or each
        ESC's own, its read/write offset after ``ado``) the data as it arrives (read before
        write, datasheet I Table 7), then ORs its registers into it: (how many ESCs wrote,
        whether an ESC's event request changed). A write of plain registers waits for the end
        of the frame; one in user or process RAM (where the read/write offset puts it) is done
        at that ESC as an APWR of the data there would do it."""
        n = len(frame)
        ored = _or_accumulate(self.memory[: len(line), ado : ado + n])
        ored |= frame  # ored[p]: the data as ESC p leaves it
        tos = [to] * len(line) if isinstance(to, int) else to
        writes, changed = len(line), False
        # the data as each ESC receives it, n bytes an ESC (one copy out of numpy, not a row's
        # index and copy at each ESC)
        arriving = frame.tobytes() + ored[:-1].tobytes()
        for p, dev in enumerate(line):
            data = arriving[p * n : (p + 1) * n]
            if tos[p] < REGISTER_END:
                dev.pending.append((tos[p], data))
                continue
            before = dev.irq
            writes -= 1 - dev.process(APWR, 0, tos[p], bytearray(data), 0, n)[1]
            changed = changed or dev.irq != before
        buf[at : at + n] = ored[-1].tobytes()
        return writes, changed

    def _end_frames(self, line: list[EscDevice], *, images_only: bool = False) -> None:
        """Every ESC of ``line`` ends the frame (:meth:`EscDevice.end_frame`); those with equal
        register writes (a broadcast's, one configuration) commit them together, and finish the
        frame together (:func:`finish_together`), and so do those whose writes differ only in
        their bytes (a logical datagram's through FMMUs onto registers, a BRW's, or broadcasts
        that met different bytes: groups of equal writes commit as one), and so, in one pass,
        do the rest of one configuration whose writes differ in their addresses too (through
        FMMUs that differ from ESC to ESC, :func:`commit_apart`), when they are many; of those
        without writes only the ones with something to finish are asked
        (:meth:`EscDevice._unfinished`).
        ESCs commit independently of each other, so the groups may go in any order, and so may
        the reactions they queue for the slaves' firmware, each to its own ESC. The whole
        buffers read over rows are exchanged last (:func:`finish_reads`). After a frame of
        image reads only (``images_only``) no ESC has a write, a buffer or its mailbox handler
        to finish (those a frame leaves are finished at its end), so only an ESC with an ESC
        reset under way, which such a frame breaks off, ends it as well."""
        if images_only:
            for dev in line:
                if dev._reset_progress:  # 'R' (and 'E') written to 0x0040 before (II 0x0040)
                    break
            else:
                self._exchange()
                return
        groups: dict[tuple[object, ...], list[int]] = {}
        last: list[tuple[int, bytes]] = []  # the pending writes of the ESC before, its group
        plans: object = None
        group: list[int] = []
        idle: list[EscDevice] = []
        for p, dev in enumerate(line):
            pending = dev.pending
            if not pending:
                idle.append(dev)
            elif pending == last and dev.write_plans is plans:  # mostly the same entries
                group.append(p)
            else:
                last, plans = pending, dev.write_plans
                group = groups.setdefault((id(plans), *pending), [])
                group.append(p)
        for dev in EscDevice._unfinished(idle):
            dev.end_frame()
        shapes: dict[tuple[object, ...], list[list[int]]] = {}  # groups by addresses, lengths
        for key, positions in groups.items():
            shape = (key[0], *((a, len(d)) for a, d in line[positions[0]].pending))
            shapes.setdefault(shape, []).append(positions)
        alone: dict[int, list[int]] = {}  # by configuration: ESCs few of which write alike
        for members in shapes.values():
            if len(members) == 1 and len(members[0]) >= TOGETHER_MIN:
                self._commit(line, members[0], alike=True)
                continue
            positions = sorted(p for group in members for p in group)
            if len(positions) < TOGETHER_MIN:
                alone.setdefault(id(line[positions[0]].write_plans), []).extend(positions)
            else:  # one commit, not one a group: each costs a pass over rows and a DC compare
                self._commit(line, positions, alike=False)
        for positions in alone.values():  # writes that differ in address too (hostile FMMUs)
            positions.sort()
            together = [line[p] for p in positions]
            rows = np.array(positions, dtype=np.intp)
            if len(positions) >= TOGETHER_MIN and commit_apart(together, self.memory, rows):
                finish_together(together, self.memory, rows)
                continue
            for dev in together:
                dev.end_frame()
        self._exchange()

    def _exchange(self) -> None:
        """The whole buffers read over rows in the frame are exchanged (:func:`finish_reads`),
        after the ESCs' register writes took effect."""
        for exchange in self._exchanges:
            finish_reads(exchange.devices, exchange.sms, self.memory, exchange.rows)
        self._exchanges.clear()

    def _commit(self, line: list[EscDevice], positions: list[int], *, alike: bool) -> None:
        """The ESCs of ``line`` at ``positions`` commit their register writes together and end
        the frame (:func:`commit_together`, :func:`finish_together`)."""
        together = [line[p] for p in positions]
        rows = np.array(positions, dtype=np.intp)
        commit_together(together, self.memory, rows, alike=alike)
        finish_together(together, self.memory, rows)

    def _addressed(self, reach: int, adp: int) -> list[int]:
        """Positions among the first ``reach`` whose station address 0x0010 is ``adp``, or
        their alias 0x0012 where DL control bit 24 enables it (datasheet I 2.3; the registers
        as the frame found them: shadowed, I 3.4). The index of addresses is the chain's own,
        made again only when those registers changed (one compare of their bytes a frame)."""
        memory = self.memory
        regs = memory[:reach, REG_STATION : REG_ALIAS + 2]
        key = regs.tobytes() + memory[:reach, REG_DL_CONTROL + 3].tobytes()
        if key != self._address_key:
            index: dict[int, list[int]] = {}
            for p, (s0, s1, _, _) in enumerate(regs.tolist()):
                index.setdefault(s0 | s1 << 8, []).append(p)
            for p in np.flatnonzero(memory[:reach, REG_DL_CONTROL + 3] & 0x01).tolist():
                found = index.setdefault(int(regs[p, 2]) | int(regs[p, 3]) << 8, [])
                if p not in found:
                    found.append(p)
                    found.sort()
            self._address_key, self._address_index = key, index
        return list(self._address_index.get(adp, ()))  # (the caller's to change)

    @staticmethod
    def _or_irq(buf: bytearray, at: int, irq: int) -> None:
        buf[at] |= irq & 0xFF
        buf[at + 1] |= irq >> 8

    def _parse(self, buf: bytearray) -> _Layout | None:
        """Where the ESC finds each datagram's fields: (cmd, ADP at, ADO, data at, length, IRQ
        at). None for a non-EtherCAT frame; an empty list for a malformed one.

        The datagrams are found as :func:`skinframes.ethercat.decode` finds them. Where it found
        nothing to remark (a well-formed frame), where they lie is kept (:attr:`_layouts`, by
        frame length, EtherCAT header offset and header word) with each datagram's length word
        (length, M bit): a frame that has the same words there has its datagrams in the same
        places (the walk reads nothing else), so it is not decoded again."""
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
        key = (len(buf), payload_at, buf[payload_at] | buf[payload_at + 1] << 8)
        known = self._layouts.get(key)
        if known is not None:
            found: _Layout = []
            for pos, word in known:
                cmd, _, _, ado, now, _ = ethercat.datagram_head(buf, pos)
                if now != word:
                    break
                found.append(
                    (cmd, pos + 2, ado, pos + 10, word & ethercat.MAX_LENGTH_FIELD, pos + 8)
                )
            else:
                return found
        try:
            ecat, _, findings = ethercat.decode(bytes(buf[payload_at:]), strict=False)
        except DecodeError:
            return []
        if ecat.frame_type != ethercat.FrameType.ECAT:
            return None
        layout = []
        words: list[tuple[int, int]] = []
        pos = payload_at + ethercat.FRAME_HEADER_BYTES
        for d in ecat.datagrams:
            n = len(d.data)
            layout.append((int(d.cmd), pos + 2, d.ado, pos + 10, n, pos + 8))
            words.append((pos, ethercat.datagram_head(buf, pos)[4]))
            pos += ethercat.DATAGRAM_OVERHEAD_BYTES + n
        if not findings and words:
            remember(self._layouts, key, words, PLAN_CACHE_ENTRIES)
        return layout

    @staticmethod
    def _pass(dev: EscDevice, buf: bytearray, layout: _Layout) -> None:
        """One ESC's processing unit executes every datagram of the frame in ``buf``, in place."""
        process = dev.process
        for cmd, adp_at, ado, data_at, n, irq_at in layout:
            adp = buf[adp_at] | buf[adp_at + 1] << 8
            new_adp, inc = process(cmd, adp, ado, buf, data_at, n)
            if new_adp != adp:
                buf[adp_at] = new_adp & 0xFF
                buf[adp_at + 1] = new_adp >> 8
            if inc:
                wkc_at = data_at + n
                wkc = (buf[wkc_at] | buf[wkc_at + 1] << 8) + inc
                buf[wkc_at] = wkc & 0xFF
                buf[wkc_at + 1] = (wkc >> 8) & 0xFF
            irq = dev.irq
            if irq:
                buf[irq_at] |= irq & 0xFF
                buf[irq_at + 1] |= irq >> 8

    def _line_loop(self) -> _Loop:
        """How far a frame goes along the line now (:func:`_loop`, worked out again once an
        ESC's forwarding or MAC marking changed)."""
        links = self.caches.links
        if self._loop.links != links:
            self._loop = _loop(self.devices, links)
        return self._loop

    def _non_ecat(self, buf: bytearray) -> bytes | None:
        """A frame that is not EtherCAT: destroyed by an ESC it reaches that marks the source
        MAC (DL control bit 0 = 1, datasheet II 2.4.1), lost at one forced open without a link
        as any frame is, else back unchanged."""
        loop = self._line_loop()
        if loop.mac or loop.lost:
            self._drop(malformed=False)
            return None
        return bytes(buf)

    def _drop(self, *, malformed: bool) -> None:
        self.dropped += 1
        if malformed:
            self._count_malformed()

    def _count_malformed(self) -> None:
        """A malformed frame: the first ESC's processing unit counts it (0x030C); it forwards
        the frame marked as an error, which every ESC after it counts as a forwarded error at
        port 0 (0x0308) and in its processing unit (datasheet II 0x0308, 0x030C): how a master
        localises the fault. The frame goes as far as the ports let it."""
        for p in range(self._line_loop().reach):
            dev = self.devices[p]
            if p:
                dev.count_error(REG_FORWARDED_ERRORS)
            dev.count_frame_error()

    # --- the timing emulator's view -----------------------------------------------------------
    def frame_effect(self, ecat: EcatFrame) -> FrameEffect:
        """What each ESC does to ``ecat`` as it passes in processing direction (processed for
        real, ESC by ESC, with end-of-frame effects): the form the timing engine caches.

        The chain's state moves on as for any frame (a skin patch's LRD changes nothing that a
        later LRD would see).
        """
        self.run_firmware()  # reactions to the frame before, if any were left
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
                self._pass(dev, buf, layout)
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
        self.run_firmware()
        return FrameEffect(ecat, tuple(slaves), frozenset(marks), self.input_offsets)

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
    input_offsets: tuple[int, ...]  # where each position's inputs start in the input image

    def wkc(self, acting: Container[int]) -> int:
        """The sum of the returned working counters when the ESCs in ``acting`` process it."""
        return sum(d.wkc for d in self.sent.datagrams) + sum(
            sum(s.wkc) for s in self.slaves if s.position in acting
        )

    def returned(
        self, acting: Container[int], taxels: npt.NDArray[np.uint8] | None
    ) -> tuple[EcatFrame, bool]:
        """The frame after the ESCs in ``acting`` processed it, and whether one marked its
        source MAC. ``taxels``: the chain's input image (every slave's inputs, at
        ``input_offsets``), or None to leave the input bytes as sent."""
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
                base = self.input_offsets[s.position]
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
            (at[k] + off, self.input_offsets[s.position] + src, n)
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
    inputs = _input_area(dev.info)
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
            run = _input_run(c, inputs)
            if run is not None and lo <= run[0] < lo + n:
                dst, src, length = run
                runs.append((k, dst - lo, src, length))
                copied[dst - lo : dst - lo + length] = b"\x01" * length
        if after[lo : lo + n] != before[lo : lo + n]:
            diff = np.frombuffer(after, np.uint8, n, lo) != np.frombuffer(before, np.uint8, n, lo)
            changed = np.flatnonzero(diff & (np.frombuffer(bytes(copied), np.uint8) == 0))
            if len(changed):  # register data the ESC wrote: one run, first to last change
                a, b = int(changed[0]), int(changed[-1]) + 1
                const.append((k, a, bytes(after[lo + a : lo + b])))
    if not any(wkc) and not any(adp) and not const and not runs:
        return None
    return SlaveEffect(dev.position, tuple(wkc), tuple(adp), tuple(runs), tuple(const))


def _input_area(info: SlaveInfo) -> tuple[int, int]:
    """[start, end) of a slave's input buffer in its memory: its input SyncManager's start and
    the bytes of its inputs."""
    sm = info.sm_of_type(SyncManagerType.INPUTS)
    start = 0 if sm is None else info.sync_managers[sm].start
    return start, start + info.input_bytes


def _input_run(c: TraceCopy, inputs: tuple[int, int]) -> tuple[int, int, int] | None:
    """(offset in the frame, offset in the slave's inputs, bytes) of the input bytes copy ``c``
    carried: a SyncManager buffer's, or the part of plain memory that lies in the input buffer
    ``inputs`` (an input SyncManager of 1 byte is not activated: datasheet II 2.14, 0x0802);
    None when it carried none."""
    if c.sm >= 0:
        return c.dst, c.src, c.length
    lo, hi = max(c.src, inputs[0]), min(c.src + c.length, inputs[1])
    if lo >= hi:
        return None
    return c.dst + lo - c.src, lo - inputs[0], hi - lo


def _row_bytes(position: int, row: object) -> bytes:
    """A row given to :meth:`EcatChain.publish` as bytes: what an array of bytes takes (bytes, a
    bytearray, a list of ints); values outside 0..255 are a TopologyError (a ValueError, as
    ``bytes`` raises), a row of another type stays a TypeError."""
    if type(row) is bytes:
        return row
    try:
        return np.asarray(row, np.uint8).tobytes()
    except (OverflowError, ValueError) as exc:
        raise TopologyError(f"publish: the row of slave {position}: {exc}") from exc


def _rows_of(data: Sequence[bytes]) -> npt.NDArray[np.uint8]:
    """Rows of bytes, all of one length, as an array (a row each)."""
    return np.frombuffer(b"".join(data), np.uint8).reshape(len(data), -1)


def skin_devices(
    nodes: int, input_bytes: int, *, config: EscConfig | None = None, mailbox: bool = False
) -> list[EscDevice]:
    """``nodes`` skin patches of ``input_bytes`` each, powered on; serial numbers the
    positions + 1 (:meth:`SlaveInfo.skin_patch`)."""
    return [
        EscDevice(SlaveInfo.skin_patch(input_bytes, serial=i + 1, mailbox=mailbox), config=config)
        for i in range(nodes)
    ]
