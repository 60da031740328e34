"""Ethernet POWERLINK: an MN and n CNs in a daisy chain of hubs, carrying real frames.

Each node has a hub in front of it (the MN too, as the paper's eq. 8 counts), joined by 0.01 m
cables; a frame between the MN and CN i therefore crosses i + 1 hubs and cables each way. Per
cycle the MN sends a SoC, then polls each CN in turn with a PReq and waits for its PRes (taxel
payload), then sends a SoA; the cycle closes after the idle period. Timing (DS 301 4.2.4.1 and
paper eqs. 3-11):

* SoC, then one IFG before the first PReq (eq. 4);
* a CN answers ``epl_cn_delay_ps`` after the end of its PReq (D_CN), the MN sends its next
  frame ``epl_mn_delay_ps`` after the end of a PRes (D_MN) -- at least an IFG in the wire preset;
* SoA, one IFG, and the idle period before the next SoC (eq. 10, T_id).
"""

from __future__ import annotations

from typing import Final

import numpy as np

from emulator.errors import TopologyError
from emulator.params import TimingParams
from emulator.result import CycleDetail, SimResult
from emulator.trace import CycleTrace
from emulator.units import PS_PER_NS, PS_PER_US
from skinframes import powerlink, taxel
from skinframes.pcap import NS_PER_S

__all__ = ["hops_to", "simulate_epl"]

EPOCH_S: Final = 1_700_000_000  # NetTime of cycle 0 in the SoC (a fixed, reproducible epoch)


def hops_to(cn: int) -> int:
    """Hubs (and cables) between the MN and CN number ``cn`` (1-based): the MN's own and CNs 1..cn."""
    return cn + 1


def simulate_epl(
    nodes: int,
    data_bytes: int,
    params: TimingParams,
    *,
    cycles: int = 4,
    seed: int = 0,
) -> SimResult:
    """Emulate ``cycles`` EPL cycles: n CNs each answering with ``data_bytes`` of taxels."""
    if not 1 <= nodes <= powerlink.MAX_CN_NODE_ID:
        raise TopologyError(f"EPL: {nodes} CNs (1..{powerlink.MAX_CN_NODE_ID})")
    if not 0 <= data_bytes <= powerlink.MAX_PDO_PAYLOAD_BYTES:
        raise TopologyError(
            f"EPL: {data_bytes} payload bytes (0..{powerlink.MAX_PDO_PAYLOAD_BYTES})"
        )
    if cycles < 1:
        raise TopologyError(f"cycles must be >= 1, not {cycles}")
    n = nodes
    cns = np.arange(1, n + 1)
    payloads = taxel.sample_payloads(n, cycles, data_bytes, seed=seed)

    preq = np.stack(
        [np.frombuffer(powerlink.frame(powerlink.PReq(int(i))).to_bytes(), np.uint8) for i in cns]
    )
    pres = powerlink.pack_pres_frames(
        payloads.reshape(cycles * n, data_bytes), np.tile(cns, cycles)
    ).reshape(cycles, n, -1)
    soa = powerlink.frame(powerlink.SoA()).to_bytes()
    soc_len = len(powerlink.frame(powerlink.SoC()).to_bytes())
    lq, ls = preq.shape[1], pres.shape[2]

    # --- timing of one cycle, relative to its SoC (integer ps) ---
    p = params
    soc_wire, preq_wire, pres_wire = p.frame_ps(soc_len), p.frame_ps(lq), p.frame_ps(ls)
    hops = (cns + 1).astype(np.int64)  # hops_to(i), vectorised
    per_cn = (
        preq_wire
        + 2 * hops * p.hop_ps
        + p.gap_ps(p.epl_cn_delay_ps)
        + pres_wire
        + p.gap_ps(p.epl_mn_delay_ps)
    )
    preq_t = soc_wire + p.ifg_ps + np.concatenate(([0], np.cumsum(per_cn)[:-1]))
    pres_t = preq_t + preq_wire + 2 * hops * p.hop_ps + p.gap_ps(p.epl_cn_delay_ps)
    soa_t = int(preq_t[-1] + per_cn[-1])
    cycle_ps = soa_t + p.frame_ps(len(soa)) + p.ifg_ps + p.epl_cycle_idle_ps

    rel = np.concatenate(([0], np.ravel(np.column_stack((preq_t, pres_t))), [soa_t]))
    lengths = np.array([soc_len] + [lq, ls] * n + [len(soa)], dtype=np.int64)
    wire = np.array([soc_wire] + [preq_wire, pres_wire] * n + [p.frame_ps(len(soa))], np.int64)
    outbound = np.array([True] + [True, False] * n + [True])

    starts = np.arange(cycles, dtype=np.int64) * cycle_ps
    socs = np.stack([np.frombuffer(_soc(int(s)), np.uint8) for s in starts])
    polls = np.concatenate((np.broadcast_to(preq, (cycles, n, lq)), pres), axis=2)
    data = np.concatenate(
        (
            socs,
            polls.reshape(cycles, -1),
            np.broadcast_to(np.frombuffer(soa, np.uint8), (cycles, len(soa))),
        ),
        axis=1,
    )

    trace = CycleTrace(
        starts[:, None] + rel[None, :], lengths, np.ascontiguousarray(data), wire, outbound
    )
    details = [CycleDetail(c, int(starts[c]), cycle_ps, n, n) for c in range(cycles)]
    return SimResult("epl", "daisy", n, data_bytes, p.name, "per-slave", details, trace)


def _soc(start_ps: int) -> bytes:
    """The SoC of a cycle starting at ``start_ps``: NetTime and RelativeTime of that instant."""
    ns = start_ps // PS_PER_NS
    soc = powerlink.SoC(
        net_time_s=EPOCH_S + ns // NS_PER_S,
        net_time_ns=ns % NS_PER_S,
        relative_time_us=start_ps // PS_PER_US,
    )
    return powerlink.frame(soc).to_bytes()
