"""EtherCAT: a master and n ESC slaves in an open or closed ring, carrying real frames.

The master sends the cycle's frames back to back (one IFG apart). Each frame passes every slave:
the chain's addressing rules (:mod:`emulator.esc`) decide which slave writes its taxels into
which datagram and how the working counters grow, and every slave sets bit 0x02 of the first
source-MAC octet, as real ESCs do. Slaves process on the fly, so a frame's bits are delayed by a
fixed latency per hop and never stored: in the open ring the frame crosses every cable twice and
passes each ESC once in processing and once in forwarding direction (the last slave loops it back);
in the closed ring it runs from the master's first port through all slaves to its second port.

The cycle ends when the last frame is back at the master plus one IFG: that is the paper's
eq. (12) when the paper preset's constants are used, and the physics otherwise.
"""

from __future__ import annotations

from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.esc import EscChain
from emulator.limits import check_cycles, check_ecat
from emulator.params import TimingParams
from emulator.result import CycleDetail, SimResult, node_payloads
from emulator.trace import CycleTrace
from skinframes import ethercat, ethernet
from skinframes.ethercat import Command, Datagram, EcatFrame

__all__ = ["LAYOUTS", "frames_for", "path_latency_ps", "returned_frame", "simulate_ecat"]

LAYOUTS: Final = ("per-slave", "logical")


def frames_for(nodes: int, data_bytes: int, layout: str = "per-slave") -> list[EcatFrame]:
    """The frames a master sends each cycle to read ``data_bytes`` of taxels from every slave.

    ``per-slave``: one LRD per slave (the paper's telegram per node), packed into as few frames as
    fit (eq. 15). ``logical``: the slaves' inputs form one contiguous logical image, read with the
    fewest LRD datagrams of up to 1486 bytes (one per frame), as masters such as TwinCAT and SOEM
    map process data.
    """
    check_ecat(nodes, data_bytes)
    if layout == "per-slave":
        dgs = [
            Datagram.logical(Command.LRD, i * data_bytes, bytes(data_bytes), idx=i & 0xFF)
            for i in range(nodes)
        ]
        return ethercat.pack_datagrams(dgs)
    if layout == "logical":
        total = nodes * data_bytes
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


def path_latency_ps(nodes: int, params: TimingParams, redundant: bool) -> int:
    """Delay of a bit from the master's port out through the chain and back to the master."""
    if redundant:  # closed ring: n + 1 cables, one processing pass per slave
        return (nodes + 1) * params.cable_ps + nodes * params.ecat_processing_ps
    # open ring: n cables crossed twice; processing out, forwarding (or loop-back) home
    return 2 * nodes * params.cable_ps + nodes * (
        params.ecat_processing_ps + params.ecat_forwarding_ps
    )


def forwarding_latency_ps(nodes: int, params: TimingParams) -> int:
    """Closed ring: a frame from the master's second port through every ESC in forwarding
    direction (port 1 -> 0) back to the first port."""
    return (nodes + 1) * params.cable_ps + nodes * params.ecat_forwarding_ps


def second_port_copy(frame: bytes) -> bytes:
    """The copy of a frame a redundancy master sends out of its second port (its own MAC)."""
    return frame[:6] + ethercat.MASTER_MAC_SECOND + frame[12:]


