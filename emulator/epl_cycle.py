"""Ethernet POWERLINK: an MN and n CNs in a daisy chain of hubs, carrying real frames.

Each node has a hub in front of it (the MN too, as the paper's eq. 8 counts), joined by 0.01 m
cables; a frame between the MN and CN i therefore crosses i + 1 hubs and cables each way. Per
cycle the MN sends a SoC, then polls each CN in turn with a PReq and waits for its PRes (taxel
payload), then sends a SoA; the cycle closes after the idle period. Timing (DS 301 4.2.4.1 and
paper eqs. 3-11):

* SoC, then one IFG before the first PReq (eq. 4);
* a CN answers ``epl_cn_delay_ps`` after the end of its PReq (D_CN), the MN sends its next
  frame ``epl_mn_delay_ps`` after the end of a PRes (D_MN) -- at least an IFG in the wire preset;
* SoA, one IFG, and the idle period before the next SoC (eq. 10, T_id);
* optionally (``asnd=True``) an ASnd in the asynchronous phase: the SoA invites one CN per cycle
  in turn with a StatusRequest and the cycle closes after its StatusResponse. The paper's eq. (11)
  charges only the ASnd's bytes; the emulator also charges the CN's turnaround and the hub chain.
"""

from __future__ import annotations

from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.limits import check_cycles, check_epl
from emulator.params import TimingParams
from emulator.result import CycleDetail, SimResult, node_payloads
from emulator.trace import CycleTrace
from emulator.units import PS_PER_NS, PS_PER_US
from skinframes import powerlink
from skinframes.pcap import NS_PER_S
from skinframes.powerlink import RequestedService

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
    payloads: npt.NDArray[np.uint8] | None = None,
    asnd: bool = False,
    pres_timeout_ps: int | None = None,
) -> SimResult:
    """Emulate ``cycles`` EPL cycles: n CNs each answering with ``data_bytes`` of taxels.

    Args:
        payloads: (cycles, nodes, data_bytes) uint8 taxel bytes to carry (e.g. the samples of a
            CAN trace); seeded contact patterns when None.
        asnd: fill the asynchronous phase: each SoA invites one CN in turn (StatusRequest) and
            that CN answers with a StatusResponse ASnd. The paper's assumption (iii) is False.
        pres_timeout_ps: the MN's PRes timeout, from the end of a PReq to the start of the PRes
            at the MN (DS 301 NMT_MNCNPResTimeout). A timeout that a CN cannot meet on this
            chain is rejected: the CN's late PRes would collide with the MN's next frame.
    """
    check_epl(nodes, data_bytes)
    check_cycles(cycles)
    n = nodes
    cns = np.arange(1, n + 1)
    payloads = node_payloads(payloads, cycles, n, data_bytes, seed)

    preq = np.stack(
        [np.frombuffer(powerlink.frame(powerlink.PReq(int(i))).to_bytes(), np.uint8) for i in cns]
    )
    pres = powerlink.pack_pres_frames(
        payloads.reshape(cycles * n, data_bytes), np.tile(cns, cycles)
    ).reshape(cycles, n, -1)
    targets = (np.arange(cycles) % n) + 1  # the CN each SoA invites when asnd is on
    if asnd:
        soa_rows = [
            powerlink.frame(powerlink.SoA(RequestedService.STATUS_REQUEST, int(t))).to_bytes()
            for t in targets
        ]
        asnd_rows = [
            powerlink.frame(powerlink.ASnd(powerlink.StatusResponse(), src=int(t))).to_bytes()
            for t in targets
        ]
    else:
        soa_rows = [powerlink.frame(powerlink.SoA()).to_bytes()] * cycles
        asnd_rows = []
    soa = soa_rows[0]
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
    if pres_timeout_ps is not None:
        needed = 2 * hops * p.hop_ps + p.gap_ps(p.epl_cn_delay_ps)
        late = np.flatnonzero(needed > pres_timeout_ps)
        if len(late):
            raise TopologyError(
                f"EPL: a PRes timeout of {pres_timeout_ps / PS_PER_US:g} us is shorter than the "
                f"{int(needed[late[0]]) / PS_PER_US:g} us CN {late[0] + 1} needs on this chain"
            )
    soa_t = int(preq_t[-1] + per_cn[-1])
    soa_wire = p.frame_ps(len(soa))
    end_t = np.full(cycles, soa_t + soa_wire, dtype=np.int64)  # last bit of the cycle's last frame
    rel_rows = np.tile(
        np.concatenate(([0], np.ravel(np.column_stack((preq_t, pres_t))), [soa_t])), (cycles, 1)
    )
    lengths_list = [soc_len] + [lq, ls] * n + [len(soa)]
    wire_list = [soc_wire] + [preq_wire, pres_wire] * n + [soa_wire]
    outbound_list = [True] + [True, False] * n + [True]
    if asnd:  # the invited CN answers after it has received the SoA, as it answers a PReq
        asnd_wire = p.frame_ps(len(asnd_rows[0]))
        asnd_t = soa_t + soa_wire + 2 * hops[targets - 1] * p.hop_ps + p.gap_ps(p.epl_cn_delay_ps)
        rel_rows = np.column_stack((rel_rows, asnd_t))
        end_t = asnd_t + asnd_wire
        lengths_list.append(len(asnd_rows[0]))
        wire_list.append(asnd_wire)
        outbound_list.append(False)
    cycle_ps = end_t + p.ifg_ps + p.epl_cycle_idle_ps
    starts = np.concatenate(([0], np.cumsum(cycle_ps)[:-1])).astype(np.int64)

    socs = np.stack([np.frombuffer(_soc(int(s)), np.uint8) for s in starts])
    polls = np.concatenate((np.broadcast_to(preq, (cycles, n, lq)), pres), axis=2)
    parts = [
        socs,
        polls.reshape(cycles, -1),
        np.stack([np.frombuffer(r, np.uint8) for r in soa_rows]),
    ]
    if asnd:
        parts.append(np.stack([np.frombuffer(r, np.uint8) for r in asnd_rows]))
    data = np.concatenate(parts, axis=1)

    trace = CycleTrace(
        starts[:, None] + rel_rows,
        np.array(lengths_list, dtype=np.int64),
        np.ascontiguousarray(data),
        np.array(wire_list, dtype=np.int64),
        np.array(outbound_list),
    )
    details = [CycleDetail(c, int(starts[c]), int(cycle_ps[c]), n, n) for c in range(cycles)]
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
