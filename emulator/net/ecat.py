"""The EtherCAT engine: a master and n ESCs in an open or closed ring, frame by frame.

Every cycle the master sends its frames back to back (one IFG apart); each frame walks the chain
hop by hop as the ESCs' ports allow (Beckhoff ESC datasheet section I, "Frame processing", "Loop
control", "Error counters"; ETG.1000.4):

* a frame entering port 0 passes the EtherCAT processing unit (``ecat_processing_ps``) and leaves
  by port 1; one entering port 1 is forwarded to port 0 (``ecat_forwarding_ps``); a closed port
  loops the frame back (the last slave of an open ring, and both ports next to a break);
* in the closed ring the master runs cable redundancy (ETG.1000.4, as TwinCAT and SOEM do): each
  frame also leaves by its second port and passes the ESCs in forwarding direction;
* when a link fails, the ESCs at its ends count a lost link (0x0310 + port) and close the ports
  ``ecat_link_loss_ps`` later; until then a frame sent into the dead cable is lost;
* a bit error on a link flips one bit of the frame's data; the port that receives it counts an
  invalid frame (0x0300 + 2 x port), every later ESC a forwarded error (0x0308 + port), no ESC
  processes it and the master discards it;
* a frame that does not come back within the master's receive timeout (the longest round trip
  the chain allows, through every ESC twice, plus ``DEFAULT_TIMEOUT_MARGIN_PS``) is a loss the
  master counts, as the EPL MN counts a late PRes; the master waits for a lost frame until then.

What each ESC does to a frame comes from the register-level ESC model
(:meth:`emulator.esc.chain.EcatChain.frame_effect`), asked once per frame of the cycle; the
frame that returns is rebuilt by ``skinframes`` from the datagrams the reached ESCs changed.
The cycle ends when the last frame is back at the master plus one IFG (the paper's eq. 12 with
the paper preset's constants).
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc.chain import EcatChain, FrameEffect
from emulator.model.limits import check_ecat, check_emulated_ecat
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_US
from emulator.net.cycle import FILL_NONE, FILL_TAXELS, Cycle, Record
from emulator.net.ecat_line import EcatLine
from emulator.net.faults import Fault, check_faults, corruption_mark
from emulator.net.startup import StartupRecord, run_startup
from emulator.slave.esi_slave import EsiSlave
from skinframes import ethercat, ethernet, vlan
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.vlan import VlanTag

__all__ = [
    "DEFAULT_TIMEOUT_MARGIN_PS",
    "LAYOUTS",
    "EcatEngine",
    "EcatTiming",
    "frames_for",
    "line_frames",
    "path_latency_ps",
    "per_slave_frame_lengths",
    "send_times_ps",
]

LAYOUTS: Final = ("per-slave", "logical")
# The receive timeout of a master (and the EPL MN's PRes timeout): the nominal round trip plus
# this margin (DS 301 NMT_MNCNPResTimeout and SOEM's EC_TIMEOUTRET are the integrator's choice).
DEFAULT_TIMEOUT_MARGIN_PS: Final = 25_000_000
# ESC error counters (ESC datasheet section II 2.6, 0x0300-0x0313)
INVALID_FRAME_REG: Final = 0x0300  # + 2 x port
FORWARDED_ERROR_REG: Final = 0x0308  # + port
LOST_LINK_REG: Final = 0x0310  # + port


def frames_for(nodes: int, data_bytes: int, layout: str = "per-slave") -> list[EcatFrame]:
    """The frames a master sends each cycle to read ``data_bytes`` of taxels from every slave
    (:func:`line_frames` of ``nodes`` equal slaves)."""
    check_ecat(nodes, data_bytes)
    return line_frames([data_bytes] * nodes, layout)


def line_frames(input_bytes: Sequence[int], layout: str = "per-slave") -> list[EcatFrame]:
    """The frames a master sends each cycle to read every slave's inputs, slave ``p`` having
    ``input_bytes[p]`` of them, mapped one after another from logical address 0
    (:func:`emulator.esc.chain.process_data_addresses`).

    ``per-slave``: one LRD per slave with inputs (the paper's telegram per node; index: the
    position, modulo 256), packed into as few frames as fit (eq. 15). ``logical``: the slaves'
    inputs form one contiguous logical image, read with the fewest LRD datagrams of up to 1486
    bytes (one per frame), as masters such as TwinCAT and SOEM map process data.
    """
    if layout == "per-slave":
        offsets = np.cumsum([0, *input_bytes]).tolist()
        dgs = [
            Datagram.logical(Command.LRD, offsets[i], bytes(n), idx=i & 0xFF)
            for i, n in enumerate(input_bytes)
            if n
        ]
        return ethercat.pack_datagrams(dgs)
    if layout == "logical":
        total = sum(input_bytes)
        step = ethercat.MAX_DATAGRAM_DATA_BYTES
        return [
            EcatFrame(
                (
                    Datagram.logical(
                        Command.LRD, off, bytes(min(step, total - off)), idx=(off // step) & 0xFF
                    ),
                )
            )
            for off in range(0, total, step)
        ]
    raise TopologyError(f"unknown layout {layout!r}; choose from {list(LAYOUTS)}")


def per_slave_frame_lengths(nodes: int, sizes: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """(frames, len(sizes)): the lengths (as captured) of the frames :func:`frames_for` builds
    in the ``per-slave`` layout, one column per size, 0 past a column's last frame.

    Equal datagrams of 12 + b bytes pack max_tgram to a frame (eq. 15, ETG.1000.4 Table 12/13),
    the last frame the rest; short frames are padded to 60 bytes (802.3 minimum).
    """
    for b in (int(sizes.min()), int(sizes.max())):
        check_ecat(nodes, b)
    per_dg = ethercat.DATAGRAM_OVERHEAD_BYTES + sizes.astype(np.int64)
    per_frame = (ethernet.MAX_PAYLOAD_BYTES - ethercat.FRAME_HEADER_BYTES) // per_dg
    frames = -(-nodes // per_frame)
    k = np.arange(int(frames.max()), dtype=np.int64)[:, None]
    count = np.clip(nodes - k * per_frame, 0, per_frame)
    length = ethernet.HEADER_BYTES + ethercat.FRAME_HEADER_BYTES + count * per_dg
    return np.where(count > 0, np.maximum(length, ethernet.MIN_FRAME_BYTES), 0)


def path_latency_ps(nodes: int, params: TimingParams, closed_ring: bool) -> int:
    """Delay of a bit from the master's (first) port through the chain back to the master."""
    if closed_ring:  # n + 1 cables, one processing pass per slave
        return (nodes + 1) * params.cable_ps + nodes * params.ecat_processing_ps
    # open ring: n cables crossed twice; processing out, forwarding (or loop-back) home
    return 2 * nodes * params.cable_ps + nodes * (
        params.ecat_processing_ps + params.ecat_forwarding_ps
    )


