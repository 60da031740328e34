"""The EPL engine: an MN and n CNs in a daisy chain of hubs, poll by poll.

Each node has a hub in front of it (the MN too, as the paper's eq. 8 counts), joined by cables;
link j is the cable between node j and j + 1 (node 0 = the MN), so a frame between the MN and CN
i crosses links 0..i-1 and i + 1 hubs each way. Per cycle (DS 301 4.2.4.1 and paper eqs. 3-11):

* SoC, then one IFG before the first PReq (eq. 4);
* a CN answers ``epl_cn_delay_ps`` after the end of its PReq (D_CN), the MN sends its next frame
  ``epl_mn_delay_ps`` after the end of a PRes (D_MN) -- at least an IFG in the wire preset;
* a PRes that does not start within the CN's PRes timeout after the end of its PReq is a loss
  the MN counts (its loss-of-PRes counter, DS 301 4.2.4.1.2), and the MN polls the next CN when
  the timeout expires; a PRes with a CRC error is discarded and counted likewise;
* SoA, one IFG, and the idle period before the next SoC (eq. 10, T_id);
* optionally (``asnd``) an ASnd in the asynchronous phase: each SoA invites one CN in turn with a
  StatusRequest and the cycle closes after its StatusResponse (or the same timeout). The paper's
  eq. (11) charges only the ASnd's bytes; the engine also charges the CN's turnaround and hubs.

Hubs have no loop-back: a failed cable or a dead CN cuts off what is behind it. A CN that answers
after its timeout would collide with the MN's next frame on the shared hub network; collisions
are not modelled, so such a PRes is counted as a loss and left out of the capture.
"""

from __future__ import annotations

import dataclasses
import random
from collections import Counter
from collections.abc import Callable
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.errors import TopologyError
from emulator.model.limits import check_epl
from emulator.model.params import TimingParams
from emulator.model.units import PS_PER_NS, PS_PER_US
from emulator.net.cycle import FILL_FRAME, FILL_NONE, FILL_TAXELS, Cycle, Record
from emulator.net.ecat import DEFAULT_TIMEOUT_MARGIN_PS, Ps
from emulator.net.faults import Fault, check_faults, corruption_mark
from skinframes import ethernet, powerlink, vlan
from skinframes.pcap import NS_PER_S
from skinframes.powerlink import RequestedService
from skinframes.vlan import VlanTag

__all__ = ["EPOCH_S", "EplEngine", "hops_to", "pres_length", "soc_frame"]

EPOCH_S: Final = 1_700_000_000  # NetTime of cycle 0 in the SoC (a fixed, reproducible epoch)
SOC_EPL_BYTES: Final = len(powerlink.SoC().to_bytes())  # 22, DS 301 4.6.1.1.1


def hops_to(cn: int) -> int:
    """Hubs (and cables) between the MN and CN number ``cn`` (1-based): the MN's own and CNs 1..cn."""
    return cn + 1


def pres_length(data_bytes: int) -> int:
    """Length (as captured) of a PRes carrying ``data_bytes`` of taxels."""
    return len(powerlink.frame(powerlink.PRes(1, bytes(data_bytes))).to_bytes())


def soc_frames(starts_ps: npt.NDArray[np.int64]) -> npt.NDArray[np.uint8]:
    """(k, SoC length) uint8: the SoCs of cycles starting at ``starts_ps``: NetTime (from
    ``EPOCH_S``) and RelativeTime of each start."""
    ns = starts_ps // PS_PER_NS
    return powerlink.pack_soc_frames(
        EPOCH_S + ns // NS_PER_S, ns % NS_PER_S, starts_ps // PS_PER_US
    )


def soc_frame(start_ps: int) -> bytes:
    """The SoC of a cycle starting at ``start_ps``."""
    return bytes(soc_frames(np.array([start_ps], dtype=np.int64))[0])


