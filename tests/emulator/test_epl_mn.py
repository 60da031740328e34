"""The emulated MN (emulator.epl.mn, mn_config, mn_live, sdo_client) offline, against the emulated
CNs of emulator.epl.skin on a simulated clock (tests/epl_mn_util.SimLink).

Expected values are typed from the kit's README ("What the oPL MN sends a CN at boot", the
shipped CDC's values), from DS 301 V1.4.0 (frame layouts 4.6.1.1, 6.3.2; PDO mapping 6.4.9.2;
SDO abort codes, Table 58) and by hand; the frames the MN sent are read byte by byte here, not
with the decoder it uses. The live judge is the real openPOWERLINK CN
(tests/emulator/test_live_epl_mn.py).
"""

from __future__ import annotations

import itertools
import random
import threading
from collections.abc import Callable
from typing import Any

import pytest
from epl_frames import hostile
from epl_mn_util import SimLink, shipped_files

from emulator.epl.mn import EplMn, Step, percentile_us
from emulator.epl.mn_config import MnConfig, mn_config
from emulator.epl.mn_live import MnRunStats, run_mn
from emulator.epl.od import ObjectDictionary
from emulator.epl.sdo_client import Phase, SdoClient
from emulator.epl.sdo_server import SdoServer
from emulator.epl.skin import EplSkin
from skinframes.powerlink import ASnd, IdentResponse, frame
from skinframes.powerlink.cdc import CdcEntry, SkinConfig, decode_cdc, encode_cdc, skin_cdc

IDS = (1, 32, 110)
EPL = 14  # EPL starts after the 14-byte Ethernet header
# The shipped CDC's 0x1F22 block of each CN, in order (the kit's README, step 5)
DEMO_BLOCK = [
    (0x1600, 0),
    (0x1A00, 0),
    (0x1006, 0),
    (0x1020, 1),
    (0x1020, 2),
    (0x1C0B, 3),
    (0x1C0D, 3),
    (0x1C14, 0),
    (0x1F98, 4),
    (0x1F98, 5),
    (0x1600, 1),
    (0x1A00, 1),
    (0x1600, 0),
    (0x1A00, 0),
]


def skin_config(block_extra: tuple[CdcEntry, ...] = ()) -> MnConfig:
    """The skin of CNs 1, 32, 110 with 24 taxel bytes at 10 ms, PRes timeout 1 ms; with
    ``block_extra`` written after each CN's block."""
    entries = list(skin_cdc(SkinConfig(IDS, 24, 10_000, 1_000, 1_000)))
    if block_extra:
        entries = [
            CdcEntry(e.index, e.subindex, encode_cdc((*e.nested, *block_extra)))
            if e.index == 0x1F22
            else e
            for e in entries
        ]
    return mn_config(entries)


def nmt_commands(sent: list[bytes]) -> list[tuple[int, int]]:
    """(destination, NMTCommandId) of each ASnd NMTCommand sent (DS 301 4.6.1.1.6: MessageType
    6 at EPL byte 0, destination 1, ServiceID 4 at byte 3, the command id at byte 4)."""
    return [(f[EPL + 1], f[EPL + 4]) for f in sent if f[EPL] == 0x06 and f[EPL + 3] == 0x04]


def sdo_writes(sent: list[bytes], node: int) -> list[tuple[int, int]]:
    """(index, sub-index) of each WriteByIndex the MN sent ``node``: ASnd ServiceID 5, the
    4-byte sequence layer at EPL 4, the command layer at EPL 8 (CommandID at 11, Index u16 at
    16, SubIndex at 18; DS 301 6.3.2.4.1, 6.3.2.4.2.1.1)."""
    out = []
    for f in sent:
        sdo_to_node = f[EPL] == 0x06 and f[EPL + 1] == node and f[EPL + 3] == 0x05
        # a WriteByIndex request (flags: neither response 0x80 nor abort 0x40)
        if sdo_to_node and len(f) > EPL + 19 and f[EPL + 11] == 0x01 and not f[EPL + 10] & 0xC0:
            out.append((int.from_bytes(f[EPL + 16 : EPL + 18], "little"), f[EPL + 18]))
    return out


def test_the_shipped_cdc_configures_the_mn_as_the_kit_says() -> None:
    config = mn_config(decode_cdc(shipped_files()["mnobd.cdc"]))
    assert config.cycle_us == 50_000 and config.async_slot_ns == 500_000
    assert config.node_ids == list(IDS)
    for node in config.nodes:
        assert node.pres_timeout_ns == 200_000
        assert node.preq_payload_bytes == 1  # the MN's TPDO maps 8 bits to each CN
        assert [(w.index, w.subindex) for w in node.writes] == DEMO_BLOCK
        assert (node.conf_date, node.conf_time) == (0x3124, 0x03735955)
        assert node.loss_of_pres_threshold == 40  # 0x1C09 (the kit's README, "What it checks")
    assert mn_config(decode_cdc(shipped_files()["mnobd.cdc"]), 20_000).cycle_us == 20_000