def forwarding_latency_ps(nodes: int, params: TimingParams) -> int:
    """Closed ring: from the master's second port through every ESC in forwarding direction."""
    return (nodes + 1) * params.cable_ps + nodes * params.ecat_forwarding_ps


Ps = Any  # a time in ps: an int, or an int64 array of them (timing-only sweeps)


def send_times_ps(
    start_ps: int, wire_ps: npt.NDArray[np.int64], ifg_ps: int
) -> npt.NDArray[np.int64]:
    """When the master starts each frame of a cycle: back to back from ``start_ps``, one IFG
    apart (axis 0: the frames, in order; ETG.1000.4 cyclic frames, paper eq. 12's n_fr T_eth)."""
    step = wire_ps + ifg_ps
    return start_ps + np.cumsum(step, axis=0) - step


@dataclass
class _Walk:
    """Where one frame went."""

    port: int | None  # the master port it came back to; None = lost on the way
    arrive_ps: Ps
    processed: list[int] = field(default_factory=list)  # chain positions 0..n-1, in order
    corrupted_link: int | None = None


Trip = tuple[_Walk, bool, Ps]  # where a frame went, back in time, when the master is done


class EcatTiming:
    """The timing of an EtherCAT chain: how frames walk it hop by hop (the same for the full
    engine, :class:`EcatEngine`, and for timing-only sweeps, :meth:`cycle_ps`).

    Args:
        closed_ring: the master's second port closes the ring (cable redundancy).
        faults: the fault plan (:mod:`emulator.net.faults`); empty for a healthy network.
        seed: the random faults' seed.
    """

    def __init__(
        self,
        nodes: int,
        params: TimingParams,
        *,
        closed_ring: bool = False,
        faults: tuple[Fault, ...] = (),
        seed: int = 0,
    ) -> None:
        self.nodes, self.params, self.closed_ring = nodes, params, closed_ring
        self.topology = "closed" if closed_ring else "open"
        self.links = nodes + 1 if closed_ring else nodes
        check_faults(faults, nodes, self.links, "ecat")
        self.faults = faults
        self.rng = random.Random(seed)
        # the longest way a frame can take (out and back through every ESC, as in an open ring
        # or a closed ring broken next to a master port) plus the margin
        longest = path_latency_ps(nodes, params, False) + 2 * params.cable_ps
        self.timeout = [longest + DEFAULT_TIMEOUT_MARGIN_PS] * 2
        self.late_ps = {f.where - 1: round(f.value * PS_PER_US) for f in faults if f.kind == "late"}
        self.chance = tuple(f for f in faults if f.kind in ("biterr", "drop") and f.value > 0)
        self.break_ps: dict[int, int] = {}  # link -> the time it failed

    @property
    def ports(self) -> tuple[int, ...]:
        """The master ports that send each frame: both in the closed ring."""
        return (0, 1) if self.closed_ring else (0,)

    def trip(self, t: Ps, wire: Ps, port: int, events: Counter[tuple[object, ...]]) -> Trip:
        """A frame of ``wire`` ps sent by master ``port`` at ``t``: where it went, whether it
        came back before the master's receive timeout, and when the master is done with it (its
        end at the master, or the timeout's end when it was lost)."""
        w = self._walk(t, port == 1, events)
        deadline = t + self.timeout[port]
        if w.port is None:
            events[("lost", port)] += 1
            return w, False, deadline + wire
        if np.any(w.arrive_ps > deadline):
            events[("lost", port)] += 1
            events[("late",)] += 1
            return w, False, w.arrive_ps + wire
        return w, True, w.arrive_ps + wire

    def cycle_ps(self, wire_ps: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        """Timing only: one steady-state cycle for each of several frame sets at once.

        ``wire_ps`` is (frames, cells): column j holds the wire times of the frames a master
        sends each cycle in cell j (0 past its last frame). Each frame walks the chain as in
        :meth:`EcatEngine.cycle` (numpy time arrays instead of ints); no bytes, no ESC model.

        Returns:
            (cells,) cycle times in ps.

        Raises:
            TopologyError: a fault plan; a sweep is of healthy networks only.
        """
        if self.faults:
            raise TopologyError("EtherCAT timing sweep: a healthy network only (no faults)")
        events: Counter[tuple[object, ...]] = Counter()
        sends = send_times_ps(0, wire_ps, self.params.ifg_ps)
        end = np.zeros(wire_ps.shape[1:], dtype=np.int64)
        for port in self.ports:
            _, _, done = self.trip(sends, wire_ps, port, events)
            end = np.maximum(end, np.where(wire_ps > 0, done, 0).max(axis=0))
        if events:
            raise TopologyError(f"EtherCAT timing sweep: frames lost in a healthy chain {events}")
        return np.asarray(end + self.params.ifg_ps, dtype=np.int64)

    # --- the chain ----------------------------------------------------------------------------
    def _fail(self, link: int, t: int, events: Counter[tuple[object, ...]]) -> None:
        if link in self.break_ps:
            return
        self.break_ps[link] = t
        for slave, port in ((link, 1), (link + 1, 0)):  # the ESCs at both ends lose the link
            if 1 <= slave <= self.nodes:
                events[("link", slave, port)] += 1

    def _down(self, link: int, t: Ps) -> bool:
        b = self.break_ps.get(link)
        return b is not None and t >= b

    def _closed(self, link: int, t: Ps) -> bool:
        b = self.break_ps.get(link)
        return b is not None and t >= b + self.params.ecat_link_loss_ps

    def _walk(self, t0: Ps, from_second_port: bool, events: Counter[tuple[object, ...]]) -> _Walk:
        """Follow one frame from a master port until it is back at a master port or lost
        (``t0``: an int, or an array of send times of frames that all take the same way)."""
        n, p, late = self.nodes, self.params, self.late_ps
        node, d, t = (n + 1, -1, t0) if from_second_port else (0, 1, t0)
        w = _Walk(None, 0)
        corrupted = False
        while True:
            link = node if d > 0 else node - 1
            open_end = not self.closed_ring and link == n  # the last slave's free port 1
            if open_end or self._down(link, t):
                if node in (0, n + 1):  # the master's own cable is down
                    return w
                if not (open_end or self._closed(link, t)):
                    return w  # sent into a dead cable before the port closed
                if d > 0:  # port 1 closed: loop back towards port 0 (forwarding path)
                    t = t + p.ecat_forwarding_ps
                else:  # port 0 closed: loop into the processing unit, out by port 1
                    t = t + p.ecat_processing_ps + late.get(node - 1, 0)
                    if not corrupted:
                        w.processed.append(node - 1)
                d = -d
                continue
            hit = self._cross(link)
            if hit == "drop":
                return w
            node, t = node + d, t + p.cable_ps
            receiver_port = 0 if d > 0 else 1
            if hit == "biterr" and not corrupted:
                corrupted = True
                w.corrupted_link = link
                if 1 <= node <= n:
                    events[("invalid", node, receiver_port)] += 1
            elif corrupted and 1 <= node <= n:  # a later ESC sees the frame already invalid
                events[("forwarded", node, receiver_port)] += 1
            if node == 0 or node == n + 1:
                w.port, w.arrive_ps = (0 if node == 0 else 1), t
                return w
            if d > 0:
                t = t + p.ecat_processing_ps + late.get(node - 1, 0)
                if not corrupted:
                    w.processed.append(node - 1)
            else:
                t = t + p.ecat_forwarding_ps

    def _cross(self, link: int) -> str | None:
        """Chance faults on one crossing of ``link``: None, 'drop' or 'biterr'."""
        for f in self.chance:
            if f.where == link and self.rng.random() < f.value:
                return f.kind
        return None


class EcatEngine(EcatTiming):
    """EtherCAT cycles of ``nodes`` skin patches with ``data_bytes`` of taxels each, then the
    slaves ``esi`` (:class:`emulator.net.ecat_line.EcatLine`).

    Args:
        closed_ring: the master's second port closes the ring (cable redundancy).
        layout: ``per-slave`` or ``logical`` (see :func:`frames_for`).
        faults: the fault plan (:mod:`emulator.net.faults`); empty for a healthy network.
        seed: the random faults' seed.
        esi: slaves ESI files describe, after the patches.
    """

    protocol: Final = "ecat"
    period: Final = 1  # every cycle of a steady state is the same

    def __init__(
        self,
        nodes: int,
        data_bytes: int,
        params: TimingParams,
        *,
        closed_ring: bool = False,
        layout: str = "per-slave",
        faults: tuple[Fault, ...] = (),
        seed: int = 0,
        startup: bool = False,
        tags: tuple[VlanTag, ...] = (),
        esi: tuple[EsiSlave, ...] = (),
    ) -> None:
        self.line = EcatLine(nodes, data_bytes, esi)
        check_emulated_ecat(self.line.nodes, data_bytes)
        super().__init__(self.line.nodes, params, closed_ring=closed_ring, faults=faults, seed=seed)
        self.tags = tags  # VLAN tags on every frame (IEEE 802.1Q); their bytes count on the wire
        self.tag_shift = vlan.TAG_BYTES * len(tags)  # where the EtherCAT bytes move in a frame
        self.sent = line_frames(self.line.input_sizes, layout)
        self.patches, self.data_bytes, self.layout = nodes, data_bytes, layout
        self.out = [ethercat.frame(f, tags=tags).to_bytes() for f in self.sent]
        self.out2 = [
            ethercat.frame(f, src=ethercat.MASTER_MAC_SECOND, tags=tags).to_bytes()
            for f in self.sent
        ]
        self.wire = [params.frame_ps(len(b)) for b in self.out]
        self._runs: dict[tuple[int, frozenset[int]], tuple[tuple[int, int, int], ...]] = {}
        # startup: patches with a CoE mailbox taken to OP by the start-up frames, timed by this
        # engine's walk (emulator.net.startup); else configured without frames on the wire
        self.startup: list[StartupRecord] = []
        if startup:
            if faults or closed_ring or tags:
                raise TopologyError(
                    "the start-up runs on an open ring without faults or VLAN tags only"
                )
            self.chain = EcatChain(self.line.devices(mailbox=True))
            self.chain.timebase.params = params  # DC latches: this preset's hops (dc.py)
            self.startup = run_startup(
                self.chain,
                lambda t: self._walk(t, False, Counter()).arrive_ps,
                params.frame_ps,
                params.ifg_ps,
            )
        else:
            self.chain = EcatChain.configured(0, data_bytes, devices=self.line.devices())
        self.effects: list[FrameEffect] = [self.chain.frame_effect(f) for f in self.sent]
        everyone = range(self.nodes)
        self.expected_wkc = sum(e.wkc(everyone) for e in self.effects)

    # --- what the driver asks -----------------------------------------------------------------
    def event_at(self, cycle: int) -> bool:
        """Does the fault plan change the network at the start of ``cycle``?"""
        return any(f.cycle == cycle and f.kind in ("cable", "power") for f in self.faults)

    def next_event(self, cycle: int) -> int | None:
        """The first cycle after ``cycle`` at whose start the fault plan changes the network."""
        later = [f.cycle for f in self.faults if f.kind in ("cable", "power") and f.cycle > cycle]
        return min(later) if later else None

    def cycle(self, c: int, start_ps: int, taxels: npt.NDArray[np.uint8] | None) -> Cycle:
        """Walk cycle ``c`` starting at ``start_ps``; ``taxels`` (nodes x data_bytes) to build
        the frames' bytes, None for timing only."""
        p = self.params
        events: Counter[tuple[object, ...]] = Counter()
        for f in self.faults:
            if f.cycle == c and f.kind == "cable":
                self._fail(f.where, start_ps, events)
            if f.cycle == c and f.kind == "power":
                for link in (f.where - 1, f.where):
                    if 0 <= link < self.links:
                        self._fail(link, start_ps, events)
        image = None if taxels is None else self.image(np.array([c]), taxels[None])[0]
        steady = not self.chance and all(
            start_ps >= b + p.ecat_link_loss_ps for b in self.break_ps.values()
        )
        records: list[Record] = []
        end, wkc = start_ps, 0
        sends = send_times_ps(start_ps, np.array(self.wire, dtype=np.int64), p.ifg_ps).tolist()
        for k, eff in enumerate(self.effects):
            wire, t = self.wire[k], sends[k]
            for port in self.ports:
                frame = (self.out if port == 0 else self.out2)[k]
                records.append(
                    Record(
                        t - start_ps,
                        port,
                        True,
                        len(frame),
                        wire,
                        frame if image is not None else None,
                    )
                )
                w, in_time, done = self.trip(t, wire, port, events)
                end = max(end, done)  # when lost: the master waited for it in vain
                if w.port is None:
                    continue
                acting = tuple(w.processed)
                back, runs = self._back(k, port, acting, image)
                mark = None
                if w.corrupted_link is not None:
                    events[("crc", w.corrupted_link)] += 1
                    j = w.corrupted_link
                    mark = corruption_mark(j)
                    bit = self._data_bit(k)  # drawn in timing-only runs too: same chances
                    if back is not None:
                        back = ethernet.flip_bit(back, bit)
                elif in_time:
                    wkc += eff.wkc(acting)
                records.append(
                    Record(
                        w.arrive_ps - start_ps,
                        w.port,
                        False,
                        len(frame),
                        wire,
                        back,
                        FILL_TAXELS if runs and mark is None else FILL_NONE,
                        runs if mark is None else (),
                        -1,
                        mark,
                    )
                )
        records.sort(key=lambda r: (r.rel_ps, r.port, not r.outbound))
        return Cycle(
            tuple(records), end + p.ifg_ps - start_ps, wkc, self.expected_wkc, events, steady
        )

    def image(
        self, cycles: npt.NDArray[np.int64], taxels: npt.NDArray[np.uint8]
    ) -> npt.NDArray[np.uint8]:
        """(k, bytes): the line's input image in cycles ``cycles`` whose patches hold ``taxels``
        (k, patches, data_bytes) (:meth:`EcatLine.image`)."""
        return self.line.image(cycles, taxels)

    def account(self, cyc: Cycle, times: int) -> None:
        """Count what ``cyc`` counted ``times`` over, in the ESCs' error counters."""
        registers = {
            "invalid": INVALID_FRAME_REG,
            "forwarded": FORWARDED_ERROR_REG,
            "link": LOST_LINK_REG,
        }
        for key, count in cyc.events.items():
            base = registers.get(str(key[0]))
            if base is None:
                continue
            slave, port = int(str(key[1])), int(str(key[2]))
            reg = base + (2 * port if key[0] == "invalid" else port)
            self.chain.count(reg, slave - 1, count * times)

    def diagnosis(self, events: Counter[tuple[object, ...]]) -> list[str]:
        """What the master and the ESCs' counters tell about the run, in words."""
        out = [self._break_text(f) for f in self.faults if f.kind == "cable"]
        out += [self._power_text(f) for f in self.faults if f.kind == "power"]
        for slave in range(1, self.nodes + 1):
            for port in (0, 1):
                count = self.chain.counter(INVALID_FRAME_REG + 2 * port, slave - 1)
                if count:
                    link = slave - 1 if port == 0 else slave
                    out.append(
                        f"CRC errors on link {link}..{link + 1}: slave {slave} port {port} counted "
                        f"{count} invalid frames (register {INVALID_FRAME_REG + 2 * port:#06x}); "
                        f"later ESCs counted them as forwarded errors "
                        f"({FORWARDED_ERROR_REG:#06x}+port)"
                    )
        lost = sum(v for k, v in events.items() if k[0] == "lost")
        if lost:
            late = events[("late",)]
            text = f"{lost} frames lost on the way (the master's receive timed out)"
            if late:
                text += f", {late} of them came back after the timeout"
            out.append(text)
        return out

    def _back(
        self, k: int, port: int, acting: tuple[int, ...], image: npt.NDArray[np.uint8] | None
    ) -> tuple[bytes | None, tuple[tuple[int, int, int], ...]]:
        """Frame ``k`` as it returns after the ESCs ``acting`` processed it (sent by ``port``),
        built by skinframes with ``image``'s taxels (None: timing only, no bytes), and where
        the taxels sit in it (for the fast path)."""
        done = frozenset(acting)
        key = (k, done)
        runs = self._runs.get(key)
        if runs is None:
            shift = self.tag_shift
            runs = tuple((at + shift, src, n) for at, src, n in self.effects[k].taxel_runs(done))
            if len(self._runs) < 4096:
                self._runs[key] = runs
        if image is None:
            return None, runs
        back, mac = self.effects[k].returned(done, image)
        src = ethercat.MASTER_MAC if port == 0 else ethercat.MASTER_MAC_SECOND
        return ethercat.frame(back, src=src, returned=mac, tags=self.tags).to_bytes(), runs

    def _data_bit(self, k: int) -> int:
        """A bit of frame ``k``'s datagram data, drawn at random: a bit error hits the data,
        not the headers, so that Wireshark still dissects the frame it captured."""
        spans = [
            (at + self.tag_shift, len(d.data))
            for at, d in zip(
                ethercat.data_offsets(self.sent[k]), self.sent[k].datagrams, strict=True
            )
            if d.data
        ]
        total = sum(n for _, n in spans)
        pick = self.rng.randrange(8 * total) if total else 8 * (len(self.out[k]) - 1)
        for at, n in spans:
            if pick < 8 * n:
                return 8 * at + pick
            pick -= 8 * n
        return pick

    def rebuild(
        self, record: Record, starts_ps: npt.NDArray[np.int64], taxels: npt.NDArray[np.uint8]
    ) -> npt.NDArray[np.uint8]:
        """EtherCAT frames change per cycle only where the ESCs write taxels (FILL_TAXELS)."""
        raise TopologyError(f"EtherCAT: no frame is rebuilt per cycle (fill {record.fill})")

    # --- diagnosis texts ----------------------------------------------------------------------
    def _break_text(self, f: Fault) -> str:
        k, n, p = f.where, self.nodes, self.params
        left = "the master" if k == 0 else f"slave {k}"
        right = "the master's second port" if k == n else f"slave {k + 1}"
        if self.closed_ring:
            return (
                f"link {k}..{k + 1} down at cycle {f.cycle}: {left} and {right} closed their "
                f"ports after {p.ecat_link_loss_ps / PS_PER_US:g} us; every slave is reached "
                "from one of the master's two ports"
            )
        lost = f"slaves {k + 1}..{n}" if k + 1 < n else f"slave {n}"
        return (
            f"link {k}..{k + 1} down at cycle {f.cycle}: {left} loops the frames back; "
            f"{lost} unreachable (DL status of {left}: port 1 without link)"
        )

    def _power_text(self, f: Fault) -> str:
        k, n = f.where, self.nodes
        if self.closed_ring:
            return (
                f"node {k} lost power at cycle {f.cycle}: links {k - 1}..{k} and {k}..{k + 1} down"
            )
        lost = f"slaves {k}..{n}" if k < n else f"slave {n}"
        return f"node {k} lost power at cycle {f.cycle}: {lost} unreachable"
