"""The emulated EPL CN offline: frames an MN sends, written byte by byte from DS 301.

Every MN frame here is typed in as hex from EPSG DS 301 V1.4.0 (4.6.1.1 frame layouts, 7.3.1
NMT commands, 6.3.2 SDO sequence and command layers) and the byte sequences the
openPOWERLINK kit's README documents for its MN; the expected answers are typed in the same
way, or read back by tshark. Nothing expected here comes from the code under test.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tshark_util
from epl_frames import (
    TAXELS,
    booted,
    epl,
    feed,
    nmt_command,
    preq,
    sdo,
    soa,
    soc,
    status_of,
)

from emulator.epl.skin import EplSkin
from emulator.errors import SdoAbortError
from skinframes.pcap import write_pcap


# --- NMT (DS 301 7.1.4) --------------------------------------------------------------------------
def test_boot_to_operational_and_back() -> None:
    skin = EplSkin([1, 32], TAXELS)
    assert feed(skin, soa(1, 1)) is None  # NotActive: silent, then PreOp1 (CT2)
    assert status_of(skin, 1) == 0x1D
    assert feed(skin, preq(1)) is None  # no PRes in PreOp1
    feed(skin, soc())
    assert status_of(skin, 1) == 0x5D  # PreOp2 (CT4)
    feed(skin, nmt_command(1, 0x21))  # StartNode in PreOp2: not allowed, ignored
    assert status_of(skin, 1) == 0x5D
    feed(skin, nmt_command(1, 0x24))  # EnableReadyToOperate (CT5)
    assert status_of(skin, 1) == 0x6D
    assert status_of(skin, 32) == 0x5D  # addressed to node 1 only
    feed(skin, nmt_command(1, 0x21))  # StartNode (CT6)
    assert status_of(skin, 1) == 0xFD
    feed(skin, nmt_command(1, 0x22))  # StopNode (CT7)
    assert status_of(skin, 1) == 0x4D
    assert feed(skin, preq(1)) is None  # Stopped: no PRes
    feed(skin, nmt_command(1, 0x23))  # EnterPreOperational2 (CT10)
    assert status_of(skin, 1) == 0x5D
    feed(skin, nmt_command(255, 0x2A))  # ResetConfiguration to all: NotActive (GT7, CT1)
    assert feed(skin, soa(2, 1)) is None  # NotActive: silent; the SoA wakes both (CT2)
    assert status_of(skin, 1) == status_of(skin, 32) == 0x1D


def test_extended_commands_use_the_node_list() -> None:
    """NMTStartNodeEx 0x41 etc. (DS 301 7.3.1.2.2): a 32-byte node list, bit n = node n."""
    skin = booted(1, 32, 110)
    node_list = bytearray(32)
    for n in (1, 110):
        node_list[n // 8] |= 1 << (n % 8)
    feed(skin, nmt_command(255, 0x44, node_list.hex()))  # EnableReadyToOperateEx
    assert [status_of(skin, n) for n in (1, 32, 110)] == [0x6D, 0x5D, 0x6D]


def test_reset_node_restores_the_defaults() -> None:
    skin = booted(1)
    feed(skin, sdo(1, "00 01 00 00"))  # open a connection (see the SDO tests)
    feed(skin, sdo(1, "01 02 00 00"))
    feed(skin, sdo(1, "02 06 00 00", "00 00 00 01 08 00 00 00 06 10 00 00 50 c3 00 00"))
    assert skin.nodes[0].od.u(0x1006, 0) == 50_000
    feed(skin, nmt_command(255, 0x28))  # NMTResetNode: reset application and communication
    assert skin.nodes[0].od.u(0x1006, 0) == 0
    assert not skin.nodes[0].sdo.connected


def test_loss_of_soc_drops_to_preop1() -> None:
    """0x1C0B: each cycle without SoC adds 8 to the threshold counter; at 0x1C0B/3 (default
    15: two losses) the CN goes to PreOp1 (NMT_CT11). A SoC in time keeps it where it is."""
    skin = booted(1)
    cn = skin.nodes[0]
    cn.od.set_value(0x1006, 0, (10_000).to_bytes(4, "little"))  # 10 ms cycle
    tolerance_ns = cn.od.u(0x1C14, 0)
    feed(skin, soc(), now_ns=1_000_000_000)
    skin.tick(1_000_000_000 + 10_000_000 + tolerance_ns)  # exactly on time: no loss
    assert status_of(skin, 1) == 0x5D and cn.od.u(0x1C0B, 1) == 0
    skin.tick(1_000_000_000 + 10_000_000 + tolerance_ns + 1)
    assert cn.od.u(0x1C0B, 1) == 1 and status_of(skin, 1) == 0x5D
    skin.tick(1_000_000_000 + 20_000_000 + tolerance_ns + 1)
    assert cn.od.u(0x1C0B, 1) == 2
    assert status_of(skin, 1) == 0x1D


def test_basic_ethernet_after_the_timeout() -> None:
    """NMT_CT3: NotActive and no EPL frame for 0x1F99 (default 5 s) -> BasicEthernet; an EPL
    frame then -> PreOp1 (CT12)."""
    skin = EplSkin([1], TAXELS)
    skin.tick(1)
    skin.tick(5_000_000_001)
    assert skin.nodes[0].nmt.state.name == "NOT_ACTIVE"
    skin.tick(5_000_001_002)
    assert skin.nodes[0].nmt.state.name == "BASIC_ETHERNET"
    feed(skin, preq(32))
    assert status_of(skin, 1) == 0x1D


# --- PRes (DS 301 4.6.1.1.4) ----------------------------------------------------------------------
def test_pres_carries_the_mapping_rd_only_in_operational() -> None:
    skin = booted(7)
    cn = skin.nodes[0]
    taxels = bytes(range(100, 100 + TAXELS))
    cn.publish(taxels)
    whole = feed(skin, preq(7))
    assert whole is not None and whole[:14] == bytes.fromhex("01111e000002 020000000a07 88ab")
    empty = epl(whole)
    # 04 ff 07, NMTStatus 5D, flags1 0 (no RD), flags2 0, PDOVersion 0, reserved, size 0
    assert empty[:10] == bytes.fromhex("04ff075d000000000000")
    assert len(empty) == 10 + 36  # the frame spans PResActPayloadLimit 0x1F98/5 (default 36)
    # map 0x6100/1 (8*24 bits at 0) and 0x6000/1 (8 bits at 192), as an MN writes it by SDO
    od = cn.od
    with pytest.raises(SdoAbortError) as exc:  # limits go down to 36 only (DS 301 7.2.1.1.18)
        od.write(0x1F98, 5, (TAXELS + 1).to_bytes(2, "little"))
    assert exc.value.code == 0x06090032
    od.write(0x1A00, 1, bytes.fromhex("00 61 01 00 00 00 c0 00"))  # 0x00C0_0000_0001_6100
    od.write(0x1A00, 2, bytes.fromhex("00 60 01 00 c0 00 08 00"))  # 0x0008_00C0_0001_6000
    od.write(0x1A00, 0, b"\x02")
    od.write(0x1600, 1, bytes.fromhex("00 62 01 00 00 00 08 00"))  # RPDO: 0x6200/1 from PReq
    od.write(0x1600, 0, b"\x01")
    feed(skin, nmt_command(7, 0x2A))  # ResetConfiguration: the mapping takes effect
    feed(skin, soa(0, 0))
    feed(skin, soc())
    pres = epl(feed(skin, preq(7, "5a")))
    assert pres[:10] == bytes.fromhex("04ff075d000000001900")  # size 25
    assert pres[10:34] == taxels and pres[34] == 1  # the taxels, then the sample number
    assert len(pres) == 10 + 36 and not any(pres[35:])  # zeros up to PResActPayloadLimit
    assert cn.outputs == 0x5A  # 0x6200/1 from the PReq's first byte
    feed(skin, nmt_command(7, 0x24))
    feed(skin, nmt_command(7, 0x21))
    pres = epl(feed(skin, preq(7)))
    assert pres[3] == 0xFD and pres[4] == 0x01  # Operational, RD


def test_mapping_rules_answer_with_abort_codes() -> None:
    od = booted(1).nodes[0].od
    with pytest.raises(SdoAbortError) as exc:  # 0x1000 is not mappable (6.4.9.2)
        od.write(0x1A00, 1, (0x0020_0000_0000_1000).to_bytes(8, "little"))
        od.write(0x1A00, 0, b"\x01")
    assert exc.value.code == 0x06040041
    od.write(0x1A00, 1, (0x0100_0000_0001_6100).to_bytes(8, "little"))  # 256 bits > 24 bytes
    with pytest.raises(SdoAbortError) as exc:
        od.write(0x1A00, 0, b"\x01")
    assert exc.value.code == 0x06040042
    wide = EplSkin([1], 48).nodes[0].od  # 48 taxel bytes: more than PResActPayloadLimit 36
    wide.write(0x1A00, 1, (0x0180_0000_0001_6100).to_bytes(8, "little"))
    with pytest.raises(SdoAbortError) as exc:
        wide.write(0x1A00, 0, b"\x01")
    assert exc.value.code == 0x06040042
    wide.write(0x1F98, 5, (48).to_bytes(2, "little"))
    wide.write(0x1A00, 0, b"\x01")
    od.write(0x1A00, 1, (0x0008_0000_0001_6000).to_bytes(8, "little"))
    od.write(0x1A00, 0, b"\x01")
    with pytest.raises(SdoAbortError) as exc:  # entries change only while /0 is 0
        od.write(0x1A00, 1, (0x0008_0000_0001_6000).to_bytes(8, "little"))
    assert exc.value.code == 0x08000022


# --- error signalling (DS 301 6.5.5, 6.5.8) ------------------------------------------------------
def flags_of(skin: EplSkin, node: int, er: bool) -> int:
    """flags1 of the StatusResponse to a StatusRequest with ER = ``er`` (ASnd byte 4)."""
    return epl(feed(skin, soa(2, node, er=er)))[4]


def test_ec_answers_er_and_a_reset_sets_it_again() -> None:
    """6.5.5.1: a CN starts with EC = 1; the MN's ER 1 -> 0 handshake clears it; a reset sets
    it again, so that the MN sees the CN was reset (EC 0x08, EN 0x10)."""
    skin = booted(1)
    assert flags_of(skin, 1, er=False) == 0x08  # fresh: EC set
    assert flags_of(skin, 1, er=True) == 0x08
    assert flags_of(skin, 1, er=True) == 0x08
    assert flags_of(skin, 1, er=False) == 0x00  # ER 1 -> 0: EC cleared
    assert flags_of(skin, 1, er=False) == 0x00
    feed(skin, nmt_command(1, 0x29))  # NMTResetCommunication
    feed(skin, soa(0, 0))  # NotActive -> PreOp1
    assert flags_of(skin, 1, er=False) == 0x08


def test_loss_of_soc_threshold_is_an_error_entry(tmp_path: Path, tshark: str) -> None:
    """The cycle error of 0x1C0B becomes an entry of the StatusResponse (type 0x7002: emergency,
    occurred, EPL profile; code 0x8245 E_DLL_LOSS_SOC_TH; time: the SoC's NetTime moved on by
    the host's clock) and toggles EN in StatusResponse and PRes."""
    skin = booted(1)
    cn = skin.nodes[0]
    cn.od.set_value(0x1006, 0, (10_000).to_bytes(4, "little"))
    tolerance_ns = cn.od.u(0x1C14, 0)
    # SoC with NetTime 1000 s + 5 ns (DS 301 4.6.1.1.1: seconds u32, nanoseconds u32)
    feed(skin, soc("e8030000 05000000"), now_ns=7_000_000_000)
    flags_of(skin, 1, er=True)  # the ER handshake: EC 1, then 0
    assert flags_of(skin, 1, er=False) == 0x00
    lost_at = 7_000_000_000 + 20_000_000 + tolerance_ns + 1  # two losses: threshold 15
    skin.tick(7_000_000_000 + 10_000_000 + tolerance_ns + 1)
    skin.tick(lost_at)
    status = feed(skin, soa(2, 1))
    assert status is not None and len(status) == 72
    assert epl(status)[4] == 0x10  # EN toggled
    write_pcap(tmp_path / "status.pcap", [(0, status)])
    (row,) = tshark_util.fields(
        tshark,
        tmp_path / "status.pcap",
        ["epl.asnd.sres.el.entry.type", "epl.asnd.sres.el.entry.code", "epl.asnd.sres.en"],
    )
    assert int(row["epl.asnd.sres.el.entry.type"][0], 0) == 0x7002
    assert int(row["epl.asnd.sres.el.entry.code"][0], 0) == 0x8245
    entry = epl(status)[18:38]  # the first entry: type, code, time s, time ns, 8 bytes info
    elapsed_ns = lost_at - 7_000_000_000
    assert int.from_bytes(entry[4:8], "little") == 1000
    assert int.from_bytes(entry[8:12], "little") == 5 + elapsed_ns


def test_a_published_sample_reaches_the_nodes_between_frames() -> None:
    """EplSkin.publish only notes the sample; refresh hands it out, node by node, in order.
    0x6000/1 (mapped behind the taxels) carries the sample's number."""
    skin = booted(1, 2)
    for cn in skin.nodes:
        cn.od.write(0x1A00, 1, (0x00C0_0000_0001_6100).to_bytes(8, "little"))
        cn.od.write(0x1A00, 2, (0x0008_00C0_0001_6000).to_bytes(8, "little"))
        cn.od.write(0x1A00, 0, b"\x02")
    feed(skin, nmt_command(255, 0x2A))
    feed(skin, soa(0, 0))
    feed(skin, soc())
    rows = np.arange(2 * TAXELS, dtype=np.uint8).reshape(2, TAXELS)
    skin.publish(rows)
    assert epl(feed(skin, preq(1)))[10:35] == bytes(TAXELS + 1)  # not handed out yet
    skin.refresh(1)
    assert epl(feed(skin, preq(1)))[10:35] == rows[0].tobytes() + b"\x01"
    assert epl(feed(skin, preq(2)))[10:35] == bytes(TAXELS + 1)
    skin.publish(rows[::-1])
    skin.refresh()
    assert epl(feed(skin, preq(1)))[10:35] == rows[1].tobytes() + b"\x02"
    assert epl(feed(skin, preq(2)))[10:35] == rows[0].tobytes() + b"\x02"
