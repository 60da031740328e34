"""Timing constants: the one place where every number of the emulator lives, in integer ps.

Two presets:

* ``paper`` reproduces Tables I-III of the paper (../shared/paper.md) exactly, including its
  simplifications and its errors (each one named below and in docs/paper-notes.md).
* ``wire`` is what 100BASE-TX hardware does, from IEEE 802.3 and datasheets.

Byte sizes (preamble, FCS, IFG, headers) are facts of the frames and live in ``skinframes``;
only their conversion into time happens here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Final

from emulator.errors import PresetError, TopologyError
from emulator.model.units import PS_PER_US, byte_time_ps
from skinframes import ethernet

__all__ = [
    "MAX_CN_RESPONSE_PS",
    "PAPER",
    "PRESETS",
    "WIRE",
    "TimingParams",
    "preset",
    "with_cn_response",
]

UM_PER_M: Final = 1_000_000
# a CN's response time the model takes (--cn-response-us): up to 1 s, well beyond any cycle
MAX_CN_RESPONSE_PS: Final = 1_000_000 * PS_PER_US


@dataclass(frozen=True, slots=True)
class TimingParams:
    """Every timing constant of the model, in integer picoseconds (or bit/s, micrometres).

    Attributes:
        name: the preset's name.
        link_rate_bps: 100 Mbit/s (paper: b = 12.5 byte/us; IEEE 802.3 clause 24/25).
        cable_length_um: each cable between two nodes (paper assumption v: 0.01 m).
        cable_ps_per_m: propagation delay per metre of cable.
        hub_delay_ps: EPL: delay of the hub in front of each node (paper: D_hub).
        epl_mn_delay_ps: EPL: the MN's turnaround after a PRes before its next frame (D_MN).
        epl_cn_delay_ps: EPL: a CN's response time from the end of its PReq to its PRes (D_CN).
        epl_cycle_idle_ps: EPL: idle time after the SoA (and ASnd) before the next SoC (T_id).
        ecat_processing_ps: EtherCAT: one pass through an ESC in processing direction (via the
            EtherCAT Processing Unit, port 0 -> 1), PHYs included.
        ecat_forwarding_ps: EtherCAT: one pass in forwarding direction (port 1 -> 0, and the
            loop-back of the last slave of an open ring), PHYs included.
        ifg_everywhere: enforce the 96-bit inter-frame gap between any two frames on one
            direction of a link (802.3 4.2.3.2.1). The paper charges an IFG only after SoC and
            SoA and between EtherCAT frames; its PReq->PRes and PRes->PReq gaps are D_CN and
            D_MN alone.
    """

    name: str
    link_rate_bps: int
    cable_length_um: int
    cable_ps_per_m: int
    hub_delay_ps: int
    epl_mn_delay_ps: int
    epl_cn_delay_ps: int
    epl_cycle_idle_ps: int
    ecat_processing_ps: int
    ecat_forwarding_ps: int
    ecat_link_loss_ps: int
    ifg_everywhere: bool

    @property
    def byte_ps(self) -> int:
        """Duration of one byte on the wire (80_000 ps at 100 Mbit/s)."""
        return byte_time_ps(1, self.link_rate_bps)

    @property
    def ifg_ps(self) -> int:
        """The inter-frame gap: 12 byte times (960_000 ps at 100 Mbit/s)."""
        return byte_time_ps(ethernet.IFG_BYTES, self.link_rate_bps)

    @property
    def cable_ps(self) -> int:
        """Propagation delay of one cable."""
        delay, rest = divmod(self.cable_ps_per_m * self.cable_length_um, UM_PER_M)
        if rest:
            raise TopologyError(f"{self.name}: cable delay is not a whole number of ps")
        return delay

    @property
    def hop_ps(self) -> int:
        """EPL: one hop of the daisy chain, hub plus cable (D_hub + D_medium)."""
        return self.hub_delay_ps + self.cable_ps

    def frame_ps(self, frame_bytes: int) -> int:
        """Wire time of a frame of ``frame_bytes`` (as captured): preamble, padding, FCS."""
        return ethernet.wire_bytes(frame_bytes) * self.byte_ps

    def gap_ps(self, delay_ps: int) -> int:
        """A gap between two frames on one link direction: ``delay_ps``, at least the IFG
        where the preset enforces it."""
        return max(delay_ps, self.ifg_ps) if self.ifg_everywhere else delay_ps

    def with_changes(self, **changes: int | bool | str) -> TimingParams:
        """A copy with some constants changed (for what-if studies)."""
        return replace(self, **changes)  # type: ignore[arg-type]

    @property
    def epl_cn_response_us(self) -> float:
        """D_CN in us (the JSON key ``epl_cn_response_us`` beside ``preset``)."""
        return self.epl_cn_delay_ps / PS_PER_US

    @property
    def label(self) -> str:
        """The preset's name, and the CN response time where it is not the preset's
        (:func:`with_cn_response`): what a table or figure says it shows."""
        base = PRESETS.get(self.name)
        if base is None or base.epl_cn_delay_ps == self.epl_cn_delay_ps:
            return self.name
        return f"{self.name}, EPL CN response {self.epl_cn_delay_ps / PS_PER_US:g} us"


PAPER: Final = TimingParams(
    name="paper",
    link_rate_bps=100_000_000,  # paper II-B: b = 12.5 byte/us
    cable_length_um=10_000,  # paper assumption (v): 0.01 m cables
    # Paper II-B.2: T_medium ~ 0.0005 us for a 0.01 m cable, i.e. 50 ns/m. That is 10x the
    # ~5 ns/m of twisted pair (see WIRE); kept here because Tables I-III use it.
    cable_ps_per_m=50_000,
    hub_delay_ps=300_000,  # paper eq. (8): D_hub = 0.3 us
    epl_mn_delay_ps=1_000_000,  # paper after eq. (7): D_mn = 1 us; Table I charges it per CN
    epl_cn_delay_ps=1_000_000,  # paper after eq. (7): D_cn = 1 us; Table I charges it per CN
    # Table I needs 14.40 us for the start and asynchronous phases: SoC + IFG (eq. 4, 6.72 us),
    # SoA + IFG (eq. 10, 6.72 us) and one more IFG, the idle period T_id of eq. (3).
    epl_cycle_idle_ps=960_000,
    # Paper eq. (12): T_ecat_fwd = 1.35 us per slave in the open ring and 0.675 us in the closed
    # ring, i.e. 0.675 us for each pass of a frame through an ESC.
    ecat_processing_ps=675_000,
    ecat_forwarding_ps=675_000,
    # Paper II-B.2: "the recovery time in case of cable failure is shorter than 15 us" (ETG
    # benchmarks); taken as the time the ports next to a break need to close.
    ecat_link_loss_ps=15_000_000,
    ifg_everywhere=False,
)

WIRE: Final = TimingParams(
    name="wire",
    link_rate_bps=100_000_000,  # 100BASE-TX, IEEE 802.3 clause 25
    cable_length_um=10_000,  # the paper's 0.01 m, so that only the physics differs
    # Twisted pair with a nominal velocity of propagation of ~0.66 c: ~5 ns/m (802.3 clause 25
    # via ANSI X3.263 allows up to 5.7 ns/m for Category 5).
    cable_ps_per_m=5_000,
    # EPL requires IEEE 802.3 Class II repeating hubs (DS 301 physical layer; e.g. Lenze EPL
    # manuals). 802.3 clause 27.3.1.7: a Class II repeater's start-of-packet propagation delay
    # is at most 46 bit times = 460 ns.
    hub_delay_ps=460_000,
    epl_mn_delay_ps=1_000_000,  # kept at the paper's D_mn; the IFG rule below also applies
    epl_cn_delay_ps=1_000_000,  # a hardware PRes (openMAC auto-response class) in ~1 us
    epl_cycle_idle_ps=0,  # the next SoC may follow the SoA after the IFG
    # One ESC pass with MII PHYs on both ports: ESC core ~300 ns (Beckhoff ET1100 datasheet,
    # section III, forwarding delays, MII; approximate) + PHY receive latency 210 ns and
    # transmit latency 30 ns (TI DP83840A datasheet 8.5.3 / 8.5.5: 21 and 3 bit times).
    ecat_processing_ps=540_000,
    ecat_forwarding_ps=540_000,
    # No datasheet figure at hand for the link-loss detection of an ESC with MII PHYs; the ETG
    # bound the paper quotes (15 us) is used, so that both presets claim no more than it.
    ecat_link_loss_ps=15_000_000,
    ifg_everywhere=True,  # IEEE 802.3 4.2.3.2.1: interFrameSpacing 96 bit times
)

PRESETS: Final = {"paper": PAPER, "wire": WIRE}


def with_cn_response(params: TimingParams, response_ps: int | None) -> TimingParams:
    """``params`` with a CN's PReq -> PRes response time ``response_ps`` as D_CN (None: as it
    is). The presets take a hardware CN (1 us); a CN in software answers far later: the
    openPOWERLINK V2.7.2 console CN on Linux answered a PReq in about 100 us median and up to
    about 600 us over veth (../shared/tools/openpowerlink/README.md, "Known limits"; issue 40),
    so a measured value shows what such a CN costs a cycle (``--cn-response-us``)."""
    if response_ps is None:
        return params
    if not 0 < response_ps <= MAX_CN_RESPONSE_PS:
        raise TopologyError(f"CN response {response_ps} ps: 1 ps .. {MAX_CN_RESPONSE_PS} ps")
    return params.with_changes(epl_cn_delay_ps=response_ps)


def preset(name: str) -> TimingParams:
    """The preset called ``name`` (``paper`` or ``wire``)."""
    try:
        return PRESETS[name]
    except KeyError:
        raise PresetError(f"unknown preset {name!r}; choose from {sorted(PRESETS)}") from None
