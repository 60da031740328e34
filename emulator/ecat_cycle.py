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

__all__ = ["LAYOUTS", "frames_for", "path_latency_ps", "simulate_ecat"]

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

    Returns:
        The result, whose trace holds every frame at the master's port (sent and returned).
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
        back, copies = _returned(f, chain)
        expected_wkc += sum(d.wkc for d in back.datagrams)
        returned.append(ethercat.frame(back, returned=True).to_bytes())
        gather.append(copies)

    # timing at the master's port (integer ps)
    wire = np.array([params.frame_ps(len(b)) for b in sent], dtype=np.int64)
    tx = np.concatenate(([0], np.cumsum(wire + params.ifg_ps)[:-1]))
    rx = tx + path_latency_ps(nodes, params, redundant)
    cycle_ps = int(rx[-1] + wire[-1] + params.ifg_ps)

    # records of one cycle in time order: (time, is_returned, frame index)
    order = sorted(
        [(int(t), 0, k) for k, t in enumerate(tx)] + [(int(t), 1, k) for k, t in enumerate(rx)]
    )
    rel = np.array([t for t, _, _ in order], dtype=np.int64)
    lengths = np.array([len(sent[k]) for _, _, k in order], dtype=np.int64)
    outbound = np.array([is_back == 0 for _, is_back, _ in order], dtype=bool)
    rec_wire = np.array([wire[k] for _, _, k in order], dtype=np.int64)

    data = np.empty((cycles, int(lengths.sum())), dtype=np.uint8)
    col = 0
    for _, is_back, k in order:
        frame_bytes = returned[k] if is_back else sent[k]
        data[:, col : col + len(frame_bytes)] = np.frombuffer(frame_bytes, dtype=np.uint8)
        if is_back:
            for dst, src, n in gather[k]:  # each slave's bytes: one contiguous run
                data[:, col + dst : col + dst + n] = taxels[:, src : src + n]
        col += len(frame_bytes)

    starts = np.arange(cycles, dtype=np.int64) * cycle_ps
    trace = CycleTrace(starts[:, None] + rel[None, :], lengths, data, rec_wire, outbound)
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


def _returned(f: EcatFrame, chain: EscChain) -> tuple[EcatFrame, list[tuple[int, int, int]]]:
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
