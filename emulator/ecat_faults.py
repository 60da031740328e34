"""EtherCAT with faults: each frame walks the chain hop by hop, as the ESCs' ports allow.

The fault-free emulator (:mod:`emulator.ecat_cycle`) computes whole cycles at once; this one
follows every frame through every cable and ESC, which is what broken cables, dead nodes, bit
errors and lost frames need. Without faults both give the same frames at the same times (a test
checks it).

ESC behaviour (Beckhoff ESC datasheet section I, "Frame processing", "Loop control", "Error
counters"; ETG.1000.4):

* a frame entering port 0 passes the EtherCAT processing unit (``ecat_processing_ps``) and leaves
  by port 1; one entering port 1 is forwarded to port 0 (``ecat_forwarding_ps``); a closed port
  loops the frame back (the last slave of an open ring, and both ports next to a break);
* when a link fails, the ports at its ends close ``link_loss_ps`` later; until then a frame sent
  into the dead cable is lost;
* a frame with a CRC error is counted by the port that receives it first (invalid frame counter,
  register 0x0300 + 2 x port) and by every later ESC as a forwarded error (0x0308 + port); no ESC
  processes it, and the master discards it.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from emulator.ecat_cycle import (
    frames_for,
    path_latency_ps,
    returned_frame,
    second_port_copy,
)
from emulator.esc import BROADCAST_CMDS, POSITION_CMDS, DatagramEffect, EscChain
from emulator.faults import Fault, check_faults
from emulator.limits import check_cycles
from emulator.params import TimingParams
from emulator.records import RecordTrace
from emulator.result import CycleDetail, SimResult, node_payloads
from emulator.units import PS_PER_US
from skinframes import ethercat, ethernet

__all__ = ["simulate_ecat_faults"]

COUNTING_CMDS = frozenset(int(c) for c in POSITION_CMDS | BROADCAST_CMDS)
# ESC registers of the error counters (ESC datasheet section II, 0x0300-0x0313)
INVALID_FRAME_REG = 0x0300  # + 2 x port
FORWARDED_ERROR_REG = 0x0308  # + port


@dataclass
class _Walk:
    """Where one frame went."""

    port: int | None  # master port it came back to; None = lost
    arrive_ps: int
    processed: list[int] = field(default_factory=list)  # slave positions 1..n, in order
    corrupted_link: int | None = None


@dataclass
class _Chain:
    """The chain's state: links, port closures, error counters."""

    n: int
    closed_ring: bool
    p: TimingParams
    rng: random.Random
    faults: tuple[Fault, ...]
    break_ps: dict[int, int] = field(default_factory=dict)  # link -> time it failed
    invalid: dict[tuple[int, int], int] = field(default_factory=dict)  # (slave, port) -> count
    forwarded: dict[tuple[int, int], int] = field(default_factory=dict)
    lost: int = 0

    def links(self) -> int:
        return self.n + 1 if self.closed_ring else self.n

    def down(self, link: int, t: int) -> bool:
        b = self.break_ps.get(link)
        return b is not None and t >= b

    def closed(self, link: int, t: int) -> bool:
        b = self.break_ps.get(link)
        return b is not None and t >= b + self.p.ecat_link_loss_ps

    def walk(self, t0: int, from_second_port: bool) -> _Walk:
        """Follow one frame from a master port until it returns to a master port or is lost."""
        n, p = self.n, self.p
        node, d, t = (n + 1, -1, t0) if from_second_port else (0, 1, t0)
        w = _Walk(None, 0)
        corrupted = False
        while True:
            link = node if d > 0 else node - 1
            open_end = not self.closed_ring and link == n  # the last slave's free port 1
            if open_end or self.down(link, t):
                if node in (0, n + 1):  # the master's own cable is down
                    self.lost += 1
                    return w
                if not (open_end or self.closed(link, t)):
                    self.lost += 1  # sent into a dead cable before the port closed
                    return w
                if d > 0:  # port 1 closed: loop back towards port 0 (forwarding path)
                    t += p.ecat_forwarding_ps
                else:  # port 0 closed: loop into the processing unit, out by port 1
                    t += p.ecat_processing_ps
                    if not corrupted:
                        w.processed.append(node)
                d = -d
                continue
            for f in self.faults:
                if f.where == link and f.kind == "drop" and self.rng.random() < f.value:
                    self.lost += 1
                    return w
                if (
                    f.where == link
                    and f.kind == "biterr"
                    and not corrupted
                    and self.rng.random() < f.value
                ):
                    corrupted = True
                    w.corrupted_link = link
                    receiver, rport = (node + 1, 0) if d > 0 else (node - 1, 1)
                    if 1 <= receiver <= n:
                        self.invalid[(receiver, rport)] = self.invalid.get((receiver, rport), 0) + 1
                    node, t = receiver, t + p.cable_ps
                    break
            else:
                node, t = node + d, t + p.cable_ps
                if corrupted and 1 <= node <= n:  # a later ESC sees the frame already invalid
                    key = (node, 0 if d > 0 else 1)
                    self.forwarded[key] = self.forwarded.get(key, 0) + 1
            if node == 0 or node == n + 1:
                w.port, w.arrive_ps = (0 if node == 0 else 1), t
                return w
            if d > 0:
                t += p.ecat_processing_ps
                if not corrupted:
                    w.processed.append(node)
            else:
                t += p.ecat_forwarding_ps


