"""N skin patches as EPL CNs on one link: which node a frame concerns, answer first, react after.

:meth:`EplSkin.answer` is the fast path a live loop calls on every received frame: a PReq to one
of the nodes gets that node's prepared PRes, a SoA inviting one of them its prepared ASnd, after
a few byte reads (DS 301 4.6.1.1: MessageType at EPL offset 0, Destination 1; SoA
RequestedServiceID 6 and Target 7). :meth:`EplSkin.after` then decodes the frame and lets every
node it concerns react (NMT, SDO, PDO data), and :meth:`EplSkin.tick` runs the nodes' timers.
Every frame is legal input: what cannot be decoded, or is for nobody here, is counted.
"""

from __future__ import annotations

from collections import Counter
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.epl.cn import SkinCn
from emulator.errors import TopologyError
from skinframes import ethernet
from skinframes.dispatch import decode_frame
from skinframes.errors import DecodeError
from skinframes.powerlink import (
    BROADCAST_NODE_ID,
    MAX_CN_NODE_ID,
    MIN_CN_NODE_ID,
    ASnd,
    MessageType,
    NmtState,
    PReq,
    PRes,
    SoA,
    SoC,
)

ETHERTYPE_EPL_BYTES: Final = ethernet.ETHERTYPE_EPL.to_bytes(2, "big")
EPL_OFFSET: Final = ethernet.HEADER_BYTES  # untagged frames: EPL starts after 14 bytes
SOA_SERVICE_OFFSET: Final = EPL_OFFSET + 6  # RequestedServiceID (DS 301 4.6.1.1.5)
SOA_TARGET_OFFSET: Final = EPL_OFFSET + 7  # RequestedServiceTarget


def node_ids(nodes: int, given: list[int] | None = None) -> list[int]:
    """The CN ids: ``given`` (checked) or 1..nodes.

    Raises:
        TopologyError: a wrong count, an id outside 1..239, or one twice.
    """
    ids = list(range(MIN_CN_NODE_ID, nodes + 1)) if given is None else list(given)
    if not 1 <= nodes <= MAX_CN_NODE_ID:
        raise TopologyError(f"--nodes: {nodes} CNs, EPL allows 1..{MAX_CN_NODE_ID}")
    if len(ids) != nodes:
        raise TopologyError(f"--node-ids: {len(ids)} ids for {nodes} nodes")
    bad = [i for i in ids if not MIN_CN_NODE_ID <= i <= MAX_CN_NODE_ID]
    if bad:
        raise TopologyError(f"--node-ids: {bad[0]} is no CN id (1..{MAX_CN_NODE_ID})")
    if len(set(ids)) != len(ids):
        raise TopologyError("--node-ids: an id appears twice")
    return ids


