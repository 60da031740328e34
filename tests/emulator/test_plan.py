"""emulator.model.plan: the fastest layout per network and its distance to the physical limit."""

from __future__ import annotations

import pytest

from emulator.errors import TopologyError
from emulator.model import analytic
from emulator.model.params import PAPER, WIRE
from emulator.model.plan import Plan, limit_us, plan


@pytest.fixture(scope="module")
def small() -> Plan:
    return plan(20, 64, WIRE)


def test_limit_is_the_taxel_bytes_alone() -> None:
    assert limit_us(160, 192, WIRE) == pytest.approx(160 * 192 * 0.08)  # 80 ns a byte
    assert limit_us(1, 1, PAPER) == pytest.approx(0.08)


def test_every_network_keeps_its_fastest_layout(small: Plan) -> None:
    assert list(small.networks) == ["epl", "ecat", "ecat_closed_ring"]
    for network in small.networks.values():
        assert network.best in network.alternatives
        assert network.best.cycle_us == min(o.cycle_us for o in network.alternatives)
        assert network.overhead_us == pytest.approx(network.best.cycle_us - small.limit_us)
        assert network.efficiency == pytest.approx(small.limit_us / network.best.cycle_us)
        assert 0 < network.efficiency < 1
    assert [o.layout for o in small.networks["epl"].alternatives] == ["per-slave"]
    assert [o.layout for o in small.networks["ecat"].alternatives] == ["per-slave", "logical"]


def test_frames_per_cycle(small: Plan) -> None:
    epl = small.networks["epl"].best
    assert epl.frames_per_cycle == 2 * 20 + 2  # SoC, a PReq and a PRes per CN, SoA
    per_slave, logical = small.networks["ecat"].alternatives
    assert per_slave.frames_per_cycle == 2  # 19 LRDs of 10 + 64 + 2 bytes fill 1498 bytes
    assert logical.frames_per_cycle == 1  # one LRD of 20 x 64 bytes


def test_json_document(small: Plan) -> None:
    doc = small.to_json()
    assert list(doc) == [
        "nodes",
        "bytes",
        "preset",
        "epl_cn_response_us",
        "limit_us",
        "epl",
        "ecat",
        "ecat_closed_ring",
        "ecat_redundant",  # the closed ring's old name, the same value
    ]
    assert doc["ecat_redundant"] == doc["ecat_closed_ring"]
    ring = round(float(analytic.ecat_cycle_us(20, 64, WIRE, closed_ring=True)), 6)
    assert doc["ecat_closed_ring"]["analytic_us"] == ring
    assert (doc["nodes"], doc["bytes"], doc["preset"]) == (20, 64, "wire")
    assert list(doc["ecat"]) == [
        "layout",
        "cycle_us",
        "frames_per_cycle",
        "overhead_us",
        "efficiency",
        "alternatives",
        "analytic_us",
    ]
    assert doc["ecat"]["analytic_us"] == round(float(analytic.ecat_cycle_us(20, 64, WIRE)), 6)
    assert doc["ecat"]["alternatives"][0] == {
        "layout": "per-slave",
        "cycle_us": small.networks["ecat"].alternatives[0].cycle_us,
        "frames_per_cycle": 2,
    }


def test_impossible_network_raises() -> None:
    with pytest.raises(TopologyError, match="240 CNs"):
        plan(240, 8, PAPER)


def test_impossible_network_skipped_when_asked() -> None:
    """skinframes plan's way: EPL cannot have 240 CNs, EtherCAT can; no network, an error."""
    p = plan(240, 8, PAPER, skip_impossible=True)
    assert list(p.networks) == ["ecat", "ecat_closed_ring"]
    assert p.not_applicable == {"epl": "EPL: 240 CNs (1..239)"}
    with pytest.raises(TopologyError, match=r"EPL: 1025 CNs .*; EtherCAT .*1025 slaves"):
        plan(1025, 8, PAPER, skip_impossible=True)
