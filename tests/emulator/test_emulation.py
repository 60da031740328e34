"""The frame-level emulator: the paper's tables from real frames, and what the frames carry."""

from __future__ import annotations

import itertools
import random
from pathlib import Path

import pytest
import tshark_util
from data.paper_tables import BYTES, NODES, PAPER_TABLES
from engine_util import assert_gaps, by_cycle, records

from emulator.errors import TopologyError
from emulator.esc.chain import EcatChain
from emulator.model.params import PAPER, WIRE
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.ecat import frames_for
from skinframes import decode_frame, ethercat, ethernet, powerlink, read_capture, taxel
from skinframes.ethercat import Command, Datagram

CELLS = [(t, n, b) for t in PAPER_TABLES for n in NODES for b in BYTES]


@pytest.mark.parametrize(("table", "nodes", "size"), CELLS)
def test_emulated_paper_preset_reproduces_every_cell(table: str, nodes: int, size: int) -> None:
    if table == "epl":
        r = simulate_epl(nodes, size, PAPER, cycles=2)
    else:
        r = simulate_ecat(nodes, size, PAPER, closed_ring=table != "ecat", cycles=2)
    c = r.cycle_us()
    assert c["min"] == c["max"]
    assert c["median"] == pytest.approx(PAPER_TABLES[table][nodes][size], abs=0.01)


def _wire_time_ns(length: int) -> float:
    """Hand formula: (8 preamble + max(len, 60) + 4 FCS) bytes x 80 ns at 100 Mbit/s."""
    return (8 + max(length, 60) + 4) * 80.0


def _assert_no_overlap(path: Path, outbound_src: set[bytes] | None) -> None:
    """From the pcap alone: frames of one direction never overlap at the master's port."""
    recs = list(read_capture(path))
    groups: dict[bool, list] = {}
    for r in recs:
        out = True if outbound_src is None else r.data[6:12] in outbound_src
        groups.setdefault(out, []).append(r)
    for rs in groups.values():
        for a, b in itertools.pairwise(rs):
            assert b.time_ns >= a.time_ns + _wire_time_ns(len(a.data)) - 1, (a.index, b.index)


RANDOM = random.Random(20261122)
EPL_CASES = [(RANDOM.randint(1, 40), RANDOM.randint(0, 1490)) for _ in range(3)]
ECAT_CASES = [
    (
        RANDOM.randint(1, 60),
        RANDOM.randint(1, 1486),
        RANDOM.choice([False, True]),
        RANDOM.choice(["per-slave", "logical"]),
    )
    for _ in range(4)
]


@pytest.mark.tshark
@pytest.mark.parametrize(("nodes", "size"), EPL_CASES)
def test_epl_pcap_is_clean_with_one_pres_per_cn(
    tshark: str, tmp_path: Path, nodes: int, size: int
) -> None:
    path = tmp_path / "epl.pcap"
    simulate_epl(nodes, size, WIRE, cycles=3, seed=nodes, pcap=path)
    assert tshark_util.problems(tshark, path) == []
    rows = tshark_util.fields(tshark, path, ["epl.mtyp", "epl.src", "epl.pres.size"])
    cycles: list[list[int]] = []
    for row in rows:
        mtyp = int(row["epl.mtyp"][0])
        if mtyp == 1:
            cycles.append([])
        elif mtyp == 4:
            cycles[-1].append(int(row["epl.src"][0]))
            assert int(row["epl.pres.size"][0]) == size
    assert cycles == [list(range(1, nodes + 1))] * 3
    _assert_no_overlap(path, None)  # a hub network is half duplex: no two frames overlap at all


