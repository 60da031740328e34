"""Captures rewritten into other encapsulations, by hand or with scapy (never by the code under
test): the same messages behind VLAN tags or over IPv4/UDP."""

from __future__ import annotations

from pathlib import Path

from skinframes.capture_writer import pcap_bytes
from skinframes.pcap import read_capture


def qinq(path: Path, out: Path) -> Path:
    """``path``'s frames behind two hand-typed tags (IEEE 802.1Q-2018 6.9): an S-tag (TPID
    88a8, VID 100) and a C-tag (TPID 8100, PCP 3, VID 7), after the source MAC."""
    tags = bytes.fromhex("88a8 0064 8100 6007".replace(" ", ""))
    frames = [(r.time_ns, r.data[:12] + tags + r.data[12:]) for r in read_capture(path)]
    out.write_bytes(pcap_bytes(frames))
    return out


def over_udp(path: Path, out: Path, port: int) -> Path:
    """``path``'s Ethernet frames with their payload carried over IPv4/UDP (scapy builds the
    headers), the MACs kept; EPL (port 3819): node n is 192.168.100.n, the message's bytes 1-2
    (dest, src) reserved, zero (DS 301 5.1.2)."""
    from scapy.layers.inet import IP, UDP
    from scapy.layers.l2 import Ether
    from scapy.packet import Raw

    frames = []
    for r in read_capture(path):
        eth = Ether(dst=r.data[:6], src=r.data[6:12])
        body = r.data[14:]
        ip = IP()
        if port == 3819:
            ip = IP(src=f"192.168.100.{body[2]}", dst=f"192.168.100.{body[1]}")
            body = body[:1] + b"\0\0" + body[3:]
        frames.append((r.time_ns, bytes(eth / ip / UDP(sport=port, dport=port) / Raw(body))))
    out.write_bytes(pcap_bytes(frames))
    return out