def test_a_cdc_without_cns_or_cycle_is_refused() -> None:
    from emulator.errors import TopologyError

    with pytest.raises(TopologyError, match="no CN assigned"):
        mn_config([CdcEntry(0x1006, 0, (10_000).to_bytes(4, "little"))])
    with pytest.raises(TopologyError, match="no cycle length"):
        mn_config([CdcEntry(0x1F81, 1, (7).to_bytes(4, "little"))])


def run(
    config: MnConfig, skin: EplSkin, *, drop: Callable[[bytes], bool] = lambda f: False
) -> tuple[EplMn, SimLink, MnRunStats]:
    """The MN of ``config`` against ``skin`` until 20 cycles with every CN Operational."""
    mn = EplMn(config)
    sim = SimLink(skin, drop=drop)
    stats = run_mn(mn, sim, threading.Event(), cycles=20)
    return mn, sim, stats


def test_the_mn_boots_the_emulated_cns_as_the_kit_describes() -> None:
    skin = EplSkin(list(IDS), 24)
    mn, sim, stats = run(skin_config(), skin)
    assert stats.operational_cycles == 20 and stats.errors == 0
    assert [cn.nmt.state.name for cn in skin.nodes] == ["OPERATIONAL"] * 3
    cns: Any = mn.report(stats.started_ns)["cns"]
    assert [cn["state"] for cn in cns] == ["OPERATIONAL"] * 3
    for cn in cns:
        assert cn["losses"] == 0 and cn["polls"] >= 20
        assert cn["response_us_median"] == 30.0  # SimLink: every answer 30 us after its PReq
    # the order of the kit's README: NMTResetNode to all, then per CN ResetConfiguration,
    # EnableReadyToOperate, StartNode
    commands = nmt_commands(sim.sent)
    assert commands[0] == (255, 0x28)
    for n in IDS:
        assert [c for d, c in commands if d == n] == [0x2A, 0x24, 0x21]
        assert sdo_writes(sim.sent, n) == [
            (e.index, e.subindex) for e in skin_config().nodes[IDS.index(n)].writes
        ]
    # StatusRequests (SoA MessageType 5, RequestedServiceID 2 at EPL byte 6, target at 7) with
    # ER (flags1 at EPL byte 4, 0x02) until the CN shows EC, then without: the error
    # signalling's reset (DS 301 6.5.3), after which no CN shows EC
    for n in IDS:
        er = [
            bool(f[EPL + 4] & 0x02)
            for f in sim.sent
            if f[EPL] == 0x05 and f[EPL + 6] == 0x02 and f[EPL + 7] == n
        ]
        # twice: before the SDO download and after NMTResetConfiguration
        assert [k for k, _ in itertools.groupby(er)] == [True, False, True, False], er
    assert not any(cn.errsig.ec for cn in skin.nodes)
    # what the CNs hold afterwards: the CDC's cycle and TPDO mapping (DS 301 6.4.9.2: length 16
    # | offset 16 | reserved 8 | sub-index 8 | index 16; 0x6100/1, 192 bits at 0)
    for cn in skin.nodes:
        assert cn.od.u(0x1006, 0) == 10_000
        assert cn.od.u(0x1A00, 1) == 0x00C0_0000_0001_6100


def test_an_sdo_abort_resets_the_cn_and_starts_its_boot_again() -> None:
    """A write to an object the CN lacks (0x1234/0): abort 0x06020000 (DS 301 Table 58, object
    does not exist), then NMTResetNode to that CN, as openPOWERLINK's MN does."""
    skin = EplSkin([1], 24)
    config = skin_config((CdcEntry(0x1234, 0, b"\x01"),))
    config = MnConfig(config.cycle_us, config.async_slot_ns, config.nodes[:1])
    mn = EplMn(config)
    stop = threading.Event()

    def inject(sent: bytes) -> list[bytes]:
        if len(sim.sent) > 3_000:
            stop.set()
        return []

    sim = SimLink(skin, inject=inject)
    run_mn(mn, sim, stop)
    node = mn.nodes[0]
    assert node.counts["sdo_aborts"] >= 1 and node.counts["boot_restarts"] >= 1
    assert node.step is not Step.OPERATIONAL
    assert (1, 0x28) in nmt_commands(sim.sent)  # NMTResetNode to the CN itself


