"""Conformance vectors for other implementations: one pcap and one JSON Lines file.

Every EPL message type and ASnd service, every EtherCAT command and frame type (1, 4, 5 and a
reserved one), the VLAN (802.1Q, 802.1ad) and UDP/IPv4 forms, size edges of the EPL PDO (0, 1,
36, 37, 45, 46, 1486..1490 bytes) and of the EtherCAT datagram (0, 1, 1486 bytes), and the
malformed cases ``skinframes check`` knows. Line N of ``vectors.jsonl`` describes frame N of
``vectors.pcap`` (Wireshark's 1-based number): ``{"frame", "name", "length", "protocol",
"fields": {wireshark field: [values]}, "findings": [{"severity", "code"}]}``. The field names
are Wireshark's display-filter names, each with all its occurrences in the frame as integers, so
that a C or Rust test suite can compare its own decoder (or tshark's ``-T fields -E
occurrence=a`` output) without Python. ``findings`` are what ``check`` reports for the frame.
"""

from __future__ import annotations

import ipaddress
import json
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

from skinframes import encap, ethercat, ethernet, golden, ipv4udp, powerlink
from skinframes.atomic_file import atomic_output
from skinframes.check import check_capture
from skinframes.dispatch import decode_frame, protocol_of
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.pcap import parse_capture, pcap_bytes
from skinframes.vlan import TPID_STAG, VlanTag

__all__ = ["JSONL_NAME", "PCAP_NAME", "build", "expected_fields", "write"]

PCAP_NAME: Final = "vectors.pcap"
JSONL_NAME: Final = "vectors.jsonl"
PDO_SIZES: Final = (0, 1, 36, 37, 45, 46, 1486, 1487, 1488, 1489, 1490)
DATAGRAM_SIZES: Final = (0, 1, ethercat.MAX_DATAGRAM_DATA_BYTES)
_IP_A: Final = ipaddress.IPv4Address("192.168.100.1")
_IP_B: Final = ipaddress.IPv4Address("192.168.100.240")


def _epl_message(frame: ethernet.EthernetFrame) -> Any:
    m = encap.message_of(frame)
    return m if protocol_of(frame) == "epl" else None


def _ecat(frame: ethernet.EthernetFrame) -> EcatFrame | None:
    m = encap.message_of(frame)
    return m if isinstance(m, EcatFrame) else None


def expected_fields(frame: ethernet.EthernetFrame) -> dict[str, list[int]]:
    """The frame's fields under Wireshark's names (only those present), every occurrence."""
    out: dict[str, list[int]] = {"eth.type": [int(frame.ethertype or 0)]}
    stag = [t for t in frame.tags if getattr(t, "tpid", 0) == TPID_STAG]
    ctag = [t for t in frame.tags if getattr(t, "tpid", 0) != TPID_STAG]
    if ctag:
        out["vlan.id"] = [getattr(t, "vid", 0) for t in ctag]
    if stag:
        out["ieee8021ad.id"] = [getattr(t, "vid", 0) for t in stag]
    if frame.tags:  # Wireshark's eth.type is the first TPID
        out["eth.type"] = [getattr(frame.tags[0], "tpid", 0)]
    p = frame.payload
    if isinstance(p, ipv4udp.Ipv4Udp):
        out["udp.srcport"], out["udp.dstport"] = [p.sport], [p.dport]
    m = _epl_message(frame)
    if m is not None:
        out["epl.mtyp"] = [m.message_type & 0x7F if hasattr(m, "message_type") else m.MESSAGE_TYPE]
        if not isinstance(p, ipv4udp.Ipv4Udp):  # Wireshark shows no src/dest over UDP
            out["epl.src"], out["epl.dest"] = [m.src], [m.dest]
        if isinstance(m, powerlink.PReq):
            out["epl.preq.size"] = [m.size]
        if isinstance(m, powerlink.PRes):
            out["epl.pres.size"] = [m.size]
        if isinstance(m, powerlink.SoA):
            out["epl.soa.svid"] = [int(m.requested_service)]
        if isinstance(m, powerlink.ASnd):
            out["epl.asnd.svid"] = [m.service_id]
    e = _ecat(frame)
    if e is not None:
        out["ecatf.type"], out["ecatf.length"] = [e.frame_type], [e.length_field]
        if e.datagrams:
            out["ecat.cmd"] = [int(d.cmd) for d in e.datagrams]
            out["ecat.idx"] = [d.idx for d in e.datagrams]
            out["ecat.subframe.length"] = [d.length for d in e.datagrams]
            out["ecat.cnt"] = [d.wkc for d in e.datagrams]
        if isinstance(e.content, ethercat.NvPublication):
            out["tc_nv.count"] = [len(e.content.variables)]
            out["tc_nv.id"] = [v.id for v in e.content.variables]
        if isinstance(e.content, ethercat.Mailbox):
            out["ecat_mailbox.type"] = [e.content.mailbox_type]
            out["ecat_mailbox.length"] = [len(e.content.data)]
    return out


