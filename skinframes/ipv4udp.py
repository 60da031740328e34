"""EPL and EtherCAT over UDP/IPv4: the IPv4 header (RFC 791 3.1), the UDP header (RFC 768), their
checksums, and the message inside.

* EPL over UDP: port 3819 (EPSG DS 301 5.1.4 "EPL over UDP/IP"; Wireshark ``packet-epl.c``,
  ``UDP_PORT_EPL``). The UDP payload's first byte is the EPL MessageType, bytes 1-2 are reserved
  (where Ethernet has Destination and Source), an ASnd's ServiceID is byte 3. The node ids are
  the IPv4 addresses' last octets (DS 301 5.1.2: 192.168.100.<NodeID>), as Wireshark shows them
  (``dissect_epludp``): :attr:`Ipv4Udp.src_node`, :attr:`Ipv4Udp.dest_node`. The reserved bytes
  are kept (as the message's ``dest``/``src``, for byte-exactness) and noted when not zero.
* EtherCAT over UDP: port 0x88A4 = 34980 (ETG.1000.4 5.3.2; Wireshark ``packet-ethercat-frame.c``
  registers ``udp.port`` 0x88A4): the UDP payload is an EtherCAT frame (2-byte header and
  datagrams) as it follows the EtherType 0x88A4.

As Wireshark's UDP dissector does, the lower of the two ports is tried first. IPv4 fragments and
other IP traffic are not decoded here (they stay ``other``).
"""

from __future__ import annotations

import ipaddress
import struct
from dataclasses import dataclass
from typing import ClassVar, Final

import construct as cs

from skinframes import ethercat, powerlink
from skinframes.errors import (
    ChecksumError,
    FieldRangeError,
    FrameTooLargeError,
    LengthMismatchError,
    TruncatedError,
)
from skinframes.findings import Finding, error, info

__all__ = [
    "EPL_IP_NETWORK",
    "ETHERTYPE_IPV4",
    "IPV4_HEADER_BYTES",
    "PROTO_UDP",
    "UDP_HEADER_BYTES",
    "UDP_PORT_ECAT",
    "UDP_PORT_EPL",
    "Ipv4Udp",
    "decode",
    "epl_node_id",
    "inner_protocol",
    "internet_checksum",
    "ipv4_header_schema",
    "udp_header_schema",
]

ETHERTYPE_IPV4: Final = 0x0800  # IEEE registry
IPV4_HEADER_BYTES: Final = 20  # without options, RFC 791 3.1 (IHL 5)
UDP_HEADER_BYTES: Final = 8  # RFC 768
PROTO_UDP: Final = 17  # IANA protocol numbers
UDP_PORT_EPL: Final = 3819  # EPSG DS 301 5.1.4; Wireshark UDP_PORT_EPL
UDP_PORT_ECAT: Final = 0x88A4  # ETG.1000.4 5.3.2; Wireshark packet-ethercat-frame.c
EPL_IP_NETWORK: Final = ipaddress.IPv4Network("192.168.100.0/24")  # DS 301 5.1.2
DEFAULT_TTL: Final = 64  # RFC 1700 / RFC 1122 3.2.1.7 recommended default
_MORE_FRAGMENTS: Final = 0x2000
_FRAGMENT_OFFSET_MASK: Final = 0x1FFF

ipv4_header_schema = cs.Struct(  # RFC 791 3.1, big-endian
    "version_ihl" / cs.BitStruct("version" / cs.BitsInteger(4), "ihl" / cs.BitsInteger(4)),
    "tos" / cs.Int8ub,
    "total_length" / cs.Int16ub,
    "identification" / cs.Int16ub,
    "flags_fragment"
    / cs.BitStruct("flags" / cs.BitsInteger(3), "fragment_offset" / cs.BitsInteger(13)),
    "ttl" / cs.Int8ub,
    "protocol" / cs.Int8ub,
    "checksum" / cs.Int16ub,
    "src" / cs.Bytes(4),
    "dst" / cs.Bytes(4),
    "options" / cs.Bytes((cs.this.version_ihl.ihl - 5) * 4),
)

udp_header_schema = cs.Struct(  # RFC 768
    "sport" / cs.Int16ub,
    "dport" / cs.Int16ub,
    "length" / cs.Int16ub,
    "checksum" / cs.Int16ub,
)