def simulate_ecat(
    nodes: int,
    data_bytes: int,
    params: TimingParams,
    *,
    redundant: bool = False,
    layout: str = "per-slave",
    cycles: int = 4,
    seed: int = 0,
    payloads: npt.NDArray[np.uint8] | None = None,
) -> SimResult:
    """Emulate ``cycles`` EtherCAT cycles reading ``data_bytes`` of taxels from each slave.

    ``payloads`` (cycles, nodes, data_bytes) uint8 are the taxel bytes the slaves publish (e.g.
    the samples of a CAN trace); seeded contact patterns when None.

    In the closed ring the master runs cable redundancy (ETG.1000.4, as TwinCAT and SOEM do): it
    sends each frame out of both ports. The frame from the first port passes every ESC in
    processing direction and arrives at the second port; the copy from the second port passes
    them in forwarding direction, unprocessed, and arrives at the first. If the ring breaks, both
    come back processed by the slaves on their side (see :mod:`emulator.ecat_faults`).

    Returns:
        The result, whose trace holds every frame at the master's port(s) (sent and returned).
    """
    check_cycles(cycles)
    sent_frames = frames_for(nodes, data_bytes, layout)
    chain = EscChain(nodes, data_bytes)
    taxels = node_payloads(payloads, cycles, nodes, data_bytes, seed).reshape(cycles, -1)

    sent: list[bytes] = []
    returned: list[bytes] = []
    gather: list[list[tuple[int, int, int]]] = []
    expected_wkc = 0
    for f in sent_frames:
        sent.append(ethercat.frame(f).to_bytes())
        back, copies = returned_frame(f, chain)
        expected_wkc += sum(d.wkc for d in back.datagrams)
        returned.append(ethercat.frame(back, returned=True).to_bytes())
        gather.append(copies)

    # timing at the master's port(s) (integer ps)
    wire = np.array([params.frame_ps(len(b)) for b in sent], dtype=np.int64)
    tx = np.concatenate(([0], np.cumsum(wire + params.ifg_ps)[:-1]))
    rx = tx + path_latency_ps(nodes, params, redundant)
    # one record: (time, port, outbound, bytes, taxel runs to fill in or None)
    recs: list[tuple[int, int, bool, bytes, list[tuple[int, int, int]] | None]] = []
    for k in range(len(sent)):
        recs.append((int(tx[k]), 0, True, sent[k], None))
        recs.append((int(rx[k]), 1 if redundant else 0, False, returned[k], gather[k]))
    if redundant:  # cable redundancy: the master also sends each frame out of its second port
        back_tx = tx + forwarding_latency_ps(nodes, params)
        for k, frame_bytes in enumerate(sent):
            copy = second_port_copy(frame_bytes)
            recs.append((int(tx[k]), 1, True, copy, None))
            recs.append((int(back_tx[k]), 0, False, copy, None))
    recs.sort(key=lambda r: (r[0], r[1], not r[2]))
    cycle_ps = max(r[0] + params.frame_ps(len(r[3])) for r in recs) + params.ifg_ps

    rel = np.array([r[0] for r in recs], dtype=np.int64)
    lengths = np.array([len(r[3]) for r in recs], dtype=np.int64)
    outbound = np.array([r[2] for r in recs], dtype=bool)
    port = np.array([r[1] for r in recs], dtype=np.int64)
    rec_wire = np.array([params.frame_ps(len(r[3])) for r in recs], dtype=np.int64)

    data = np.empty((cycles, int(lengths.sum())), dtype=np.uint8)
    col = 0
    for _, _, _, frame_bytes, runs in recs:
        data[:, col : col + len(frame_bytes)] = np.frombuffer(frame_bytes, dtype=np.uint8)
        for dst, src, n in runs or ():  # each slave's bytes: one contiguous run
            data[:, col + dst : col + dst + n] = taxels[:, src : src + n]
        col += len(frame_bytes)

    starts = np.arange(cycles, dtype=np.int64) * cycle_ps
    trace = CycleTrace(starts[:, None] + rel[None, :], lengths, data, rec_wire, outbound, port)
    details = [
        CycleDetail(c, int(starts[c]), cycle_ps, expected_wkc, expected_wkc) for c in range(cycles)
    ]
    return SimResult(
        "ecat",
        "closed" if redundant else "open",
        nodes,
        data_bytes,
        params.name,
        layout,
        details,
        trace,
    )


def returned_frame(f: EcatFrame, chain: EscChain) -> tuple[EcatFrame, list[tuple[int, int, int]]]:
    """The frame as it comes back (constant part), and where each slave's taxel bytes go.

    Returns:
        (returned frame with zero taxel data, runs of (byte offset in the returned Ethernet
        frame, offset in the chain's flattened input image, length)).
    """
    runs: list[tuple[int, int, int]] = []
    pos = ethernet.HEADER_BYTES + ethercat.FRAME_HEADER_BYTES
    back: list[Datagram] = []
    for d in f.datagrams:
        eff = chain.effect(d)
        data = bytearray(d.data)
        for off, value in eff.constant:
            data[off : off + len(value)] = value
        data_at = pos + ethercat.DATAGRAM_HEADER_BYTES
        runs += [
            (data_at + c.dst, c.slave * chain.input_bytes + c.src, c.length) for c in eff.copies
        ]
        back.append(
            Datagram(
                d.cmd,
                eff.adp,
                d.ado,
                bytes(data),
                d.idx,
                d.irq,
                (d.wkc + eff.wkc_increment) & 0xFFFF,
                d.circulating,
            )
        )
        pos += d.size_bytes
    return EcatFrame(tuple(back)), runs