def _apply(
    frame: bytes,
    dg_offsets: list[int],
    effects: list[DatagramEffect],
    processed: list[int],
    taxels: npt.NDArray[np.uint8],
    input_bytes: int,
) -> tuple[bytes, int]:
    """The frame after the given slaves processed it, and its total working counter."""
    buf = bytearray(frame)
    done = {p - 1 for p in processed}  # chain positions are 0-based
    total = 0
    for pos, eff in zip(dg_offsets, effects, strict=True):
        acting = [s for s in eff.slaves if s in done]
        length = int.from_bytes(buf[pos + 6 : pos + 8], "little") & 0x7FF
        wkc_at = pos + 10 + length
        inc = (eff.wkc_increment // len(eff.slaves)) * len(acting) if eff.slaves else 0
        wkc = (int.from_bytes(buf[wkc_at : wkc_at + 2], "little") + inc) & 0xFFFF
        buf[wkc_at : wkc_at + 2] = wkc.to_bytes(2, "little")
        total += wkc
        if buf[pos] in COUNTING_CMDS:  # every processing slave increments the ADP
            adp = (int.from_bytes(buf[pos + 2 : pos + 4], "little") + len(done)) & 0xFFFF
            buf[pos + 2 : pos + 4] = adp.to_bytes(2, "little")
        if acting:
            for off, value in eff.constant:
                buf[pos + 10 + off : pos + 10 + off + len(value)] = value
        for c in eff.copies:
            if c.slave in done:
                src = c.slave * input_bytes + c.src
                at = pos + 10 + c.dst
                buf[at : at + c.length] = taxels[src : src + c.length].tobytes()
    if processed:
        buf[6] |= ethercat.RETURNED_MAC_BIT
    return bytes(buf), total


def simulate_ecat_faults(
    nodes: int,
    data_bytes: int,
    params: TimingParams,
    faults: tuple[Fault, ...],
    *,
    redundant: bool = False,
    layout: str = "per-slave",
    cycles: int = 4,
    seed: int = 0,
    payloads: npt.NDArray[np.uint8] | None = None,
) -> SimResult:
    """Emulate EtherCAT cycles hop by hop with ``faults`` (see :mod:`emulator.faults`)."""
    check_cycles(cycles)
    sent_frames = frames_for(nodes, data_bytes, layout)
    chain_rules = EscChain(nodes, data_bytes)
    state = _Chain(nodes, redundant, params, random.Random(seed), faults)
    check_faults(faults, nodes, state.links(), "ecat")
    taxels = node_payloads(payloads, cycles, nodes, data_bytes, seed).reshape(cycles, -1)

    sent = [ethercat.frame(f).to_bytes() for f in sent_frames]
    effects = [[chain_rules.effect(d) for d in f.datagrams] for f in sent_frames]
    offsets = []
    for f in sent_frames:
        pos, offs = ethernet.HEADER_BYTES + ethercat.FRAME_HEADER_BYTES, []
        for d in f.datagrams:
            offs.append(pos)
            pos += d.size_bytes
        offsets.append(offs)
    expected = sum(
        sum(d.wkc for d in returned_frame(f, chain_rules)[0].datagrams) for f in sent_frames
    )
    wire = [params.frame_ps(len(b)) for b in sent]
    nominal = path_latency_ps(nodes, params, redundant)

    trace = RecordTrace()
    details: list[CycleDetail] = []
    diagnosis: list[str] = []
    recovery_ps: int | None = None
    start = 0
    for c in range(cycles):
        for fault in faults:
            if fault.cycle == c and fault.kind == "cable":
                state.break_ps.setdefault(fault.where, start)
                recovery_ps = params.ecat_link_loss_ps
                diagnosis.append(_break_text(fault, nodes, redundant, params))
            if fault.cycle == c and fault.kind == "power":
                for link in (fault.where - 1, fault.where):
                    if 0 <= link < state.links():
                        state.break_ps.setdefault(link, start)
                recovery_ps = params.ecat_link_loss_ps
                diagnosis.append(_power_text(fault, nodes, redundant))
        t, end, wkc = start, start, 0
        for k, frame in enumerate(sent):
            walks = [(frame, state.walk(t, False))]
            trace.add(t, frame, wire[k], True, 0)
            if redundant:
                copy = second_port_copy(frame)
                walks.append((copy, state.walk(t, True)))
                trace.add(t, copy, wire[k], True, 1)
            for original, w in walks:
                if w.port is None:
                    end = max(end, t + wire[k] + nominal)  # the master waits for it in vain
                    continue
                back, got = _apply(
                    original, offsets[k], effects[k], w.processed, taxels[c], data_bytes
                )
                mark = None
                if w.corrupted_link is not None:
                    mark = (
                        f"skinframes: corrupted on link {w.corrupted_link}.."
                        f"{w.corrupted_link + 1} (injected bit error; FCS mismatch)"
                    )
                    back = _flip_a_data_bit(back, offsets[k][0])
                else:
                    wkc += got
                trace.add(w.arrive_ps, back, wire[k], False, w.port, mark)
                end = max(end, w.arrive_ps + wire[k])
            t += wire[k] + params.ifg_ps
        cycle_ps = end + params.ifg_ps - start
        details.append(CycleDetail(c, start, cycle_ps, wkc, expected))
        start += cycle_ps
    diagnosis += _counter_texts(state)
    if state.lost:
        diagnosis.append(f"{state.lost} frames lost on the way (the master's receive timed out)")
    result = SimResult(
        "ecat",
        "closed" if redundant else "open",
        nodes,
        data_bytes,
        params.name,
        layout,
        details,
        trace.sorted(),
    )
    result.recovery_us = None if recovery_ps is None or not redundant else recovery_ps / PS_PER_US
    result.diagnosis = diagnosis
    return result


def _flip_a_data_bit(frame: bytes, first_datagram: int) -> bytes:
    """The bytes a corrupted frame carries: one bit of the first datagram's data flipped (the
    header stays intact, so Wireshark still dissects it; the FCS would not match)."""
    buf = bytearray(frame)
    at = first_datagram + ethercat.DATAGRAM_HEADER_BYTES
    if at < len(buf):
        buf[at] ^= 0x01
    return bytes(buf)


def _break_text(f: Fault, n: int, redundant: bool, p: TimingParams) -> str:
    k = f.where
    left = "the master" if k == 0 else f"slave {k}"
    right = "the master's second port" if k == n else f"slave {k + 1}"
    if redundant:
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


def _power_text(f: Fault, n: int, redundant: bool) -> str:
    k = f.where
    if redundant:
        return f"node {k} lost power at cycle {f.cycle}: links {k - 1}..{k} and {k}..{k + 1} down"
    lost = f"slaves {k}..{n}" if k < n else f"slave {n}"
    return f"node {k} lost power at cycle {f.cycle}: {lost} unreachable"


def _counter_texts(state: _Chain) -> list[str]:
    out = []
    for (slave, port), count in sorted(state.invalid.items()):
        link = slave - 1 if port == 0 else slave
        reg = INVALID_FRAME_REG + 2 * port
        out.append(
            f"CRC errors on link {link}..{link + 1}: slave {slave} port {port} counted "
            f"{count} invalid frames (register {reg:#06x}); later ESCs counted them as "
            f"forwarded errors ({FORWARDED_ERROR_REG:#06x}+port)"
        )
    return out
