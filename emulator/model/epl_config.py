"""The times an openPOWERLINK MN's CDC gives a skin of software CNs (``skinframes epl-config``).

The bytes of the CDC are :mod:`skinframes.powerlink.cdc`'s; this module chooses its times from
the model (:mod:`emulator.model.analytic`, preset ``wire``) and from what software CNs were
measured to need.
"""

from __future__ import annotations

import math
from typing import Final

from emulator.model import analytic
from emulator.model.params import WIRE, TimingParams
from emulator.model.units import PS_PER_US
from skinframes import ethernet
from skinframes.powerlink.cdc import SkinConfig

__all__ = [
    "CYCLE_STEP_US",
    "DEFAULT_PRES_TIMEOUT_US",
    "default_cycle_us",
    "shortest_cycle_us",
    "skin_config",
    "worst_cycle_us",
]

# A PRes timeout (0x1F92) a CN in software meets on a loaded host: openPOWERLINK's own console
# CN answered a PReq in ~100 us median and up to ~600 us over veth, and with 1 ms eight of them
# ran at a 10 ms cycle on a busy 2-core host where the shipped 200 us lost them
# (../shared/tools/openpowerlink/README.md, "Known limits"); serve epl under --rt-priority
# answered within 50-200 us p99 (benchmarks/README.md, bench_epl_live.py). The asynchronous
# slot timeout (0x1F8A/2) defaults to the same: a CN answers an SoA as it answers a PReq.
DEFAULT_PRES_TIMEOUT_US: Final = 1_000
CYCLE_STEP_US: Final = 1_000  # the default cycle is rounded up to a whole millisecond
# The largest ASnd the asynchronous phase may carry: a full Ethernet payload (1500 bytes, less
# the ASnd header the model adds back)
ASND_MAX_DATA_BYTES: Final = ethernet.MAX_PAYLOAD_BYTES - analytic.H_ASND


def shortest_cycle_us(
    nodes: int, pres_payload_bytes: int, cn_response_us: float, params: TimingParams = WIRE
) -> float:
    """The model's cycle (eq. 3: SoC, every PReq/PRes, SoA) with each CN answering in
    ``cn_response_us``, no asynchronous frame."""
    p = params.with_changes(epl_cn_delay_ps=round(cn_response_us * PS_PER_US))
    return float(analytic.epl_cycle_us(nodes, pres_payload_bytes, p))


def worst_cycle_us(
    nodes: int, pres_payload_bytes: int, pres_timeout_us: int, async_slot_us: int
) -> float:
    """The cycle in which every CN answers at the end of its PRes timeout and the asynchronous
    slot takes its whole timeout plus the largest ASnd (the model, preset ``wire``)."""
    isochronous = shortest_cycle_us(nodes, pres_payload_bytes, pres_timeout_us)
    return isochronous + async_slot_us + float(analytic.t_asnd(ASND_MAX_DATA_BYTES, WIRE))


def default_cycle_us(
    nodes: int, pres_payload_bytes: int, pres_timeout_us: int, async_slot_us: int
) -> int:
    """:func:`worst_cycle_us` rounded up to a whole millisecond: no CN's lateness within its
    timeout, and no ASnd, can push the next SoC late."""
    worst = worst_cycle_us(nodes, pres_payload_bytes, pres_timeout_us, async_slot_us)
    return math.ceil(worst / CYCLE_STEP_US) * CYCLE_STEP_US


def skin_config(
    node_ids: tuple[int, ...],
    taxel_bytes: int,
    cycle_us: int | None = None,
    pres_timeout_us: int | None = None,
) -> SkinConfig:
    """The skin's configuration with the model's times where none is given: PRes timeout and
    asynchronous slot :data:`DEFAULT_PRES_TIMEOUT_US`, the cycle :func:`default_cycle_us`."""
    timeout_us = pres_timeout_us or DEFAULT_PRES_TIMEOUT_US
    payload = SkinConfig(node_ids, taxel_bytes, 1, timeout_us, timeout_us).pres_payload_bytes
    cycle = cycle_us or default_cycle_us(len(node_ids), payload, timeout_us, timeout_us)
    return SkinConfig(node_ids, taxel_bytes, cycle, timeout_us, timeout_us)
