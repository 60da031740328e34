"""VLAN tags, UDP/IPv4, all EtherCAT frame types and the M-bit chain, judged by tshark.

The tagged and UDP frames are built by scapy (Dot1Q, Dot1AD, IP, UDP), not by skinframes, around
the messages of the golden captures; tshark dissects them, and our decoder must show the same
fields, re-encode them byte-exact and find nothing wrong with them.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import tshark_util

from conformance.fields import ALL_FIELDS, CONTENT_FIELDS, UDP_FIELDS
from conformance.test_tshark import assert_fields_agree
from skinframes import decode_frame, encap, ethercat, golden, powerlink, read_capture
from skinframes.check import check_capture
from skinframes.dispatch import protocol_of
from skinframes.findings import Severity
from skinframes.pcap import write_pcap

pytestmark = pytest.mark.tshark

CHECKSUMS = ("-o", "ip.check_checksum:TRUE", "-o", "udp.check_checksum:TRUE")


def _messages() -> list[tuple[bytes, bytes, int, bytes]]:
    """(dst, src, EtherType, payload) of every golden frame: EtherCAT without Ethernet padding,
    EPL with it (Wireshark reads NMT services and the StatusResponse at fixed sizes, which
    the padding of a minimum-size frame provides)."""
    out = []
    for name in sorted(golden.SCENARIOS):
        for _, raw in golden.build(name):
            frame = decode_frame(raw)
            ecat = isinstance(frame.payload, ethercat.EcatFrame)
            body = frame.payload_bytes if ecat else raw[14:]
            out.append((frame.dst, frame.src, int(frame.ethertype or 0), body))
    return out


def _scapy_frames() -> list[bytes]:
    from scapy.layers.inet import IP, UDP
    from scapy.layers.l2 import Dot1AD, Dot1Q, Ether
    from scapy.packet import Raw

    frames: list[list[bytes]] = [[], [], [], []]  # one run per encapsulation: cycles stay whole
    for i, (dst, src, ethertype, body) in enumerate(_messages()):
        mac = {"dst": dst.hex(":"), "src": src.hex(":")}
        port = 3819 if ethertype == 0x88AB else 0x88A4
        ip = IP(src="192.168.100.1", dst="192.168.100.240", ttl=64 - i % 3, id=i)
        for run, pkt in zip(
            frames,
            (
                Ether(**mac) / Dot1Q(vlan=i % 4095 + 1, prio=i % 8, type=ethertype) / Raw(body),
                Ether(**mac) / Dot1AD(vlan=100) / Dot1Q(vlan=7, type=ethertype) / Raw(body),
                Ether(**mac) / ip / UDP(sport=port, dport=port) / Raw(body),
                Ether(**mac) / Dot1Q(vlan=5) / ip / UDP(sport=50000 + i, dport=port) / Raw(body),
            ),
            strict=True,
        ):
            run.append(bytes(pkt))
    return [f for run in frames for f in run]


def test_scapy_built_vlan_and_udp_frames_agree_with_tshark(tshark: str, tmp_path: Path) -> None:
    frames = _scapy_frames()
    path = tmp_path / "encap.pcap"
    write_pcap(path, [(i * 1_000_000, f) for i, f in enumerate(frames)])
    assert tshark_util.problems(tshark, path, *CHECKSUMS) == []
    protocols = tshark_util.run(tshark, path, "-T", "fields", "-e", "frame.protocols").split()
    for raw, stack in zip(frames, protocols, strict=True):
        frame = decode_frame(raw)
        assert frame.to_bytes() == raw
        assert protocol_of(frame) == ("epl" if ":epl" in stack else "ecat"), stack
    assert assert_fields_agree(tshark, path, {**ALL_FIELDS, **UDP_FIELDS}, *CHECKSUMS) == len(
        frames
    )
    report = check_capture(read_capture(path))
    assert report.at_least(Severity.WARNING) == []
    assert report.counts["other"] == 0


def test_checksum_findings_match_tshark_verdicts(tshark: str, tmp_path: Path) -> None:
    frames = _scapy_frames()
    good = frames[len(frames) // 2]  # the first frame over UDP/IPv4
    bad_ip = bytearray(good)
    bad_ip[24] ^= 0x01  # IPv4 header checksum (offset 14 + 10)
    bad_udp = bytearray(good)
    bad_udp[40] ^= 0x01  # UDP checksum (14 + 20 + 6)
    path = tmp_path / "checksums.pcap"
    write_pcap(path, [(0, good), (1000, bytes(bad_ip)), (2000, bytes(bad_udp))])
    rows = tshark_util.fields(
        tshark, path, ["ip.checksum.status", "udp.checksum.status"], "", *CHECKSUMS
    )
    # tshark's checksum status: 0 bad, 1 good
    assert [(r["ip.checksum.status"], r["udp.checksum.status"]) for r in rows] == [
        (["1"], ["1"]),
        (["0"], ["1"]),
        (["1"], ["0"]),
    ]
    codes = []
    for raw in (good, bytes(bad_ip), bytes(bad_udp)):
        frame = decode_frame(raw)
        assert frame.to_bytes() == raw
        codes.append([f.code for f in frame.findings if f.severity == Severity.ERROR])
    assert codes == [[], ["ipv4.checksum"], ["udp.checksum"]]


def test_network_variable_and_mailbox_frames_agree_with_tshark(tshark: str, tmp_path: Path) -> None:
    nv = ethercat.NvPublication(
        bytes.fromhex("00005e005301"),
        (
            ethercat.NetworkVariable(1, bytes(range(8)), hash=0xBEEF, quality=3),
            ethercat.NetworkVariable(0x0102, b"\x01\x02", hash=7),
        ),
        cycle_index=42,
    )
    frames = [
        ethercat.EcatFrame((), ethercat.FrameType.NV, content=nv),
        ethercat.EcatFrame((), ethercat.FrameType.NV, content=ethercat.NvPublication(bytes(6))),
        ethercat.EcatFrame(
            (),
            ethercat.FrameType.MAILBOX,
            content=ethercat.Mailbox(0x1001, 3, bytes.fromhex("00204000100000000000"), counter=2),
        ),
        ethercat.EcatFrame((), ethercat.FrameType.MAILBOX, content=ethercat.Mailbox(0, 15, b"")),
    ]
    path = tmp_path / "types.pcap"
    write_pcap(path, [(i * 10_000, ethercat.frame(f).to_bytes()) for i, f in enumerate(frames)])
    stacks = tshark_util.run(tshark, path, "-T", "fields", "-e", "frame.protocols").split()
    assert [s.split(":")[3] for s in stacks] == ["tc_nv", "tc_nv", "ecat_mailbox", "ecat_mailbox"]
    assert tshark_util.problems(tshark, path) == []
    assert assert_fields_agree(tshark, path, {**CONTENT_FIELDS, **ALL_FIELDS}) == len(frames)
    report = check_capture(read_capture(path))
    assert report.errors == report.warnings == 0


def test_m_bit_chains_show_the_datagrams_tshark_shows(tshark: str, tmp_path: Path) -> None:
    from skinframes.ethercat import Command, Datagram

    def body(*words: int, length: int, tail: bytes = b"") -> bytes:
        parts = [(length | 0x1000).to_bytes(2, "little")]
        for i, w in enumerate(words):
            d = Datagram(Command.FPRD, 0x1001 + i, 0x130, bytes(4), idx=i + 1)
            raw = d.to_bytes()
            parts.append(raw[:6] + w.to_bytes(2, "little") + raw[8:])
        return b"".join(parts) + tail

    bodies = [
        body(0x8004, 4, length=32),
        body(4, 4, length=32),
        body(0x8004, 0x8004, length=32, tail=bytes(20)),
        body(0x8004, 0x8004, length=32, tail=bytes(12) + body(4, length=16)[2:]),
        body(0x8004, 4, length=16),
        body(0x8004, 4, length=48, tail=bytes(20)),
    ]
    head = ethercat.BROADCAST_MAC + ethercat.MASTER_MAC + b"\x88\xa4"
    frames = [(head + b).ljust(60, b"\x00") for b in bodies]
    path = tmp_path / "chains.pcap"
    write_pcap(path, [(i * 1000, f) for i, f in enumerate(frames)])
    assert assert_fields_agree(tshark, path, ALL_FIELDS) == len(frames)
    for raw in frames:
        assert decode_frame(raw).to_bytes() == raw


# tshark 4.0 over UDP shows no epl.src/epl.dest: the node ids appear in the Info column only,
# taken from the IPv4 addresses' last octets ("  4-> 32  ASnd ...").
INFO_NODES = re.compile(r"^\s*(\d+)->\s*(\d+)\s+ASnd\b")
ASND_FIELDS = [
    "epl.mtyp",
    "epl.src",
    "epl.dest",
    "epl.asnd.svid",
    "epl.asnd.ires.state",
    "epl.asnd.ires.vendorid",
    "epl.asnd.sres.stat",
    "epl.asnd.nmtrequest.rcid",
    "epl.asnd.nmtrequest.rct",
    "epl.asnd.nmtcommand.cid",
    "epl.asnd.sdo.cmd.transaction.id",
    "epl.asnd.sdo.cmd.command.id",
    "_ws.col.Info",
]


def _epl_udp_frames() -> list[bytes]:
    """The golden ASnd frames over UDP (DS 301 5.1.2: node n is 192.168.100.n), bytes 1-2
    zeroed (reserved there); then one ASnd with its Ethernet node ids still in bytes 1-2 and
    other IP addresses, and one from an ephemeral port, as a PC's SDO client sends."""
    from scapy.layers.inet import IP, UDP
    from scapy.layers.l2 import Ether
    from scapy.packet import Raw

    out = []
    asnds = [raw for _, raw in golden.build("epl_asnd_services") if raw[14] == 6]
    for raw in asnds:
        dest, src = raw[15], raw[16]
        body = raw[14:15] + b"\x00\x00" + raw[17:]  # with Ethernet padding, as tshark wants
        ip = IP(src=f"192.168.100.{src}", dst=f"192.168.100.{dest}")
        out.append(bytes(Ether() / ip / UDP(sport=3819, dport=3819) / Raw(body)))
    ip = IP(src="192.168.100.4", dst="192.168.100.32")
    out.append(bytes(Ether() / ip / UDP(sport=3819, dport=3819) / Raw(asnds[1][14:])))
    ip = IP(src="192.168.100.240", dst="192.168.100.7")
    body = asnds[-1][14:15] + b"\x00\x00" + asnds[-1][17:]
    out.append(bytes(Ether() / ip / UDP(sport=50123, dport=3819) / Raw(body)))
    return out