_IP = struct.Struct(">BBHHHBBH4s4s")
_UDP = struct.Struct(">HHHH")

Inner = powerlink.EplMessage | ethercat.EcatFrame | bytes


def internet_checksum(data: bytes) -> int:
    """The 16-bit one's complement of the one's complement sum (RFC 1071), as sent."""
    if len(data) % 2:
        data += b"\x00"
    total = int(sum(struct.unpack(f">{len(data) // 2}H", data)))
    while total >> 16:
        total = (total & 0xFFFF) + (total >> 16)
    return ~total & 0xFFFF


def _udp_checksum(src: bytes, dst: bytes, udp: bytes) -> int:
    """RFC 768: over the pseudo header, the UDP header (checksum 0) and data; 0 is sent as 0xFFFF."""
    pseudo = src + dst + struct.pack(">BBH", 0, PROTO_UDP, len(udp))
    value = internet_checksum(pseudo + udp)
    return value or 0xFFFF


def epl_node_id(address: ipaddress.IPv4Address) -> int:
    """The EPL node id of an IPv4 address: its last octet (DS 301 5.1.2, 192.168.100.<NodeID>;
    Wireshark takes the last octet of any address)."""
    return address.packed[3]


def inner_protocol(sport: int, dport: int) -> str | None:
    """``"epl"``, ``"ecat"`` or None for a UDP port pair, lower port first (as Wireshark)."""
    for port in sorted((sport, dport)):
        if port == UDP_PORT_EPL:
            return "epl"
        if port == UDP_PORT_ECAT:
            return "ecat"
    return None


@dataclass(frozen=True, slots=True)
class Ipv4Udp:
    """An IPv4 packet carrying a UDP datagram with an EPL or EtherCAT message.

    Fields left None are computed when encoding (lengths, checksums); a decoder sets them only
    when the captured value differs (kept for byte-exactness, reported as a finding).
    ``udp_checksum`` 0 means "no checksum" (RFC 768), which is legal over IPv4.

    Attributes:
        src_ip, dst_ip: the addresses.
        sport, dport: UDP ports (3819 EPL, 0x88A4 EtherCAT).
        payload: the EPL message or EtherCAT frame (raw bytes if built so). An EPL message's
            ``dest`` and ``src`` travel as the reserved bytes 1-2 (DS 301): 0 in a conformant
            frame; the node ids are the IP addresses' (:attr:`src_node`, :attr:`dest_node`).
        extra: bytes inside the UDP datagram after the message.
        options: IPv4 options (a multiple of 4 bytes).
    """

    ETHERTYPE: ClassVar[int] = ETHERTYPE_IPV4
    src_ip: ipaddress.IPv4Address
    dst_ip: ipaddress.IPv4Address
    sport: int
    dport: int
    payload: Inner
    tos: int = 0
    identification: int = 0
    flags: int = 0
    ttl: int = DEFAULT_TTL
    options: bytes = b""
    extra: bytes = b""
    total_length: int | None = None
    ip_checksum: int | None = None
    udp_length: int | None = None
    udp_checksum: int | None = None

    @property
    def protocol(self) -> str | None:
        """``"epl"`` or ``"ecat"`` by the ports."""
        return inner_protocol(self.sport, self.dport)

    @property
    def src_node(self) -> int:
        """EPL: the source node id, the last octet of ``src_ip`` (DS 301 5.1.2)."""
        return epl_node_id(self.src_ip)

    @property
    def dest_node(self) -> int:
        """EPL: the destination node id, the last octet of ``dst_ip`` (DS 301 5.1.2)."""
        return epl_node_id(self.dst_ip)

    @property
    def message_bytes(self) -> bytes:
        """The UDP payload: message plus ``extra``."""
        p = self.payload
        body = bytes(p) if isinstance(p, bytes | bytearray) else p.to_bytes()
        return body + self.extra

    def to_bytes(self) -> bytes:
        """The IPv4 packet (header, UDP header, payload), as it follows the EtherType."""
        data = self.message_bytes
        if len(self.options) % 4 or len(self.options) > 40:
            raise FieldRangeError("IPv4: options must be 0..40 bytes, a multiple of 4")
        udp_len = UDP_HEADER_BYTES + len(data) if self.udp_length is None else self.udp_length
        ihl = 5 + len(self.options) // 4
        total = ihl * 4 + UDP_HEADER_BYTES + len(data)
        total_field = total if self.total_length is None else self.total_length
        src, dst = self.src_ip.packed, self.dst_ip.packed
        try:
            udp = _UDP.pack(self.sport, self.dport, udp_len, 0) + data
            csum = self.udp_checksum
            if csum is None:
                csum = _udp_checksum(src, dst, udp)
            udp = udp[:6] + struct.pack(">H", csum) + udp[8:]
            flags = (self.flags << 13) & 0xFFFF
            if not 0 <= self.flags <= 7:
                raise FieldRangeError("IPv4: flags are 3 bits", field="flags")
            head = _IP.pack(
                0x40 | ihl,
                self.tos,
                total_field,
                self.identification,
                flags,
                self.ttl,
                PROTO_UDP,
                0,
                src,
                dst,
            )
        except struct.error as exc:
            raise FieldRangeError(f"IPv4/UDP: {exc}") from exc
        head += self.options
        ip_csum = internet_checksum(head) if self.ip_checksum is None else self.ip_checksum
        head = head[:10] + struct.pack(">H", ip_csum) + head[12:]
        if total > 0xFFFF:
            raise FrameTooLargeError(f"IPv4: {total} bytes exceed 65535")
        return head + udp