def test_the_sdo_client_reports_the_abort_code() -> None:
    server = SdoServer(ObjectDictionary(1, 8))
    client = SdoClient(
        [CdcEntry(0x1006, 0, (5_000).to_bytes(4, "little")), CdcEntry(0x1234, 0, b"\x01")]
    )
    while not client.finished:
        out = client.next_frame()
        if out is None:
            pytest.fail(f"client stuck in {client.phase}")
        for answer in server.receive(out):
            client.receive(answer)
    assert client.phase is Phase.FAILED and client.done == 1
    assert client.abort_code == 0x06020000
    assert server.od.u(0x1006, 0) == 5_000


def test_lost_sdo_answers_make_the_mn_start_the_boot_again() -> None:
    """The first SDO answers of CN 1 are lost: the MN stops waiting, resets the CN, boots it
    again, and the CN ends OPERATIONAL."""
    skin = EplSkin([1], 24)
    config = skin_config()
    config = MnConfig(config.cycle_us, config.async_slot_ns, config.nodes[:1])
    lost = []

    def drop(answer: bytes) -> bool:  # the CN's SDO frames (ASnd ServiceID 5), the first 5
        if answer[EPL] == 0x06 and answer[EPL + 3] == 0x05 and len(lost) < 5:
            lost.append(answer)
            return True
        return False

    mn, _, stats = run(config, skin, drop=drop)
    assert len(lost) == 5
    assert mn.nodes[0].counts["sdo_timeouts"] >= 1
    assert stats.operational_cycles == 20 and skin.nodes[0].nmt.state.name == "OPERATIONAL"


def test_equal_conf_date_and_time_write_only_the_cycle() -> None:
    """IdentResponse ConfDate/ConfTime equal to 0x1F26/0x1F27: only 0x1006 is written (the
    kit's README, "What it checks")."""
    config = mn_config(decode_cdc(shipped_files()["mnobd.cdc"]))
    mn = EplMn(config)
    ident = IdentResponse(verify_conf_date=0x3124, verify_conf_time=0x03735955)
    mn.receive(frame(ASnd(ident, dest=255, src=32)).to_bytes(), 0)
    node = mn.by_id[32]
    assert node.step is Step.STATUS and node.sdo is not None
    assert [(w.index, w.subindex) for w in node.sdo.writes] == [(0x1006, 0)]
    other = IdentResponse(verify_conf_date=0x3124, verify_conf_time=1)
    mn.receive(frame(ASnd(other, dest=255, src=1)).to_bytes(), 0)
    assert mn.by_id[1].sdo is not None and len(mn.by_id[1].sdo.writes) == len(DEMO_BLOCK)


def test_hostile_frames_never_stop_the_mn() -> None:
    """After every frame the MN sends, a hostile one and a mangled copy of a CN answer arrive:
    the MN goes on, raises nothing, and counts what it could not use."""
    rng = random.Random(402)
    skin = EplSkin(list(IDS), 24)
    stop = threading.Event()
    mn = EplMn(skin_config())

    def inject(sent: bytes) -> list[bytes]:
        if len(sim.sent) > 20_000:
            stop.set()
        mangled = bytearray(skin.nodes[rng.randrange(3)].ident_frame)
        for _ in range(rng.randrange(1, 4)):
            mangled[rng.randrange(EPL, len(mangled))] = rng.randrange(256)
        return [hostile(rng), bytes(mangled), rng.randbytes(rng.randrange(0, 20))]

    sim = SimLink(skin, inject=inject)
    stats = run_mn(mn, sim, stop, cycles=50)
    assert stats.errors == 0, stats.error_messages
    assert sum(mn.counts.values()) > 0
    print(f"\nhostile: {dict(mn.counts)}, {stats.cycles} cycles")


def test_percentiles_are_nearest_rank() -> None:
    times = [k * 1000 for k in range(100, 0, -1)]  # 1..100 us, in any order
    assert percentile_us(times, 0.5) == 50.0  # rank ceil(0.5 * 100) = 50
    assert percentile_us(times, 0.99) == 99.0
    assert percentile_us([7_500], 0.99) == 7.5
    assert percentile_us([], 0.5) is None


def test_five_losses_in_a_row_reach_the_loss_of_pres_threshold() -> None:
    """0x1C09 = 40 (skin_cdc), DS 301's counter +8 per loss: the 5th loss in a row reaches it;
    the MN counts it and goes on polling (openPOWERLINK's MN would reset the CN)."""
    skin = EplSkin(list(IDS), 24)
    pres_of_1: list[bytes] = []

    def drop(answer: bytes) -> bool:  # PRes (MessageType 4) of CN 1 (source at EPL byte 2)
        if answer[EPL] == 0x04 and answer[EPL + 2] == 1:
            pres_of_1.append(answer)
            return 30 < len(pres_of_1) <= 35
        return False

    mn, _, stats = run(skin_config(), skin, drop=drop)
    node = mn.by_id[1]
    assert node.losses == 5 and node.counts["loss_of_pres_threshold"] == 1
    assert stats.operational_cycles == 20 and node.step is Step.OPERATIONAL