def _epl_cases() -> list[tuple[str, bytes]]:
    cases: list[tuple[str, bytes]] = []
    for _, raw in golden.build("epl_cycle_4cn")[:3] + golden.build("epl_asnd_services"):
        m = decode_frame(raw).payload
        name = type(m).__name__
        if isinstance(m, powerlink.ASnd):
            name += "." + type(m.service).__name__
        cases.append((f"epl.{name}", raw))
    sync = powerlink.ASnd(powerlink.SyncResponse(), src=1)
    cases.append(("epl.SoA", powerlink.frame(powerlink.SoA()).to_bytes()))
    cases.append(("epl.ASnd.SyncResponse", powerlink.frame(sync).to_bytes()))
    for mtype in (powerlink.MessageType.AMNI, powerlink.MessageType.AINV):
        raw_msg = powerlink.RawMessage(int(mtype), 255, 240, bytes(3))
        cases.append((f"epl.{mtype.name}", powerlink.frame(raw_msg).to_bytes()))
    # the PDO size edges inside one isochronous phase: SoC, (PReq, PRes) per size, SoA
    payload = bytes(range(256)) * 6
    cases.append(("epl.SoC", powerlink.frame(powerlink.SoC()).to_bytes()))
    for size in PDO_SIZES:
        cases.append(("epl.PReq", powerlink.frame(powerlink.PReq(1)).to_bytes()))
        pres = powerlink.PRes(1, payload[:size])
        cases.append((f"epl.PRes.size_{size}", powerlink.frame(pres).to_bytes()))
    cases.append(("epl.SoA", powerlink.frame(powerlink.SoA()).to_bytes()))
    return cases


def _ecat_cases() -> list[tuple[str, bytes]]:
    cases = [
        (f"ecat.{Command(r[1][ethernet.HEADER_BYTES + 2]).name}", r[1])
        for r in golden.build("ecat_all_commands")
    ]
    for size in DATAGRAM_SIZES:
        d = Datagram.logical(Command.LRD, 0x10000, bytes(size), wkc=1)
        cases.append((f"ecat.LRD.data_{size}", ethercat.frame(EcatFrame((d,))).to_bytes()))
    nv = ethercat.NvPublication(
        ethercat.MASTER_MAC, (ethercat.NetworkVariable(1, bytes(8), hash=0x1234),), cycle_index=1
    )
    mbx = ethercat.Mailbox(0x1001, 3, bytes.fromhex("00204000100000000000"))
    for name, content in (("type4_nv", nv), ("type5_mailbox", mbx)):
        ftype = ethercat.FrameType.NV if name == "type4_nv" else ethercat.FrameType.MAILBOX
        body = EcatFrame((), ftype, content=content)
        cases.append((f"ecat.{name}", ethercat.frame(body).to_bytes()))
    return cases


def _encapsulated(cases: list[tuple[str, bytes]]) -> list[tuple[str, bytes]]:
    """Each first EPL and EtherCAT case again, 802.1Q-tagged, 802.1ad-stacked and over UDP."""
    out: list[tuple[str, bytes]] = []
    for form in ("vlan", "qinq", "udp"):
        for name, raw in cases:
            f = decode_frame(raw)
            message = f.payload
            assert isinstance(message, EcatFrame | powerlink.SoA | powerlink.ASnd)
            port = ipv4udp.UDP_PORT_EPL if protocol_of(f) == "epl" else ipv4udp.UDP_PORT_ECAT
            if form == "udp":
                packet = ipv4udp.Ipv4Udp(_IP_A, _IP_B, port, port, message)
                framed = ethernet.EthernetFrame(f.dst, f.src, packet)
            else:
                tags: tuple[VlanTag, ...] = (VlanTag(5, pcp=3),)
                if form == "qinq":
                    tags = (VlanTag(100, tpid=TPID_STAG), VlanTag(5))
                framed = ethernet.EthernetFrame(f.dst, f.src, message, tags=tags)
            out.append((f"{name}.{form}", framed.to_bytes()))
    return out


def _patch(raw: bytes, at: int, value: bytes) -> bytes:
    return raw[:at] + value + raw[at + len(value) :]