@pytest.mark.tshark
@pytest.mark.parametrize(("nodes", "size", "redundant", "layout"), ECAT_CASES)
def test_ecat_pcap_is_clean_and_every_slave_answers(
    tshark: str, tmp_path: Path, nodes: int, size: int, redundant: bool, layout: str
) -> None:
    path = tmp_path / "ecat.pcap"
    kw = {"closed_ring": redundant, "layout": layout, "cycles": 2, "seed": 3}
    simulate_ecat(nodes, size, WIRE, pcap=path, **kw)  # type: ignore[arg-type]
    assert tshark_util.problems(tshark, path) == []
    rows = tshark_util.fields(
        tshark, path, ["eth.src", "ecat.subframe.length", "ecat.cnt", "ecat.lad"]
    )
    returned = [row for row in rows if int(row["eth.src"][0].split(":")[0], 16) & 0x02]
    sent = [row for row in rows if row["eth.src"] == ["00:00:5e:00:53:01"]]
    assert len(returned) == len(sent)
    copies = [row for row in rows if row["eth.src"] == ["00:00:5e:00:53:02"]]
    # closed ring: the second port's copy goes out and comes back unprocessed (WKC 0)
    assert len(copies) == (2 * len(sent) if redundant else 0)
    assert all(int(v) == 0 for row in copies for v in row["ecat.cnt"])
    per_cycle = len(returned) // 2
    for cycle in (returned[:per_cycle], returned[per_cycle:]):
        lengths = [int(v) for row in cycle for v in row["ecat.subframe.length"]]
        counts = [int(v) for row in cycle for v in row["ecat.cnt"]]
        assert sum(lengths) == nodes * size  # every taxel byte of every slave, once
        assert all(c > 0 for c in counts)
        if layout == "per-slave":
            assert lengths == [size] * nodes and counts == [1] * nodes
        else:  # each datagram's WKC is the number of slaves whose bytes it covers (hand rule)
            lads = [int(v, 0) for row in cycle for v in row["ecat.lad"]]
            for lad, n_bytes, wkc in zip(lads, lengths, counts, strict=True):
                assert wkc == (lad + n_bytes - 1) // size - lad // size + 1
    if redundant:  # two ports: a classic pcap cannot tell them apart; the records know them
        _r, recs = records(simulate_ecat, nodes, size, WIRE, **kw)
        assert_gaps(recs, WIRE, 0)
    else:
        _assert_no_overlap(path, {ethercat.MASTER_MAC})


def test_returned_frames_carry_each_slaves_taxels() -> None:
    n, size = 23, taxel.PATCH_BYTES
    r, recs = records(simulate_ecat, n, size, PAPER, cycles=2, seed=5)
    samples = taxel.sample_payloads(n, 2, size, seed=5)
    for c, cycle in enumerate(by_cycle(r, recs)):
        got = b""
        for rec in cycle:
            frame = decode_frame(rec[3])
            if frame.src == ethercat.returned_mac(ethercat.MASTER_MAC):
                assert isinstance(frame.payload, ethercat.EcatFrame)
                got += b"".join(d.data for d in frame.payload.datagrams)
        assert got == samples[c].tobytes()


def test_epl_pres_carry_the_taxels_and_soc_the_cycle_time() -> None:
    r, recs = records(simulate_epl, 5, 192, PAPER, cycles=2, seed=9)
    samples = taxel.sample_payloads(5, 2, 192, seed=9)
    for c, cycle in enumerate(by_cycle(r, recs)):
        msgs = [decode_frame(rec[3]).payload for rec in cycle]
        pres = [m for m in msgs if isinstance(m, powerlink.PRes)]
        assert [m.payload for m in pres] == [samples[c, i].tobytes() for i in range(5)]
        soc = msgs[0]
        assert isinstance(soc, powerlink.SoC)
        assert soc.relative_time_us == cycle[0][0] // 1_000_000
        assert cycle[0][0] == c * r.details[0].cycle_ps  # every cycle as long as the first


def test_gaps_respect_the_ifg_in_the_wire_preset() -> None:
    for fn, n, b in ((simulate_epl, 20, 100), (simulate_ecat, 30, 192)):
        _, recs = records(fn, n, b, WIRE, cycles=2)
        assert_gaps(recs, WIRE, WIRE.ifg_ps)


def test_logical_layout_uses_fewer_bytes() -> None:
    per_slave = frames_for(160, 192, "per-slave")
    logical = frames_for(160, 192, "logical")
    assert len(per_slave) == 23  # ceil(160 / 7)
    assert len(logical) == 21  # ceil(160 x 192 / 1486)
    assert (
        simulate_ecat(160, 192, WIRE, layout="logical", cycles=1).cycle_us()["min"]
        < simulate_ecat(160, 192, WIRE, cycles=1).cycle_us()["min"]
    )
    assert ethernet.MAX_PAYLOAD_BYTES == 1500


