"""Our decoded fields, named as tshark names them (the one mapping table; STYLE 2.2).

Each entry maps a tshark field to a function of our decoded frame that returns every occurrence
of that field in the frame, in order, as ints (tshark prints hex fields as 0x.., parse with int(v, 0)).
"""

from __future__ import annotations

from collections.abc import Callable

from skinframes import encap, ethercat, ipv4udp, powerlink, vlan
from skinframes.ethernet import EthernetFrame

Extract = Callable[[EthernetFrame], list[int]]


def _epl(frame: EthernetFrame) -> powerlink.EplMessage | None:
    p = encap.message_of(frame)
    ok = (powerlink.SoC, powerlink.PReq, powerlink.PRes, powerlink.SoA, powerlink.ASnd)
    return p if isinstance(p, ok) else None


def _on_ethernet(frame: EthernetFrame) -> powerlink.EplMessage | None:
    """The EPL message unless it came over UDP: Wireshark shows no epl.src/epl.dest there."""
    return None if isinstance(frame.payload, ipv4udp.Ipv4Udp) else _epl(frame)


def _ecat(frame: EthernetFrame) -> ethercat.EcatFrame | None:
    p = encap.message_of(frame)
    return p if isinstance(p, ethercat.EcatFrame) else None


def _dgs(frame: EthernetFrame) -> tuple[ethercat.Datagram, ...]:
    p = _ecat(frame)
    return p.datagrams if p is not None else ()


def _content(frame: EthernetFrame, cls: type) -> list[object]:
    p = _ecat(frame)
    return [p.content] if p is not None and isinstance(p.content, cls) else []


def _nv(frame: EthernetFrame) -> list[ethercat.NetworkVariable]:
    return [v for nv in _content(frame, ethercat.NvPublication) for v in nv.variables]  # type: ignore[attr-defined]


def _udp(frame: EthernetFrame) -> list[ipv4udp.Ipv4Udp]:
    p = frame.payload
    return [p] if isinstance(p, ipv4udp.Ipv4Udp) else []


def _if(cls: type | tuple[type, ...], attr: str) -> Extract:
    def get(frame: EthernetFrame) -> list[int]:
        m = _epl(frame)
        return [int(getattr(m, attr))] if isinstance(m, cls) else []

    return get


def _service(cls: type, attr: str) -> Extract:
    def get(frame: EthernetFrame) -> list[int]:
        m = _epl(frame)
        s = m.service if isinstance(m, powerlink.ASnd) else None
        return [int(getattr(s, attr))] if isinstance(s, cls) else []

    return get


def _physical(d: ethercat.Datagram) -> bool:
    return d.cmd not in ethercat.LOGICAL_COMMANDS


EPL_FIELDS: dict[str, Extract] = {
    "epl.mtyp": lambda f: [int(m.MESSAGE_TYPE)] if (m := _epl(f)) is not None else [],
    "epl.src": lambda f: [m.src] if (m := _on_ethernet(f)) is not None else [],
    "epl.dest": lambda f: [m.dest] if (m := _on_ethernet(f)) is not None else [],
    "epl.preq.size": _if(powerlink.PReq, "size"),
    "epl.pres.size": _if(powerlink.PRes, "size"),
    "epl.pres.stat": _if(powerlink.PRes, "nmt_status"),
    "epl.soa.svid": _if(powerlink.SoA, "requested_service"),
    "epl.soa.svtg": _if(powerlink.SoA, "requested_target"),
    "epl.soa.eplv": _if(powerlink.SoA, "epl_version"),
    "epl.asnd.svid": _if(powerlink.ASnd, "service_id"),
    # Wireshark's names of the IdentResponse / StatusResponse flag bits (our aliases)
    **{
        f"epl.asnd.{short}.{name}": _service(cls, name)
        for short, cls in (("ires", powerlink.IdentResponse), ("sres", powerlink.StatusResponse))
        for name in ("en", "ec", "fls", "sls", "pr", "rs")
    },
}