class EplEngine:
    """EPL cycles of ``nodes`` CNs answering with ``data_bytes`` of taxels each.

    Args:
        asnd: fill the asynchronous phase (each SoA invites one CN in turn).
        pres_timeout_ps: the MN's PRes timeout for every CN, from the end of a PReq to the start
            of the PRes at the MN (DS 301 NMT_MNCNPResTimeout); by default each CN's round trip
            plus ``DEFAULT_TIMEOUT_MARGIN_PS``. A CN that cannot meet it loses every PRes.
        faults: the fault plan (:mod:`emulator.net.faults`).
        seed: the random faults' seed.
    """

    protocol: Final = "epl"
    topology: Final = "daisy"
    layout: Final = "per-slave"

    def __init__(
        self,
        nodes: int,
        data_bytes: int,
        params: TimingParams,
        *,
        asnd: bool = False,
        pres_timeout_ps: int | None = None,
        faults: tuple[Fault, ...] = (),
        seed: int = 0,
        tags: tuple[VlanTag, ...] = (),
    ) -> None:
        check_epl(nodes, data_bytes)
        self.tags = tags  # VLAN tags on every frame (IEEE 802.1Q); their bytes count on the wire
        check_faults(faults, nodes, nodes, "epl")
        if pres_timeout_ps is not None and pres_timeout_ps < 0:
            raise TopologyError(f"EPL: a PRes timeout of {pres_timeout_ps} ps")
        p = params
        self.nodes, self.data_bytes, self.params, self.asnd = nodes, data_bytes, params, asnd
        self.faults = faults
        self.period = nodes if asnd else 1
        self.expected_wkc = nodes
        self.rng = random.Random(seed)
        self.preq = [self._bytes(powerlink.PReq(i)) for i in range(1, nodes + 1)]
        self.soa_plain = self._bytes(powerlink.SoA())
        self.soa_invite = [
            self._bytes(powerlink.SoA(RequestedService.STATUS_REQUEST, i))
            for i in range(1, nodes + 1)
        ]
        self.status = [
            self._bytes(powerlink.ASnd(powerlink.StatusResponse(), src=i))
            for i in range(1, nodes + 1)
        ]
        self.soc_len = len(self._socs(np.zeros(1, dtype=np.int64))[0])
        self.pres_len = len(self._bytes(powerlink.PRes(1, bytes(data_bytes))))
        # where a PRes carries its taxels: after the Ethernet header, the tags and the PDO header
        self.payload_at = (
            ethernet.HEADER_BYTES + vlan.TAG_BYTES * len(tags) + powerlink.PDO_HEADER_BYTES
        )
        self.needed = [
            2 * hops_to(i) * p.hop_ps + p.gap_ps(p.epl_cn_delay_ps) for i in range(1, nodes + 1)
        ]
        self.timeout = [
            pres_timeout_ps if pres_timeout_ps is not None else t + DEFAULT_TIMEOUT_MARGIN_PS
            for t in self.needed
        ]
        self.late_ps = {f.where: round(f.value * PS_PER_US) for f in faults if f.kind == "late"}
        self.chance = tuple(f for f in faults if f.kind in ("biterr", "drop") and f.value > 0)
        self.broken: dict[int, int] = {}  # link -> the cycle it broke
        self.dead: dict[int, int] = {}  # CN -> the cycle it lost power

    def _bytes(self, message: powerlink.EplMessage) -> bytes:
        """The frame of ``message`` as the MN or a CN sends it, with the VLAN tags."""
        return dataclasses.replace(powerlink.frame(message), tags=self.tags).to_bytes()

    def _socs(self, starts_ps: npt.NDArray[np.int64]) -> npt.NDArray[np.uint8]:
        """The SoCs of cycles starting at ``starts_ps``, with the VLAN tags."""
        return vlan.tag_frames(soc_frames(starts_ps), self.tags, SOC_EPL_BYTES)

    def _pres(self, taxels: npt.NDArray[np.uint8], cns: npt.ArrayLike) -> npt.NDArray[np.uint8]:
        """The PRes frames of CNs ``cns`` carrying ``taxels``, with the VLAN tags."""
        frames = powerlink.pack_pres_frames(taxels, cns)
        size = powerlink.PDO_HEADER_BYTES + taxels.shape[1]
        return vlan.tag_frames(frames, self.tags, size)

    def event_at(self, cycle: int) -> bool:
        """Does the fault plan change the network at the start of ``cycle``?"""
        return any(f.cycle == cycle and f.kind in ("cable", "power") for f in self.faults)

    def next_event(self, cycle: int) -> int | None:
        """The first cycle after ``cycle`` at whose start the fault plan changes the network."""
        later = [f.cycle for f in self.faults if f.kind in ("cable", "power") and f.cycle > cycle]
        return min(later) if later else None

    def rebuild(
        self, record: Record, starts_ps: npt.NDArray[np.int64], taxels: npt.NDArray[np.uint8]
    ) -> npt.NDArray[np.uint8]:
        """(k, length) uint8: the SoC (the FILL_FRAME record) of k cycles starting at
        ``starts_ps``; a PRes changes only its taxels (FILL_TAXELS)."""
        if record.node >= 0:
            raise TopologyError(f"EPL: only the SoC is rebuilt per cycle (node {record.node})")
        return self._socs(starts_ps)

    @property
    def patches(self) -> int:
        """The nodes that carry taxels: every CN."""
        return self.nodes

    def image(
        self, cycles: npt.NDArray[np.int64], taxels: npt.NDArray[np.uint8]
    ) -> npt.NDArray[np.uint8]:
        """(k, nodes x data_bytes): the taxels of cycles ``cycles``, CN after CN."""
        return taxels.reshape(len(cycles), -1)

    def cycle(self, c: int, start_ps: int, taxels: npt.NDArray[np.uint8] | None) -> Cycle:
        """Walk cycle ``c`` starting at ``start_ps``; ``taxels`` (nodes x data_bytes) to build
        the frames' bytes, None for timing only."""
        p, n = self.params, self.nodes
        bytes_on = taxels is not None
        for f in self.faults:
            if f.kind == "cable" and f.cycle == c:
                self.broken.setdefault(f.where, c)
            if f.kind == "power" and f.cycle == c:
                self.dead.setdefault(f.where, c)
        events: Counter[tuple[object, ...]] = Counter()
        recs: list[Record] = []

        def add(
            t: int,
            frame: bytes,
            length: int,
            out: bool,
            fill: int = FILL_NONE,
            node: int = -1,
            mark: str | None = None,
        ) -> None:
            data = frame if bytes_on else None
            runs: tuple[tuple[int, int, int], ...] = ()
            if fill == FILL_TAXELS:  # a PRes: its payload is node's row of the cycle's image
                runs = ((self.payload_at, node * self.data_bytes, self.data_bytes),)
                fill = FILL_TAXELS if self.data_bytes else FILL_NONE
            recs.append(
                Record(
                    t - start_ps, 0, out, length, p.frame_ps(length), data, fill, runs, node, mark
                )
            )

        pres = self._pres(taxels, np.arange(1, n + 1)) if taxels is not None else None
        end, received = self._timeline(
            c, start_ps, p.frame_ps(self.pres_len), events, add, pres, bytes_on
        )
        return Cycle(tuple(recs), end - start_ps, received, n, events, steady=not self.chance)

    def cycle_ps(self, pres_wire_ps: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        """Timing only: one steady-state cycle for each PRes wire time in ``pres_wire_ps`` (one
        per payload size), the polls walked once as in :meth:`cycle` with numpy time arrays;
        no frames built.

        Raises:
            TopologyError: a fault plan or ``asnd``; a sweep is of healthy networks only.
        """
        if self.faults or self.asnd:
            raise TopologyError("EPL timing sweep: a healthy network without ASnd only")
        events: Counter[tuple[object, ...]] = Counter()

        def skip(t: Ps, frame: bytes, length: int, out: bool, *more: object) -> None:
            pass

        end, _ = self._timeline(0, 0, pres_wire_ps, events, skip, None, False)
        if events:
            raise TopologyError(f"EPL timing sweep: PRes lost in a healthy network {events}")
        return np.broadcast_to(np.asarray(end, dtype=np.int64), pres_wire_ps.shape).copy()

    def _timeline(
        self,
        c: int,
        start_ps: int,
        pres_wire: Ps,
        events: Counter[tuple[object, ...]],
        add: Callable[..., None],
        pres: npt.NDArray[np.uint8] | None,
        bytes_on: bool,
    ) -> tuple[Ps, int]:
        """Cycle ``c`` from ``start_ps``: SoC, the polls, SoA (and ASnd), each frame handed to
        ``add``; returns when the next cycle starts and the PRes received. ``pres_wire``: the
        PRes wire time, an int or an array of them (then every time is an array)."""
        p, n = self.params, self.nodes
        soc = bytes(self._socs(np.array([start_ps], dtype=np.int64))[0]) if bytes_on else b""
        add(start_ps, soc, self.soc_len, True, FILL_FRAME)
        t: Ps = start_ps + p.frame_ps(self.soc_len) + p.ifg_ps
        received = 0
        for i in range(1, n + 1):
            add(t, self.preq[i - 1], len(self.preq[i - 1]), True)
            preq_end = t + p.frame_ps(len(self.preq[i - 1]))
            answer = self._answer(i, preq_end, events)
            if answer is None:
                t = preq_end + self.timeout[i - 1] + p.gap_ps(p.epl_mn_delay_ps)
                continue
            at, link = answer
            frame = pres[i - 1].tobytes() if pres is not None else b""
            if link is None:
                received += 1
                add(at, frame, self.pres_len, False, FILL_TAXELS, i - 1)
            else:
                bad = self._corrupt(frame, self.data_bytes)
                add(at, bad, self.pres_len, False, FILL_NONE, -1, corruption_mark(link))
            t = at + pres_wire + p.gap_ps(p.epl_mn_delay_ps)
        target = c % n + 1
        soa = self.soa_invite[target - 1] if self.asnd else self.soa_plain
        add(t, soa, len(soa), True)
        end = t + p.frame_ps(len(soa))
        if self.asnd:
            answer = self._answer(target, end, events, asnd=True)
            status = self.status[target - 1]
            if answer is None:
                end += self.timeout[target - 1]
            else:
                at, link = answer
                if link is None:
                    add(at, status, len(status), False)
                else:
                    bad = self._corrupt(status, 0)
                    add(at, bad, len(status), False, FILL_NONE, -1, corruption_mark(link))
                end = at + p.frame_ps(len(status))
        return end + p.ifg_ps + p.epl_cycle_idle_ps, received

    def _answer(
        self, i: int, request_end: Ps, events: Counter[tuple[object, ...]], *, asnd: bool = False
    ) -> tuple[Ps, int | None] | None:
        """When CN ``i``'s answer to a request ending at ``request_end`` starts at the MN, and the
        link where a bit error hit it on its way back (None: intact); None when the MN gets no
        answer in time."""
        reachable = all(j not in self.dead for j in range(1, i + 1)) and all(
            j not in self.broken for j in range(i)
        )
        kind = "asnd" if asnd else "pres"
        if not reachable or self._cross(range(i)) is not None:  # request lost or corrupted
            events[("loss", kind, i)] += 1
            return None
        back = self._cross(range(i - 1, -1, -1))
        if back is not None and back[0] == "drop":
            events[("loss", kind, i)] += 1
            return None
        delay = self.needed[i - 1] + self.late_ps.get(i, 0)
        at = request_end + delay
        if delay > self.timeout[i - 1]:
            events[("loss", kind, i)] += 1
            events[("late", kind, i)] += 1
            return None
        if back is not None:
            events[("loss", kind, i)] += 1
            events[("crc", kind, i)] += 1
            return at, back[1]
        return at, None

    def _cross(self, links: range) -> tuple[str, int] | None:
        """Cross these links once: None, or ('drop' | 'biterr', link) for what happened."""
        for j in links:
            for f in self.chance:
                if f.where == j and self.rng.random() < f.value:
                    return f.kind, j
        return None

    def _corrupt(self, frame: bytes, data_bytes: int) -> bytes:
        """A bit error flips one bit of the frame's data (the ``data_bytes`` after the EPL
        header, or its padding when it carries none), drawn at random, so that Wireshark still
        dissects the frame."""
        lo = self.payload_at
        hi = lo + data_bytes if data_bytes else ethernet.MIN_FRAME_BYTES
        bit = self.rng.randrange(8 * lo, 8 * hi)  # drawn in timing-only runs too: same chances
        return ethernet.flip_bit(frame, bit) if frame else frame

    def account(self, cyc: Cycle, times: int) -> None:
        """The MN's counters live in the events; nothing else to update."""

    def diagnosis(self, events: Counter[tuple[object, ...]], cycles: int) -> list[str]:
        """What the MN's counters tell about the run, in words."""
        n = self.nodes
        out = []
        for link, c in sorted(self.broken.items()):
            first = link + 1
            who = f"CNs {first}..{n}" if first < n else f"CN {n}"
            out.append(
                f"link {link}..{link + 1} down at cycle {c}: {who} no longer answer (PRes timeouts)"
            )
        for cn, c in sorted(self.dead.items()):
            out.append(f"CN {cn} lost power at cycle {c}; CNs behind it are cut off too")
        for cn in range(1, n + 1):
            losses = events[("loss", "pres", cn)]
            if losses:
                text = f"CN {cn}: {losses} of {cycles} PRes lost (the MN's loss-of-PRes counter)"
                if events[("crc", "pres", cn)]:
                    text += f", {events[('crc', 'pres', cn)]} of them with CRC errors"
                if events[("late", "pres", cn)]:
                    text += (
                        f", {events[('late', 'pres', cn)]} answered after the PRes timeout (on a "
                        "hub network they would collide with the MN's next frame; not in the trace)"
                    )
                out.append(text)
            if events[("loss", "asnd", cn)]:
                out.append(f"CN {cn}: {events[('loss', 'asnd', cn)]} StatusResponses (ASnd) lost")
        return out