class EplSkin:
    """The CNs ``ids`` (in patch order), each with ``taxel_bytes`` bytes of taxels."""

    def __init__(self, ids: list[int], taxel_bytes: int) -> None:
        self.nodes = [SkinCn(i, taxel_bytes) for i in ids]
        self.by_id = {cn.node_id: cn for cn in self.nodes}
        self.counts: Counter[str] = Counter()
        self.last_epl_ns = 0  # when the last EPL frame arrived (NMT_CT3's timer)
        self.published = 0  # taxel samples published so far
        self._rows: npt.NDArray[np.uint8] | None = None
        self._stale: list[int] = []  # nodes whose row of the last sample is not applied yet

    def publish(self, payloads: npt.NDArray[np.uint8]) -> None:
        """One taxel sample: row k of ``payloads`` (patches x bytes) for the k-th node.

        Only noted here: :meth:`refresh` hands the rows to the nodes a few at a time, between
        frames, so that no PReq waits for all N PRes to be rebuilt (160 nodes take about
        1 ms). Until its turn a node sends the sample before, whole.
        """
        if len(payloads) != len(self.nodes):
            raise TopologyError(f"publish: {len(payloads)} rows for {len(self.nodes)} CNs")
        self.published += 1
        self._rows = payloads
        self._stale = list(range(len(self.nodes) - 1, -1, -1))  # popped from the end: node 0 first

    def refresh(self, nodes: int | None = None) -> None:
        """Give up to ``nodes`` (default: all) nodes their row of the last published sample."""
        stale, rows, number = self._stale, self._rows, self.published
        if rows is None:
            return
        for _ in range(len(stale) if nodes is None else min(nodes, len(stale))):
            i = stale.pop()
            self.nodes[i].publish(rows[i].tobytes(), number)

    # --- the fast path -----------------------------------------------------------------------
    def answer(self, frame: bytes) -> bytes | None:
        """The frame one of the nodes sends at once in answer to ``frame``, if any.

        A PReq gets its node's PRes (in PreOperational2 and later, else nothing); a SoA whose
        target is one of the nodes gets what it invites (:meth:`SkinCn.invited`).
        """
        if len(frame) <= SOA_TARGET_OFFSET or frame[12:14] != ETHERTYPE_EPL_BYTES:
            return None
        mtype = frame[EPL_OFFSET]
        if mtype == MessageType.PREQ:
            cn = self.by_id.get(frame[EPL_OFFSET + 1])
            return cn.pres_frame if cn is not None and cn.pres_frame_ready else None
        if mtype == MessageType.SOA:
            cn = self.by_id.get(frame[SOA_TARGET_OFFSET])
            if cn is None or not cn.dll_active:
                return None
            return cn.invited(frame[SOA_SERVICE_OFFSET], frame[EPL_OFFSET + 4])
        return None

    # --- reacting ----------------------------------------------------------------------------
    def after(self, frame: bytes, answered: bytes | None, now_ns: int) -> None:
        """Let the nodes react to ``frame`` (``answered``: what :meth:`answer` sent for it)."""
        if frame[12:14] != ETHERTYPE_EPL_BYTES:
            self.counts["not_epl"] += 1
            return
        self.last_epl_ns = now_ns
        try:
            message = decode_frame(frame).payload
        except DecodeError:
            self.counts["malformed"] += 1
            return
        if isinstance(message, SoC):
            net_time_ns = message.net_time_s * 1_000_000_000 + message.net_time_ns
            for cn in self.nodes:
                cn.saw_soc(now_ns, net_time_ns)
                cn.after_soc()
        elif isinstance(message, SoA):
            target = message.requested_target
            for cn in self.nodes:
                cn.after_soa(message, answered is not None and cn.node_id == target)
        elif isinstance(message, PReq | PRes):
            self._after_pdo(message)
        elif isinstance(message, ASnd):
            self._after_asnd(message)
        else:
            self.counts["epl_other"] += 1

    def _after_pdo(self, message: PReq | PRes) -> None:
        """A PReq (to one of the nodes, or to a node not here) or a PRes of another node."""
        addressed = self.by_id.get(message.dest) if isinstance(message, PReq) else None
        if isinstance(message, PReq) and addressed is None:
            self.counts["preq_unknown_node"] += 1
        if isinstance(message, PRes) and message.src in self.by_id:
            self.counts["pres_from_our_id"] += 1
        if addressed is not None and isinstance(message, PReq):
            addressed.after_pdo(message)
        for cn in self.nodes:  # NMT_CT12 wakes a node in BasicEthernet on any PReq/PRes
            if cn.nmt.state == NmtState.BASIC_ETHERNET and cn is not addressed:
                cn.after_pdo(None)

    def _after_asnd(self, message: ASnd) -> None:
        """An ASnd to one node or to all (NMT commands, SDO); not from one of ours."""
        if message.src in self.by_id:
            self.counts["asnd_from_our_id"] += 1
            return
        if message.dest == BROADCAST_NODE_ID:
            for cn in self.nodes:
                cn.after_asnd(message)
            return
        target = self.by_id.get(message.dest)
        if target is None:
            self.counts["asnd_unknown_node"] += 1
        else:
            target.after_asnd(message)

    def tick(self, now_ns: int) -> None:
        """The nodes' timers: loss of SoC, the NotActive -> BasicEthernet timeout."""
        for cn in self.nodes:
            cn.check_soc(now_ns)
            cn.check_basic_ethernet(now_ns, self.last_epl_ns)

    def report(self) -> dict[str, object]:
        """Per node: state, counts; and what the skin counted."""
        return {
            "counts": dict(sorted(self.counts.items())),
            "cns": [
                {
                    "node_id": cn.node_id,
                    "state": cn.nmt.state.name,
                    "state_changes": cn.nmt.changes,
                    "counts": dict(sorted((cn.counts + cn.sdo.counts).items())),
                }
                for cn in self.nodes
            ],
        }