ECAT_FIELDS: dict[str, Extract] = {
    "ecatf.length": lambda f: [p.length_field] if (p := _ecat(f)) is not None else [],
    "ecatf.type": lambda f: [int(p.frame_type)] if (p := _ecat(f)) is not None else [],
    "ecat.cmd": lambda f: [int(d.cmd) for d in _dgs(f)],
    "ecat.idx": lambda f: [d.idx for d in _dgs(f)],
    "ecat.adp": lambda f: [d.adp for d in _dgs(f) if _physical(d)],
    "ecat.ado": lambda f: [d.ado for d in _dgs(f) if _physical(d)],
    "ecat.lad": lambda f: [d.lad for d in _dgs(f) if not _physical(d)],
    "ecat.subframe.length": lambda f: [d.length for d in _dgs(f)],
    "ecat.subframe.circulating": lambda f: [int(d.circulating) for d in _dgs(f)],
    "ecat.int": lambda f: [d.irq for d in _dgs(f)],
    "ecat.cnt": lambda f: [d.wkc for d in _dgs(f)],
}

# VLAN tags: Wireshark's vlan dissector shows C-tags (and 0x9100), ieee8021ad the S-tags.
VLAN_FIELDS: dict[str, Extract] = {
    "vlan.id": lambda f: [t.vid for t in f.tags if getattr(t, "tpid", 0) != vlan.TPID_STAG],
    "vlan.priority": lambda f: [t.pcp for t in f.tags if getattr(t, "tpid", 0) != vlan.TPID_STAG],
    "ieee8021ad.id": lambda f: [t.vid for t in f.tags if getattr(t, "tpid", 0) == vlan.TPID_STAG],
}

ALL_FIELDS: dict[str, Extract] = {**EPL_FIELDS, **ECAT_FIELDS, **VLAN_FIELDS}

# Only on frames we decode as EPL/EtherCAT over UDP (other IP traffic has these fields too).
UDP_FIELDS: dict[str, Extract] = {
    "udp.srcport": lambda f: [p.sport for p in _udp(f)],
    "udp.dstport": lambda f: [p.dport for p in _udp(f)],
    "ip.ttl": lambda f: [p.ttl for p in _udp(f)],
    "ip.checksum": lambda f: [int.from_bytes(f.payload_bytes[10:12], "big") for _ in _udp(f)],
    "udp.checksum": lambda f: [
        int.from_bytes(f.payload_bytes[26 + len(p.options) : 28 + len(p.options)], "big")
        for p in _udp(f)
    ],
}

# Only on frames of EtherCAT type 4 or 5 (Wireshark also finds mailboxes inside datagrams).
CONTENT_FIELDS: dict[str, Extract] = {
    "tc_nv.count": lambda f: [len(nv.variables) for nv in _content(f, ethercat.NvPublication)],  # type: ignore[attr-defined]
    "tc_nv.cycleindex": lambda f: [nv.cycle_index for nv in _content(f, ethercat.NvPublication)],  # type: ignore[attr-defined]
    "tc_nv.id": lambda f: [v.id for v in _nv(f)],
    "tc_nv.hash": lambda f: [v.hash for v in _nv(f)],
    "tc_nv.length": lambda f: [len(v.data) for v in _nv(f)],
    "tc_nv.quality": lambda f: [v.quality for v in _nv(f)],
    "ecat_mailbox.length": lambda f: [len(m.data) for m in _content(f, ethercat.Mailbox)],  # type: ignore[attr-defined]
    "ecat_mailbox.address": lambda f: [m.address for m in _content(f, ethercat.Mailbox)],  # type: ignore[attr-defined]
    "ecat_mailbox.type": lambda f: [m.mailbox_type for m in _content(f, ethercat.Mailbox)],  # type: ignore[attr-defined]
    "ecat_mailbox.counter": lambda f: [m.counter for m in _content(f, ethercat.Mailbox)],  # type: ignore[attr-defined]
}
