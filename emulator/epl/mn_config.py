"""What the emulated MN reads from a CDC (the concise device configuration, as openPOWERLINK's
MN reads ``mnobd.cdc``; :mod:`skinframes.powerlink.cdc` decodes it).

Objects read (EPSG DS 301 V1.4.0 7.2.1; the kit's README, "CDC (mnobd.cdc) format"): the node
assignment 0x1F81/<node> (bit 0 the node exists, bit 1 it is a CN; the last entry of a node
counts, as the CDC writes it twice), the cycle 0x1006/0 (us), the asynchronous slot timeout
0x1F8A/2 (ns), each CN's PRes timeout 0x1F92/<node> (ns), its loss-of-PRes threshold
0x1C09/<node>, ConfDate/ConfTime 0x1F26/0x1F27 <node>, its 0x1F22 block (the objects the MN
writes to it), and the MN's TPDO channels (0x1800+k/1 the node a channel sends to, 0x1A00+k its
mapping), which size each PReq's payload.
Every other entry configures the real MN's own dictionary and is not needed here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

from emulator.errors import TopologyError
from skinframes.powerlink.cdc import (
    CONFIGURATION_DATA_INDEX,
    MN_PDO_CHANNELS,
    MN_TPDO_COMM,
    TPDO_MAPPING,
    CdcEntry,
)
from skinframes.powerlink.enums import MAX_CN_NODE_ID, MIN_CN_NODE_ID

NODE_EXISTS: Final = 0x01  # 0x1F81 bit 0
NODE_IS_CN: Final = 0x02  # 0x1F81 bit 1
# DS 301 defaults where a CDC leaves an object out: 0x1F92 PresTimeout 25 us (openPOWERLINK's
# objdict.h too), 0x1F8A/2 AsyncSlotTimeout 100 us
DEFAULT_PRES_TIMEOUT_NS: Final = 25_000
DEFAULT_ASYNC_SLOT_NS: Final = 100_000
BITS_PER_BYTE: Final = 8


@dataclass(frozen=True, slots=True)
class NodeConfig:
    """One CN as the CDC configures it."""

    node_id: int
    pres_timeout_ns: int
    preq_payload_bytes: int
    writes: tuple[CdcEntry, ...]
    conf_date: int | None
    conf_time: int | None
    loss_of_pres_threshold: int = 0  # 0x1C09/<node>; 0: none


@dataclass(frozen=True, slots=True)
class MnConfig:
    """The cycle, the asynchronous slot timeout and the CNs (by node id)."""

    cycle_us: int
    async_slot_ns: int
    nodes: tuple[NodeConfig, ...]

    @property
    def node_ids(self) -> list[int]:
        """The CNs' node ids, in order."""
        return [n.node_id for n in self.nodes]


def _values(entries: Sequence[CdcEntry]) -> dict[tuple[int, int], CdcEntry]:
    """Each object's last entry."""
    return {(e.index, e.subindex): e for e in entries}


def _preq_payload_bytes(values: dict[tuple[int, int], CdcEntry], node_id: int) -> int:
    """The payload of the PReq to ``node_id``: what the MN's TPDO channel to it maps (the end
    of its last mapped object, DS 301 6.4.9.2), 0 without a channel."""
    for k in range(MN_PDO_CHANNELS):
        channel = values.get((MN_TPDO_COMM + k, 1))
        if channel is None or channel.value != node_id:
            continue
        count = values.get((TPDO_MAPPING + k, 0))
        mapped = range(1, 1 + (count.value if count is not None else 0))
        end_bits = 0
        for sub in mapped:
            entry = values.get((TPDO_MAPPING + k, sub))
            if entry is not None:
                offset, length = entry.value >> 32 & 0xFFFF, entry.value >> 48 & 0xFFFF
                end_bits = max(end_bits, offset + length)
        return -(-end_bits // BITS_PER_BYTE)
    return 0


def mn_config(entries: Sequence[CdcEntry], cycle_us: int | None = None) -> MnConfig:
    """The MN's configuration from a CDC's entries; ``cycle_us`` replaces its 0x1006.

    Raises:
        TopologyError: no CN assigned, or no cycle.
    """
    values = _values(entries)
    ids = [
        sub
        for (index, sub), e in sorted(values.items())
        if index == 0x1F81
        and MIN_CN_NODE_ID <= sub <= MAX_CN_NODE_ID
        and e.value & (NODE_EXISTS | NODE_IS_CN) == NODE_EXISTS | NODE_IS_CN
    ]
    if not ids:
        raise TopologyError("CDC: no CN assigned (0x1F81/<node> with bits 0 and 1 set)")
    cycle = cycle_us if cycle_us is not None else values.get((0x1006, 0), CdcEntry(0, 0, b"")).value
    if not cycle:
        raise TopologyError("CDC: no cycle length (0x1006/0); give --cycle-us")
    nodes = []
    for n in ids:
        timeout = values.get((0x1F92, n))
        block = values.get((CONFIGURATION_DATA_INDEX, n))
        date, time_ = values.get((0x1F26, n)), values.get((0x1F27, n))
        threshold = values.get((0x1C09, n))
        nodes.append(
            NodeConfig(
                node_id=n,
                pres_timeout_ns=timeout.value if timeout is not None else DEFAULT_PRES_TIMEOUT_NS,
                preq_payload_bytes=_preq_payload_bytes(values, n),
                writes=block.nested if block is not None else (),
                conf_date=date.value if date is not None else None,
                conf_time=time_.value if time_ is not None else None,
                loss_of_pres_threshold=threshold.value if threshold is not None else 0,
            )
        )
    slot = values.get((0x1F8A, 2))
    return MnConfig(
        cycle_us=cycle,
        async_slot_ns=slot.value if slot is not None else DEFAULT_ASYNC_SLOT_NS,
        nodes=tuple(nodes),
    )
