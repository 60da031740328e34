"""IPv4/UDP encapsulation of EPL and EtherCAT: schema of record, checksums (RFC 791, RFC 768),
lengths, what stays ``other``. tshark's view of the same frames: tests/conformance/test_encapsulation.py."""

from __future__ import annotations

import ipaddress
import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from skinframes import decode_frame, ethercat, powerlink, protocol_of
from skinframes.check import check_capture
from skinframes.describe import frame_fields, summary
from skinframes.errors import ChecksumError
from skinframes.ethernet import EthernetFrame
from skinframes.findings import Severity
from skinframes.ipv4udp import (
    UDP_PORT_ECAT,
    UDP_PORT_EPL,
    Ipv4Udp,
    internet_checksum,
    ipv4_header_schema,
    udp_header_schema,
)
from skinframes.pcap import parse_capture, pcap_bytes

A = ipaddress.IPv4Address("192.168.100.1")
B = ipaddress.IPv4Address("192.168.100.240")
MAC1, MAC2 = bytes.fromhex("020000000a01"), bytes.fromhex("020000000af0")
SOA = powerlink.SoA()
LRD = ethercat.EcatFrame((ethercat.Datagram.logical(ethercat.Command.LRD, 0, bytes(8)),))


def test_rfc1071_example() -> None:
    # RFC 1071 section 3: the one's complement sum of 0001 f203 f4f5 f6f7 is ddf2
    assert internet_checksum(bytes.fromhex("0001f203f4f5f6f7")) == 0xFFFF - 0xDDF2


