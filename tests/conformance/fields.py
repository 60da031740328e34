"""Our decoded fields, named as tshark names them (the one mapping table; STYLE 2.2).

Each entry maps a tshark field to a function of our decoded frame that returns every occurrence
of that field in the frame, in order, as ints (tshark prints hex fields as 0x.., parse with int(v, 0)).
"""

from __future__ import annotations

from collections.abc import Callable

from skinframes import ethercat, powerlink
from skinframes.ethernet import EthernetFrame

Extract = Callable[[EthernetFrame], list[int]]


def _epl(frame: EthernetFrame) -> powerlink.EplMessage | None:
    p = frame.payload
    ok = (powerlink.SoC, powerlink.PReq, powerlink.PRes, powerlink.SoA, powerlink.ASnd)
    return p if isinstance(p, ok) else None


def _dgs(frame: EthernetFrame) -> tuple[ethercat.Datagram, ...]:
    p = frame.payload
    return p.datagrams if isinstance(p, ethercat.EcatFrame) else ()


def _if(cls: type | tuple[type, ...], attr: str) -> Extract:
    def get(frame: EthernetFrame) -> list[int]:
        m = _epl(frame)
        return [int(getattr(m, attr))] if isinstance(m, cls) else []

    return get


def _physical(d: ethercat.Datagram) -> bool:
    return d.cmd not in ethercat.LOGICAL_COMMANDS


EPL_FIELDS: dict[str, Extract] = {
    "epl.mtyp": lambda f: [int(m.MESSAGE_TYPE)] if (m := _epl(f)) is not None else [],
    "epl.src": lambda f: [m.src] if (m := _epl(f)) is not None else [],
    "epl.dest": lambda f: [m.dest] if (m := _epl(f)) is not None else [],
    "epl.preq.size": _if(powerlink.PReq, "size"),
    "epl.pres.size": _if(powerlink.PRes, "size"),
    "epl.pres.stat": _if(powerlink.PRes, "nmt_status"),
    "epl.soa.svid": _if(powerlink.SoA, "requested_service"),
    "epl.soa.svtg": _if(powerlink.SoA, "requested_target"),
    "epl.soa.eplv": _if(powerlink.SoA, "epl_version"),
    "epl.asnd.svid": _if(powerlink.ASnd, "service_id"),
}

ECAT_FIELDS: dict[str, Extract] = {
    "ecatf.length": lambda f: (
        [p.datagram_bytes if p.length is None else p.length]
        if isinstance(p := f.payload, ethercat.EcatFrame)
        else []
    ),
    "ecatf.type": lambda f: (
        [int(p.frame_type)] if isinstance(p := f.payload, ethercat.EcatFrame) else []
    ),
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

ALL_FIELDS: dict[str, Extract] = {**EPL_FIELDS, **ECAT_FIELDS}
