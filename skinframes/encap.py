"""Encapsulations around EPL and EtherCAT: VLAN tags (:mod:`skinframes.vlan`) and UDP/IPv4
(:mod:`skinframes.ipv4udp`). The one place that peels them, used by :mod:`skinframes.dispatch`
before its EtherType dispatch, and by whoever wants the EPL or EtherCAT message of a frame.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from skinframes import ethernet, ipv4udp, vlan
from skinframes.findings import Finding

__all__ = ["decoder_for", "encapsulation", "fields", "message_of", "split"]

Decoder = Callable[..., tuple[Any, int, list[Finding]]]


def split(data: bytes) -> tuple[tuple[vlan.VlanTag, ...], int, int]:
    """(VLAN tags, EtherType after them, offset of the payload) of an Ethernet frame."""
    return vlan.peel(data)


def decoder_for(ethertype: int, payload: bytes) -> tuple[Decoder, str] | None:
    """The decoder and protocol name of an encapsulated EPL or EtherCAT message, or None.

    Today: IPv4/UDP on port 3819 (EPL) or 0x88A4 (EtherCAT); other IP traffic is not ours.
    """
    if ethertype != ipv4udp.ETHERTYPE_IPV4:
        return None
    proto = ipv4udp.claims(payload)
    return None if proto is None else (ipv4udp.decode, proto)


def message_of(frame: ethernet.EthernetFrame) -> ethernet.Payload | bytes:
    """The EPL message or EtherCAT frame a frame carries, through UDP/IPv4 (raw bytes if none)."""
    p = frame.payload
    if isinstance(p, ipv4udp.Ipv4Udp):
        return p.payload
    return p


def encapsulation(frame: ethernet.EthernetFrame) -> str:
    """How the message travels: ``"ethernet"``, ``"vlan"``, ``"udp"`` or ``"vlan+udp"``."""
    parts = ["vlan"] if frame.tags else []
    if isinstance(frame.payload, ipv4udp.Ipv4Udp):
        parts.append("udp")
    return "+".join(parts) or "ethernet"


def fields(frame: ethernet.EthernetFrame) -> dict[str, Any]:
    """JSON fields of the encapsulation: ``vlan`` (tags, outermost first) and ``ipv4``/``udp``;
    empty for a plain Ethernet frame. Names follow Wireshark's (``vlan.id``, ``ip.src``, ...)."""
    out: dict[str, Any] = {}
    if frame.tags:
        out["vlan"] = [
            {"tpid": t.tpid, "priority": t.pcp, "dei": int(t.dei), "id": t.vid}
            for t in frame.tags
            if isinstance(t, vlan.VlanTag)
        ]
    p = frame.payload
    if isinstance(p, ipv4udp.Ipv4Udp):
        out["ipv4"] = {"src": str(p.src_ip), "dst": str(p.dst_ip), "ttl": p.ttl}
        out["udp"] = {"srcport": p.sport, "dstport": p.dport}
    return out