def claims(payload: bytes) -> str | None:
    """``"epl"`` or ``"ecat"`` when ``payload`` (after EtherType 0x0800) is an unfragmented
    IPv4/UDP packet to or from the EPL or EtherCAT port, else None (not ours: stays ``other``)."""
    if len(payload) < IPV4_HEADER_BYTES + UDP_HEADER_BYTES or payload[0] >> 4 != 4:
        return None
    ihl = payload[0] & 0x0F
    if ihl < 5 or payload[9] != PROTO_UDP or len(payload) < ihl * 4 + UDP_HEADER_BYTES:
        return None
    (frag,) = struct.unpack_from(">H", payload, 6)
    if frag & (_MORE_FRAGMENTS | _FRAGMENT_OFFSET_MASK):
        return None
    sport, dport = struct.unpack_from(">HH", payload, ihl * 4)
    return inner_protocol(sport, dport)


def decode(payload: bytes, *, strict: bool = True) -> tuple[Ipv4Udp, int, list[Finding]]:
    """Decode an IPv4/UDP packet with an EPL or EtherCAT message (the bytes after EtherType).

    Returns:
        The packet, the bytes it occupies (IPv4 total length; the rest is Ethernet padding),
        and findings: ``ipv4.checksum``, ``udp.checksum`` (errors: a receiver drops the packet),
        ``ipv4.length``, ``udp.length``, ``udp.extra``; EPL (info, Wireshark says nothing; not
        raised when strict): ``epl.udp.reserved``, ``epl.udp.message_type``, ``epl.udp.address``.

    Raises:
        DecodeError: not an IPv4/UDP packet on the EPL or EtherCAT port, truncated, an
            undecodable message, or (strict) a wrong checksum or length.
    """
    buf = bytes(payload)
    proto = claims(buf)
    if proto is None:
        raise LengthMismatchError("IPv4: not an unfragmented UDP packet on port 3819 or 0x88A4")
    findings: list[Finding] = []
    vihl, tos, total, ident, frag, ttl, _, ip_csum, src, dst = _IP.unpack_from(buf)
    hlen = (vihl & 0x0F) * 4
    if total > len(buf) or total < hlen + UDP_HEADER_BYTES:
        raise TruncatedError(
            f"IPv4: total length {total}, {len(buf)} bytes present, header {hlen} + UDP 8",
            field="total_length",
            offset=2,
        )
    head = buf[:hlen]
    options = buf[IPV4_HEADER_BYTES:hlen]
    computed = internet_checksum(head[:10] + b"\x00\x00" + head[12:])
    keep_ip_csum: int | None = None
    if computed != ip_csum:
        msg = f"IPv4: header checksum {ip_csum:#06x}, computed {computed:#06x}"
        if strict:
            raise ChecksumError(msg, field="checksum", offset=10)
        findings.append(error("ipv4.checksum", msg))
        keep_ip_csum = ip_csum
    sport, dport, udp_len, udp_csum = _UDP.unpack_from(buf, hlen)
    ip_udp = total - hlen
    keep_udp_len: int | None = None
    end = total
    if udp_len != ip_udp:
        msg = f"UDP: length {udp_len}, the IPv4 packet leaves {ip_udp}"
        if strict or udp_len < UDP_HEADER_BYTES or udp_len > ip_udp:
            raise LengthMismatchError(msg, field="udp.length", offset=hlen + 4)
        findings.append(error("udp.length", msg))
        keep_udp_len, end = udp_len, hlen + udp_len
    data = buf[hlen + UDP_HEADER_BYTES : end]
    keep_udp_csum: int | None = None
    if udp_csum == 0:
        keep_udp_csum = 0  # no checksum: legal over IPv4 (RFC 768)
    else:
        udp = buf[hlen : hlen + 6] + b"\x00\x00" + buf[hlen + 8 : end]
        want = _udp_checksum(src, dst, udp)
        if want != udp_csum:
            msg = f"UDP: checksum {udp_csum:#06x}, computed {want:#06x}"
            if strict:
                raise ChecksumError(msg, field="udp.checksum", offset=hlen + 6)
            findings.append(error("udp.checksum", msg))
            keep_udp_csum = udp_csum
    message: powerlink.EplMessage | ethercat.EcatFrame
    if proto == "epl":
        message, used, more = powerlink.decode(data, strict=strict)
        more = more + _epl_findings(message, src, dst)
    else:
        message, used, more = ethercat.decode(data, strict=strict)
    findings += more
    extra = data[used:]
    if extra:
        findings.append(
            info("udp.extra", f"UDP: {len(extra)} bytes follow the {used}-byte {proto} message")
        )
    packet = Ipv4Udp(
        ipaddress.IPv4Address(src),
        ipaddress.IPv4Address(dst),
        sport,
        dport,
        message,
        tos=tos,
        identification=ident,
        flags=frag >> 13,
        ttl=ttl,
        options=options,
        extra=extra,
        total_length=None if keep_udp_len is None else total,
        ip_checksum=keep_ip_csum,
        udp_length=keep_udp_len,
        udp_checksum=keep_udp_csum,
    )
    if packet.to_bytes() != buf[:total]:  # e.g. bytes between UDP length and IPv4 length
        raise LengthMismatchError("IPv4/UDP: the packet does not re-encode to its bytes")
    return packet, total, findings


