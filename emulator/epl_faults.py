"""EPL with faults: the MN polls CN by CN and waits for each PRes up to its timeout.

Link j is the cable between node j and j + 1 (node 0 = the MN); a frame between the MN and CN i
crosses links 0..i-1. Hubs have no loop-back: a failed cable or a dead CN simply cuts off what is
behind it. What the MN does (DS 301 4.2.4.1.2): a PRes that does not start within the CN's PRes
timeout after the end of its PReq counts as lost (the MN's loss-of-PRes counter for that CN) and
the MN goes on with the next CN when the timeout expires; a PRes with a CRC error is discarded.

Without faults the frames and times equal :func:`emulator.epl_cycle.simulate_epl`'s (tested).
Simplification: a CN that answers after its timeout would collide with the MN's next frame on
the shared hub network; collisions are not modelled, so such a late PRes is reported in the
diagnosis and left out of the trace.
"""

from __future__ import annotations

import random
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.epl_cycle import _soc
from emulator.faults import Fault, check_faults
from emulator.limits import check_cycles, check_epl
from emulator.params import TimingParams
from emulator.records import RecordTrace
from emulator.result import CycleDetail, SimResult, node_payloads
from emulator.units import PS_PER_US
from skinframes import powerlink

__all__ = ["DEFAULT_TIMEOUT_MARGIN_PS", "simulate_epl_faults"]

# Our default PRes timeout per CN: its round trip plus this margin (DS 301 configures one
# timeout per CN, NMT_MNCNPResTimeout_AU32; the value is the integrator's choice).
DEFAULT_TIMEOUT_MARGIN_PS: Final = 25_000_000


def simulate_epl_faults(
    nodes: int,
    data_bytes: int,
    params: TimingParams,
    faults: tuple[Fault, ...],
    *,
    cycles: int = 4,
    seed: int = 0,
    payloads: npt.NDArray[np.uint8] | None = None,
    pres_timeout_ps: int | None = None,
) -> SimResult:
    """Emulate EPL cycles with ``faults`` (see :mod:`emulator.faults`)."""
    check_epl(nodes, data_bytes)
    check_cycles(cycles)
    check_faults(faults, nodes, nodes, "epl")
    p, n = params, nodes
    rng = random.Random(seed)
    taxels = node_payloads(payloads, cycles, n, data_bytes, seed)
    soa = powerlink.frame(powerlink.SoA()).to_bytes()
    preq = [powerlink.frame(powerlink.PReq(i)).to_bytes() for i in range(1, n + 1)]
    soc_wire = p.frame_ps(len(_soc(0)))
    preq_wire, soa_wire = p.frame_ps(len(preq[0])), p.frame_ps(len(soa))
    pres_len = len(powerlink.frame(powerlink.PRes(1, bytes(data_bytes))).to_bytes())
    pres_wire = p.frame_ps(pres_len)
    needed = [2 * (i + 1) * p.hop_ps + p.gap_ps(p.epl_cn_delay_ps) for i in range(1, n + 1)]
    timeout = [
        pres_timeout_ps if pres_timeout_ps is not None else t + DEFAULT_TIMEOUT_MARGIN_PS
        for t in needed
    ]
    late = {f.where: round(f.value * PS_PER_US) for f in faults if f.kind == "late"}
    broken: dict[int, int] = {}  # link -> cycle it broke
    dead: dict[int, int] = {}  # CN -> cycle it died
    losses = [0] * (n + 1)
    late_beyond = [0] * (n + 1)
    corrupted = [0] * (n + 1)

    def crossing(links: range) -> str | None:
        """Cross these links once: None, or 'drop' / 'biterr:J' for what happened."""
        for j in links:
            for f in faults:
                if f.where == j and f.kind == "drop" and rng.random() < f.value:
                    return "drop"
                if f.where == j and f.kind == "biterr" and rng.random() < f.value:
                    return f"biterr:{j}"
        return None

    trace = RecordTrace()
    details: list[CycleDetail] = []
    start = 0
    for c in range(cycles):
        for f in faults:
            if f.kind == "cable" and f.cycle == c:
                broken.setdefault(f.where, c)
            if f.kind == "power" and f.cycle == c:
                dead.setdefault(f.where, c)
        trace.add(start, _soc(start), soc_wire, True)
        t = start + soc_wire + p.ifg_ps
        received = 0
        for i in range(1, n + 1):
            trace.add(t, preq[i - 1], preq_wire, True)
            preq_end = t + preq_wire
            # a CN's hub dies with it: everything behind a dead CN or a broken cable is cut off
            reachable = all(j not in dead for j in range(1, i + 1)) and all(
                j not in broken for j in range(i)
            )
            out = crossing(range(i)) if reachable else "cut"
            back = crossing(range(i - 1, -1, -1)) if out is None else None
            answer = preq_end + needed[i - 1] + late.get(i, 0)
            if out is None and back != "drop" and answer - preq_end <= timeout[i - 1]:
                payload = taxels[c, i - 1].tobytes()
                frame = powerlink.frame(powerlink.PRes(i, payload)).to_bytes()
                mark = None
                if back is not None:  # a bit error on the way back: the MN discards it
                    mark = (
                        f"skinframes: corrupted on link {back[7:]}..{int(back[7:]) + 1} "
                        "(injected bit error; FCS mismatch)"
                    )
                    frame = frame[:-1] + bytes([frame[-1] ^ 0x01])
                    corrupted[i] += 1
                    losses[i] += 1
                else:
                    received += 1
                trace.add(answer, frame, pres_wire, False, 0, mark)
                t = answer + pres_wire + p.gap_ps(p.epl_mn_delay_ps)
            else:
                losses[i] += 1
                if out is None and back != "drop":
                    late_beyond[i] += 1
                t = preq_end + timeout[i - 1] + p.gap_ps(p.epl_mn_delay_ps)
        trace.add(t, soa, soa_wire, True)
        end = t + soa_wire + p.ifg_ps + p.epl_cycle_idle_ps
        details.append(CycleDetail(c, start, end - start, received, n))
        start = end
    result = SimResult("epl", "daisy", n, data_bytes, p.name, "per-slave", details, trace.sorted())
    result.diagnosis = _diagnosis(faults, n, cycles, losses, late_beyond, corrupted, broken, dead)
    return result


def _diagnosis(
    faults: tuple[Fault, ...],
    n: int,
    cycles: int,
    losses: list[int],
    late_beyond: list[int],
    corrupted: list[int],
    broken: dict[int, int],
    dead: dict[int, int],
) -> list[str]:
    out = []
    for link, c in sorted(broken.items()):
        first = link + 1
        who = f"CNs {first}..{n}" if first < n else f"CN {n}"
        out.append(
            f"link {link}..{link + 1} down at cycle {c}: {who} no longer answer (PRes timeouts)"
        )
    for cn, c in sorted(dead.items()):
        out.append(f"CN {cn} lost power at cycle {c}; CNs behind it are cut off too")
    for cn in range(1, n + 1):
        if losses[cn]:
            text = f"CN {cn}: {losses[cn]} of {cycles} PRes lost (the MN's loss-of-PRes counter)"
            if corrupted[cn]:
                text += f", {corrupted[cn]} of them with CRC errors"
            if late_beyond[cn]:
                text += (
                    f", {late_beyond[cn]} answered after the PRes timeout (on a hub network "
                    "they would collide with the MN's next frame; not in the trace)"
                )
            out.append(text)
    return out