def _malformed() -> list[tuple[str, bytes]]:
    """Frames with one deviation each, named after the finding ``check`` reports."""
    pres = powerlink.frame(powerlink.PRes(1, bytes(8))).to_bytes()
    soa = powerlink.frame(powerlink.SoA()).to_bytes()
    lrd = ethercat.frame(EcatFrame((Datagram.logical(Command.LRD, 0, bytes(4)),))).to_bytes()
    two = ethercat.frame(
        EcatFrame((Datagram(Command.FPRD, 0x1001, 0x130, bytes(2)), Datagram(Command.BRD, 0, 0)))
    ).to_bytes()
    udp = ethernet.EthernetFrame(
        ethercat.BROADCAST_MAC,
        ethercat.MASTER_MAC,
        ipv4udp.Ipv4Udp(_IP_A, _IP_B, 0x88A4, 0x88A4, EcatFrame((Datagram(Command.BRD, 0, 0),))),
    ).to_bytes()
    short_sres = powerlink.ASnd(powerlink.StatusResponse(short=True), src=1)
    word = struct.unpack_from("<H", two, 14 + 2 + 14 + 6)[0]
    header = struct.unpack_from("<H", lrd, 14)[0]
    reserved = struct.pack("<H", header & 0x0FFF | 6 << 12)  # type 6: reserved
    return [
        ("bad.epl.undecodable", _patch(pres, 14 + 8, struct.pack("<H", 192))),
        ("bad.eth.padding.nonzero", _patch(soa, len(soa) - 1, b"\x01")),
        ("bad.ecat.header.length", _patch(lrd, 14, struct.pack("<H", 0x1000 | 40))),
        ("bad.ecat.more.last", _patch(two, 14 + 2 + 14 + 6, struct.pack("<H", word | 0x8000))),
        ("bad.ecat.type.reserved", _patch(lrd, 14, reserved)),
        ("bad.epl.sres.short", powerlink.frame(short_sres).to_bytes()),
        ("bad.ipv4.checksum", _patch(udp, 24, bytes([udp[24] ^ 1]))),
        ("bad.udp.checksum", _patch(udp, 40, bytes([udp[40] ^ 1]))),
        ("bad.eth.unpadded", powerlink.frame(powerlink.SoA()).to_bytes()[:30]),
    ]


def build() -> list[tuple[str, int, bytes]]:
    """The vector set: (name, time_ns, frame bytes) in file order."""
    epl, ecat = _epl_cases(), _ecat_cases()
    encapsulated = _encapsulated([epl[3], epl[4], ecat[10], ecat[-1]])  # SoA, IdentResponse, ...
    cases = epl + ecat + encapsulated + _malformed()
    stamped = golden.stamp([raw for _, raw in cases])
    return [(name, t, raw) for (name, raw), (t, _) in zip(cases, stamped, strict=True)]


def lines(vectors: list[tuple[str, int, bytes]]) -> list[dict[str, Any]]:
    """One JSON object per frame: the expected fields and the findings of ``check``."""
    report = check_capture(parse_capture(pcap_bytes([(t, raw) for _, t, raw in vectors])))
    found: dict[int, list[dict[str, str]]] = {}
    for f in report.findings:
        found.setdefault(f.index, []).append(
            {"severity": str(f.finding.severity), "code": f.finding.code}
        )
    out = []
    for i, (name, _, raw) in enumerate(vectors):
        frame = decode_frame(raw)
        out.append(
            {
                "frame": i + 1,
                "name": name,
                "length": len(raw),
                "protocol": protocol_of(frame),
                "fields": expected_fields(frame),
                "findings": found.get(i, []),
            }
        )
    return out


def write(out_dir: str | Path, *, progress: Callable[[str], None] | None = None) -> list[Path]:
    """Write ``vectors.pcap`` and ``vectors.jsonl`` into ``out_dir`` (which must exist), as a
    set: where either cannot be written (a symbolic link, say), neither is."""
    vectors = build()
    folder = Path(out_dir)
    pcap_path, jsonl_path = folder / PCAP_NAME, folder / JSONL_NAME
    with atomic_output(pcap_path, "wb") as f, atomic_output(jsonl_path, "w") as g:
        f.write(pcap_bytes([(t, raw) for _, t, raw in vectors]))
        for obj in lines(vectors):
            g.write(json.dumps(obj, sort_keys=True) + "\n")
    if progress is not None:
        progress(f"{len(vectors)} frames")
    return [pcap_path, jsonl_path]
