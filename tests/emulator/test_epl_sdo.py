"""The emulated CN's SDO server offline, and its IdentResponse/StatusResponse read by tshark.

MN frames and expected answers are typed in from DS 301 V1.4.0 6.3.2 (sequence layer: Tables
51-52; command layer: 6.3.2.4, Table 55; abort codes: Table 58) and from the exchange the
openPOWERLINK kit's README documents: MN (0,1) InitReq -> CN (1,1) -> MN (1,2) -> CN (2,2), then
each command advances its sender's sequence number.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import tshark_util
from epl_frames import TAXELS, booted, epl, feed, invite, sdo, soa

from emulator.epl.skin import EplSkin
from skinframes.pcap import write_pcap

CN_SDO = bytes.fromhex("06f00105")  # ASnd from node 1 to the MN (240), ServiceID 5


def answers(skin: EplSkin, node: int = 1) -> list[bytes]:
    """Every queued frame of ``node``, one SoA UnspecifiedInvite each: the bytes after the ASnd
    header up to the end of the SDO (the sequence layer, 4, plus the command layer, present
    when its CommandID is not 0 or Abort is set, as Wireshark reads it)."""
    out = []
    while (frame := invite(skin, node)) is not None:
        body = epl(frame)
        assert body[:4] == CN_SDO[:1] + bytes((0xF0, node, 5))
        assert len(frame) >= 60  # an ASnd is a whole Ethernet frame
        sdo = body[4:]  # the SDO and the frame's padding: cut where the SDO ends (6.3.2.4.1)
        has_command = len(sdo) >= 12 and (sdo[7] != 0 or sdo[6] & 0x40)
        out.append(sdo[: 12 + int.from_bytes(sdo[8:10], "little")] if has_command else sdo[:4])
    return out


def connected() -> EplSkin:
    skin = booted(1)
    feed(skin, sdo(1, "00 01 00 00"))  # InitReq: rcon 0, ssnr 0 scon 1
    assert [a[:4] for a in answers(skin)] == [bytes.fromhex("01010000")]  # (1,1)
    feed(skin, sdo(1, "01 02 00 00"))  # rsnr 0 rcon 1, ssnr 0 scon 2
    assert [a[:4] for a in answers(skin)] == [bytes.fromhex("02020000")]  # (2,2): valid
    return skin


def test_the_readme_sequence_write_read_abort_close() -> None:
    skin = connected()
    # WriteByIndex 0x1006/0 = 50000 (tid 0): MN ssnr 1; CN answers ssnr 1, acks 1
    feed(skin, sdo(1, "02 06 00 00", "00 00 00 01 08 00 00 00 06 10 00 00 50 c3 00 00"))
    assert answers(skin) == [bytes.fromhex("06060000 00008001 00000000")]
    assert skin.nodes[0].od.u(0x1006, 0) == 50_000
    feed(skin, sdo(1, "06 06 00 00"))  # the MN's acknowledgement: nothing to answer
    assert answers(skin) == []
    # ReadByIndex 0x1018/4 (serial number = the node id), tid 1
    feed(skin, sdo(1, "06 0a 00 00", "00 01 00 02 04 00 00 00 18 10 04 00"))
    assert answers(skin) == [bytes.fromhex("0a0a0000 00018002 04000000 01000000")]
    # 0x1011/1 "load" (restore defaults), as the openPOWERLINK MN writes it first: this CN
    # stores nothing, abort 0x08000020; then an unknown object: 0x06020000
    feed(skin, sdo(1, "0a 0e 00 00", "00 02 00 01 08 00 00 00 11 10 01 00 6c 6f 61 64"))
    assert answers(skin) == [bytes.fromhex("0e0e0000 0002c001 04000000 20000008")]
    feed(skin, sdo(1, "0e 12 00 00", "00 03 00 01 05 00 00 00 34 12 00 00 01"))
    assert answers(skin) == [bytes.fromhex("12120000 0003c001 04000000 00000206")]
    feed(skin, sdo(1, "12 16 00 00", "00 04 00 01 05 00 00 00 00 10 00 00 01"))  # const 0x1000
    assert answers(skin)[0][8:] == bytes.fromhex("04000000 02000106")
    feed(skin, sdo(1, "16 1a 00 00", "00 05 00 01 06 00 00 00 06 10 00 00 01 02"))  # 2 bytes
    assert answers(skin)[0][8:] == bytes.fromhex("04000000 13000706")  # length too low
    feed(skin, sdo(1, "1a 1e 00 00", "00 06 00 02 04 00 00 00 06 10 07 00"))  # read sub 7
    assert answers(skin)[0][8:] == bytes.fromhex("04000000 11000906")
    feed(skin, sdo(1, "1e 22 00 00", "00 07 00 09 04 00 00 00 06 10 00 00"))  # command 9
    assert answers(skin)[0][8:] == bytes.fromhex("04000000 01000405")
    feed(skin, sdo(1, "22 00 00 00"))  # close: scon 0
    assert answers(skin) == [] and not skin.nodes[0].sdo.connected
    # a command without a connection is answered "no connection" (rcon 0, scon 0)
    feed(skin, sdo(1, "22 26 00 00", "00 08 00 02 04 00 00 00 00 10 00 00"))
    assert answers(skin) == [bytes.fromhex("24000000")]


def test_segmented_write() -> None:
    """An initiate segment (DataSize 8, 0x1A00/1, 4 bytes), then the complete one (4 bytes):
    acknowledged without a command, answered once complete."""
    skin = connected()
    initiate = "00 09 10 01 0c 00 00 00 08 00 00 00 00 1a 01 00 00 60 01 00"
    feed(skin, sdo(1, "02 06 00 00", initiate))
    assert answers(skin) == [bytes.fromhex("06020000")]
    feed(skin, sdo(1, "02 0a 00 00", "00 09 30 01 04 00 00 00 00 00 08 00"))
    assert answers(skin) == [bytes.fromhex("0a060000 00098001 00000000")]
    assert skin.nodes[0].od.u(0x1A00, 1) == 0x0008_0000_0001_6000


def test_segmented_read_of_a_long_octet_string() -> None:
    """0x6100/1 of 1490 taxel bytes exceeds one segment (1500 - 4 - 4 - 8 = 1484 bytes):
    initiate (DataSize 1490 + 1480 bytes), then complete (10 bytes)."""
    skin = EplSkin([1], 1490)
    feed(skin, soa(0, 0))
    skin.nodes[0].publish(bytes(range(256)) * 5 + bytes(210))
    feed(skin, sdo(1, "00 01 00 00"))
    feed(skin, sdo(1, "01 02 00 00"))
    answers(skin)
    feed(skin, sdo(1, "02 06 00 00", "00 05 00 02 04 00 00 00 00 61 01 00"))
    first, last = answers(skin)
    assert first[:12] == bytes.fromhex("06060000 00059002 cc050000")  # initiate, size 1484
    assert first[12:16] == (1490).to_bytes(4, "little")
    assert last[:12] == bytes.fromhex("060a0000 0005b002 0a000000")  # complete, 10 bytes
    assert first[16:] + last[12:22] == skin.nodes[0].taxels


def test_sequence_errors_ack_requests_and_retransmission() -> None:
    skin = connected()
    feed(skin, sdo(1, "02 0a 00 00"))  # ssnr 2 skips 1: frames lost -> rcon 3 (error response)
    assert answers(skin) == [bytes.fromhex("03020000")]
    feed(skin, sdo(1, "02 03 00 00"))  # scon 3 with the old ssnr: acknowledge at once
    assert answers(skin) == [bytes.fromhex("02020000")]
    feed(skin, sdo(1, "02 06 00 00", "00 01 00 02 04 00 00 00 00 10 00 00"))  # read 0x1000
    reply = answers(skin)
    assert reply == [bytes.fromhex("06060000 00018002 04000000 91010f00")]
    feed(skin, sdo(1, "03 06 00 00"))  # rcon 3, rsnr 0: the MN lost our reply: send it again
    assert answers(skin) == reply
    feed(skin, sdo(1, "06 06 00 00"))  # acknowledged: nothing kept, nothing sent
    assert answers(skin) == [] and not skin.nodes[0].sdo.seq.history


@pytest.fixture
def frames(tmp_path: Path) -> Path:
    """The CN's IdentResponse and StatusResponse (ER set) after an SDO write of 0x1020/1,2."""
    skin = connected()
    feed(skin, sdo(1, "02 06 00 00", "00 00 00 01 08 00 00 00 20 10 01 00 24 31 00 00"))
    feed(skin, sdo(1, "06 0a 00 00", "00 01 00 01 08 00 00 00 20 10 02 00 55 59 73 03"))
    answers(skin)
    ident, status = feed(skin, soa(1, 1)), feed(skin, soa(2, 1, er=True))
    assert ident is not None and status is not None
    assert len(ident) == 176 and len(status) == 72  # 14 + 162; the 72 an oPL MN needs
    path = tmp_path / "cn.pcap"
    write_pcap(path, [(0, ident), (1000, status)])
    return path