def test_epl_over_udp_nodes_and_services_agree_with_tshark(
    tshark: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from skinframes_cli import main

    frames = _epl_udp_frames()
    path = tmp_path / "epl_udp.pcap"
    write_pcap(path, [(i * 1_000_000, f) for i, f in enumerate(frames)])
    assert tshark_util.problems(tshark, path, *CHECKSUMS) == []
    rows = tshark_util.fields(tshark, path, ASND_FIELDS, "", *CHECKSUMS)
    assert len(rows) == len(frames) == 8

    assert main(["decode", "--json", str(path)]) == 0
    objs = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert main(["decode", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    for row, obj, line in zip(rows, objs, lines, strict=True):
        assert row["epl.src"] == row["epl.dest"] == []  # not shown over UDP
        info_nodes = INFO_NODES.match(row["_ws.col.Info"][0])
        assert info_nodes is not None, row["_ws.col.Info"]
        src, dest = int(info_nodes[1]), int(info_nodes[2])
        assert (obj["src"], obj["dest"]) == (src, dest), (obj, row)
        assert re.search(rf"EPL\s+{src}->\s*{dest} ASND", line), line
        assert obj["message_type"] == int(row["epl.mtyp"][0])
        assert obj["service_id"] == int(row["epl.asnd.svid"][0], 0)
    # the service payloads at their offsets: tshark's value of each field equals ours
    payload = {
        "epl.asnd.ires.state": ("IDENT_RESPONSE", "nmt_status"),
        "epl.asnd.sres.stat": ("STATUS_RESPONSE", "nmt_status"),
        "epl.asnd.nmtcommand.cid": ("NMT_COMMAND", "command_id"),
        "epl.asnd.sdo.cmd.command.id": ("SDO", "sdo_command_id"),
    }
    for field, (service, key) in payload.items():
        theirs = [int(r[field][0], 0) for r in rows if r[field]]
        ours = [o[key] for o in objs if o["service"] == service]
        assert ours == theirs and theirs, field
    for frame, row in zip(frames, rows, strict=True):  # fields decode --json does not show
        m = encap.message_of(decode_frame(frame))
        assert isinstance(m, powerlink.ASnd)
        s = m.service
        if isinstance(s, powerlink.IdentResponse):
            assert s.vendor_id == int(row["epl.asnd.ires.vendorid"][0], 0)
        if isinstance(s, powerlink.NmtRequest):
            assert s.requested_command_id == int(row["epl.asnd.nmtrequest.rcid"][0], 0)
            assert s.requested_command_target == int(row["epl.asnd.nmtrequest.rct"][0], 0)
    assert assert_fields_agree(tshark, path, {**ALL_FIELDS, **UDP_FIELDS}, *CHECKSUMS) == 8

    # check: tshark has no expert item here, so no error and no warning either
    report = check_capture(read_capture(path))
    assert report.at_least(Severity.WARNING) == []
    codes = {f.finding.code for f in report.findings}
    assert codes <= {"udp.extra", "epl.udp.reserved", "eth.unpadded"}, codes
    reserved = [f.frame for f in report.findings if f.finding.code == "epl.udp.reserved"]
    assert reserved == [7]  # the one that kept its Ethernet node ids in bytes 1-2