def _epl_findings(message: powerlink.EplMessage, src: bytes, dst: bytes) -> list[Finding]:
    """EPL over UDP, what DS 301 5.1 asks and Wireshark does not check: reserved bytes 1-2 zero,
    only ASnd, addresses in 192.168.100.0/24 (else the node id, the last octet, means nothing)."""
    out: list[Finding] = []
    if message.dest or message.src:
        out.append(
            info(
                "epl.udp.reserved",
                f"EPL/UDP: reserved bytes 1-2 are {message.dest:#04x} {message.src:#04x}, not 0 "
                "(the node ids are the IP addresses'; Wireshark ignores these bytes)",
            )
        )
    mtype = (
        message.message_type & 0x7F  # bit 7 reserved: powerlink.decode reports it
        if isinstance(message, powerlink.RawMessage)
        else message.MESSAGE_TYPE
    )
    if mtype != powerlink.MessageType.ASND:
        try:
            name = powerlink.MessageType(mtype).name
        except ValueError:
            name = f"MessageType {mtype:#04x}"
        out.append(
            info("epl.udp.message_type", f"EPL/UDP: {name}; DS 301 defines only ASnd over UDP/IP")
        )
    for side, raw in (("source", src), ("destination", dst)):
        address = ipaddress.IPv4Address(raw)
        if address not in EPL_IP_NETWORK:
            out.append(
                info(
                    "epl.udp.address",
                    f"EPL/UDP: {side} {address} is outside {EPL_IP_NETWORK}; its node id "
                    f"{raw[3]} (the last octet, as Wireshark shows it) is not an EPL node's",
                )
            )
    return out