def test_ident_and_status_response_as_tshark_reads_them(tshark: str, frames: Path) -> None:
    assert tshark_util.problems(tshark, frames) == []
    names = [
        "epl.asnd.ires.state",
        "epl.asnd.ires.devicetype",
        "epl.asnd.ires.devicetype.add",
        "epl.asnd.ires.serialno",
        "epl.asnd.ires.productcode",
        "epl.asnd.ires.confdate",
        "epl.asnd.ires.conftime",
        "epl.asnd.ires.pollinsize",
        "epl.asnd.ires.polloutsizes",
        "epl.asnd.ires.mtu",
        "epl.asnd.ires.ip",
        "epl.asnd.ires.hostname",
        "epl.asnd.ires.features",
        "epl.asnd.sres.stat",
        "epl.asnd.sres.ec",
    ]
    ident, status = tshark_util.fields(tshark, frames, names)
    got = {k: v[0] for row in (ident, status) for k, v in row.items() if v}
    assert int(got["epl.asnd.ires.state"], 0) == 0x5D  # PreOperational2
    assert int(got["epl.asnd.ires.devicetype"], 0) == 401  # CiA 401, generic I/O
    assert int(got["epl.asnd.ires.devicetype.add"], 0) == 0x000F  # 0x1000 bits 16-31
    assert int(got["epl.asnd.ires.serialno"], 0) == 1
    assert int(got["epl.asnd.ires.productcode"], 0) == 0x534B494E
    assert int(got["epl.asnd.ires.confdate"], 0) == 0x3124
    assert int(got["epl.asnd.ires.conftime"], 0) == 0x03735955
    assert (
        int(got["epl.asnd.ires.pollinsize"], 0) == int(got["epl.asnd.ires.polloutsizes"], 0) == 36
    )
    assert int(got["epl.asnd.ires.mtu"], 0) == 1500
    assert got["epl.asnd.ires.ip"] == "192.168.100.1"
    assert got["epl.asnd.ires.hostname"] == "01-00000000"
    assert int(got["epl.asnd.ires.features"], 0) == 0x65
    assert int(got["epl.asnd.sres.stat"], 0) == 0x5D
    assert got["epl.asnd.sres.ec"] in ("1", "True")  # ER in the SoA: EC in the answer


def test_taxel_bytes_setting_is_kept_per_node() -> None:
    skin = EplSkin([3, 4], TAXELS)
    assert [cn.od.u(0x1018, 4) for cn in skin.nodes] == [3, 4]