@given(
    st.sampled_from([SOA, LRD]),
    st.integers(0, 0xFFFF),
    st.integers(1, 255),
    st.sampled_from([b"", bytes(4), b"\x01\x01\x01\x00"]),
)
def test_packet_equals_the_schema_and_round_trips(
    message: powerlink.SoA | ethercat.EcatFrame, ident: int, ttl: int, options: bytes
) -> None:
    port = UDP_PORT_EPL if isinstance(message, powerlink.SoA) else UDP_PORT_ECAT
    packet = Ipv4Udp(A, B, 40000, port, message, identification=ident, ttl=ttl, options=options)
    raw = packet.to_bytes()
    ip = ipv4_header_schema.parse(raw)
    assert (ip.version_ihl.version, ip.version_ihl.ihl) == (4, 5 + len(options) // 4)
    assert (ip.total_length, ip.identification, ip.ttl, ip.protocol) == (len(raw), ident, ttl, 17)
    assert (ip.src, ip.dst, ip.options) == (A.packed, B.packed, options)
    hlen = 20 + len(options)
    assert internet_checksum(raw[:hlen]) == 0  # a correct header sums to 0xFFFF
    assert ipv4_header_schema.build(ip) == raw[:hlen]
    udp = udp_header_schema.parse(raw[hlen:])
    assert (udp.sport, udp.dport, udp.length) == (40000, port, len(raw) - hlen)
    pseudo = A.packed + B.packed + struct.pack(">BBH", 0, 17, udp.length)
    assert internet_checksum(pseudo + raw[hlen:]) == 0
    frame = EthernetFrame(MAC1, MAC2, packet)
    back = decode_frame(frame.to_bytes(), strict=True)
    assert back.payload == packet
    assert back.to_bytes() == frame.to_bytes()
    assert protocol_of(back) == ("epl" if port == UDP_PORT_EPL else "ecat")


def test_wrong_checksums_are_findings_and_strict_errors() -> None:
    raw = EthernetFrame(MAC1, MAC2, Ipv4Udp(A, B, 3819, 3819, SOA)).to_bytes()
    for at, code in ((14 + 10, "ipv4.checksum"), (14 + 26, "udp.checksum")):
        bad = bytearray(raw)
        bad[at] ^= 0x40
        with pytest.raises(ChecksumError):
            decode_frame(bytes(bad), strict=True)
        frame = decode_frame(bytes(bad))
        assert [f.code for f in frame.findings if str(f.severity) == "error"] == [code]
        assert frame.to_bytes() == bytes(bad)


def test_no_udp_checksum_is_legal() -> None:
    raw = EthernetFrame(MAC1, MAC2, Ipv4Udp(A, B, 3819, 3819, SOA, udp_checksum=0)).to_bytes()
    frame = decode_frame(raw, strict=True)
    assert frame.to_bytes() == raw
    assert protocol_of(frame) == "epl"


@pytest.mark.parametrize(
    "packet",
    [
        Ipv4Udp(A, B, 53, 53, b"\x00" * 20),  # DNS: not ours
        Ipv4Udp(A, B, 3819, 3819, SOA, flags=1),  # more fragments: not reassembled
    ],
)
def test_other_ip_traffic_stays_other(packet: Ipv4Udp) -> None:
    raw = EthernetFrame(MAC1, MAC2, packet).to_bytes()
    frame = decode_frame(raw)
    assert protocol_of(frame) == "other"
    assert frame.findings == () or all(str(f.severity) == "info" for f in frame.findings)
    assert frame.to_bytes() == raw


def test_lower_port_decides_as_in_wireshark() -> None:
    # sport 3819 < dport 0x88A4: Wireshark's UDP dissector tries the lower port first
    raw = EthernetFrame(MAC1, MAC2, Ipv4Udp(A, B, UDP_PORT_EPL, UDP_PORT_ECAT, SOA)).to_bytes()
    assert protocol_of(decode_frame(raw)) == "epl"


# --- EPL over UDP: node ids from the IPv4 addresses (DS 301 5.1.2: node n is 192.168.100.n) ---
def _epl_udp(src: str, dst: str, message: powerlink.EplMessage) -> bytes:
    packet = Ipv4Udp(ipaddress.IPv4Address(src), ipaddress.IPv4Address(dst), 3819, 3819, message)
    return EthernetFrame(MAC1, MAC2, packet).to_bytes()


def _check(frames: list[bytes]) -> list[tuple[str, str, str]]:
    raw = pcap_bytes([(i * 10_000, f) for i, f in enumerate(frames)])
    report = check_capture(parse_capture(raw, "hand-built"))
    return [(str(f.finding.severity), f.finding.code, f.finding.message) for f in report.findings]


# bytes 1-2 are reserved over UDP: a conformant sender leaves them 0
STATUS = powerlink.ASnd(powerlink.StatusResponse(), dest=0, src=0)


def test_epl_udp_node_ids_are_the_last_octets_of_the_addresses() -> None:
    raw = _epl_udp("192.168.100.4", "192.168.100.240", STATUS)
    frame = decode_frame(raw, strict=True)
    fields = frame_fields(frame)
    assert (fields["src"], fields["dest"], fields["service_id"]) == (4, 240, 2)
    assert "EPL   4->240 ASND (STATUS_RESPONSE)" in summary(frame)
    assert frame.to_bytes() == raw
    assert _check([raw]) == []


def test_epl_udp_reserved_bytes_are_noted_not_errors() -> None:
    # the Ethernet node ids left in bytes 1-2: kept byte-exact, an info finding, strict or not
    message = powerlink.ASnd(powerlink.StatusResponse(), dest=240, src=9)
    raw = _epl_udp("192.168.100.4", "192.168.100.240", message)
    frame = decode_frame(raw, strict=True)
    assert frame.to_bytes() == raw
    assert (frame_fields(frame)["src"], frame_fields(frame)["dest"]) == (4, 240)
    assert [(f.severity, f.code) for f in frame.findings] == [(Severity.INFO, "epl.udp.reserved")]
    assert [c[:2] for c in _check([raw])] == [("info", "epl.udp.reserved")]


def test_epl_udp_reserved_node_ids_are_still_errors() -> None:
    # DS 301 node ids: 0 invalid, 241..252 reserved
    findings = _check([_epl_udp("192.168.100.4", "192.168.100.245", STATUS)])
    assert [c[:2] for c in findings] == [("error", "epl.node_id")]
    assert "destination 245 (192.168.100.245) is reserved" in findings[0][2]


def test_epl_udp_outside_the_epl_network_and_non_asnd_are_info() -> None:
    # 10.1.2.250: not an EPL address, so 250 is no node id to judge (Wireshark shows it anyway)
    routed = _check([_epl_udp("10.1.2.250", "192.168.100.1", STATUS)])
    assert [c[:2] for c in routed] == [("info", "epl.udp.address")]
    soc = _check([_epl_udp("192.168.100.240", "192.168.100.255", powerlink.SoC(dest=0, src=0))])
    assert [c[:2] for c in soc] == [("info", "epl.udp.message_type")]