@pytest.mark.parametrize(
    ("datagram", "wkc", "adp_back", "slaves"),
    [
        (Datagram(Command.APRD, (-2) & 0xFFFF, 0x0130, bytes(2)), 1, 8, (2,)),  # ADP 0xFFFE: pos 2
        (Datagram(Command.APWR, 0, 0x0010, bytes(2)), 1, 10, (0,)),
        (Datagram(Command.APRW, 0xFFFF, 0x0120, bytes(2)), 3, 9, (1,)),
        (Datagram(Command.FPRD, 0x1003, 0x0130, bytes(2)), 1, 0x1003, (2,)),
        (Datagram(Command.FPRD, 0x2000, 0x0130, bytes(2)), 0, 0x2000, ()),  # nobody
        (Datagram(Command.BRD, 0, 0x0130, bytes(2)), 10, 10, tuple(range(10))),
        (Datagram(Command.BRW, 0, 0x0120, bytes(2)), 30, 10, tuple(range(10))),
        # bytes 100..291 of 96-byte slaves: slaves 1 (96..191), 2 (192..287), 3 (288..383); a
        # SyncManager buffer is read only from its start address (datasheet I 8): not slave 1
        (Datagram.logical(Command.LRD, 100, bytes(192)), 2, 100, (2, 3)),
        (Datagram.logical(Command.LWR, 0, bytes(192)), 0, 0, ()),  # inputs only: nobody writes
        (Datagram.logical(Command.LRW, 0, bytes(96)), 1, 0, (0,)),
        (Datagram(Command.FRMW, 0x1001, 0x0910, bytes(8)), 10, 0x1001, tuple(range(10))),
        (Datagram(Command.NOP, 0, 0, bytes(2)), 0, 0, ()),
    ],
)
def test_esc_addressing_and_working_counter(
    datagram: Datagram, wkc: int, adp_back: int, slaves: tuple[int, ...]
) -> None:
    """ETG.1000.4 addressing and WKC rules, hand-applied to a chain of 10 input-only slaves in
    OP, asked of the register-level ESCs the timing engine uses."""
    eff = EcatChain.configured(10, 96).frame_effect(ethercat.EcatFrame((datagram,)))
    everyone = range(10)
    back, _ = eff.returned(everyone, None)
    acted = tuple(s.position for s in eff.slaves if s.wkc[0])
    assert (eff.wkc(everyone), back.datagrams[0].adp, acted) == (wkc, adp_back, slaves)


def test_esc_register_reads_return_station_and_al_status() -> None:
    chain = EcatChain.configured(4, 16)
    for d, value in (
        (Datagram(Command.FPRD, 0x1002, 0x0010, bytes(2)), (0x1002).to_bytes(2, "little")),
        (Datagram(Command.BRD, 0, 0x0130, bytes(2)), bytes([0x08, 0])),  # AL status OP in all
    ):
        back, _ = chain.frame_effect(ethercat.EcatFrame((d,))).returned(range(4), None)
        assert back.datagrams[0].data == value


@pytest.mark.parametrize(
    ("call", "args"),
    [
        (simulate_epl, (0, 192)),
        (simulate_epl, (240, 192)),
        (simulate_epl, (4, 1491)),
        (simulate_ecat, (0, 192)),
        (simulate_ecat, (4, 0)),
        (simulate_ecat, (4, 1487)),
    ],
)
def test_impossible_networks_raise_topology_error(call, args) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(TopologyError):
        call(*args, PAPER)


def test_asnd_phase_costs_frame_turnaround_and_hub_chain() -> None:
    """With --asnd, CN k answers the SoA: eq. (11)'s bytes plus D_CN and 2(k+1) hops (hand sum)."""
    n = 4
    r, recs = records(simulate_epl, n, 192, PAPER, cycles=3 * n, asnd=True)
    base = simulate_epl(n, 192, PAPER, cycles=1).details[0].cycle_ps
    asnd_frame_ps = (8 + 72 + 4) * 80_000  # a 72-byte StatusResponse (openPOWERLINK minimum)
    assert [d.cycle for d in r.details] == list(range(n))  # one period listed, then repeated
    for c, detail in enumerate(r.details):
        k = c + 1  # the CN invited in cycle c
        assert detail.cycle_ps == base + 1_000_000 + 2 * (k + 1) * 300_500 + asnd_frame_ps
    assert_gaps(recs, PAPER, 0)
    kinds = [type(decode_frame(rec[3]).payload).__name__ for rec in recs[: 2 * n + 3]]
    assert kinds[-2:] == ["SoA", "ASnd"]
    socs = [rec[0] for rec in recs if type(decode_frame(rec[3]).payload).__name__ == "SoC"]
    assert len(socs) == 3 * n and socs[n] - socs[0] == sum(d.cycle_ps for d in r.details)


def test_pres_timeout_shorter_than_the_chain_needs_is_a_loss_the_mn_counts() -> None:
    # CN 39 of a paper-preset chain: 2 x 40 hops x 0.3005 us + 1 us = 25.04 us > 25 us
    r = simulate_epl(45, 192, PAPER, cycles=3, pres_timeout_ps=25_000_000)
    assert [(d.wkc, d.expected_wkc) for d in r.details] == [(38, 45)]  # CNs 39..45 never in time
    assert any(line.startswith("CN 39: 3 of 3 PRes lost") for line in r.diagnosis)
    assert not any(line.startswith("CN 38:") for line in r.diagnosis)
    assert simulate_epl(38, 192, PAPER, cycles=1, pres_timeout_ps=25_000_000).diagnosis == []
