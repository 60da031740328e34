"""The golden captures in ``pcaps/``: each built here from the codecs, deterministically.

Every scenario returns ``(time_ns, frame bytes)`` records. Timestamps are 10 us apart from 0, or
further where a sender's previous frame is still on the wire: a frame starts no earlier than the
end of its sender's previous frame plus the inter-frame gap at 100 Mbit/s (IEEE 802.3-2018 4.4.2;
``skinframes check`` flags overlaps). These files pin down bytes; timing is the emulator's
business. MACs are locally administered
(``02:00:00:00:0a:NN`` for EPL node NN, ``00:00:5e:00:53:01`` for the EtherCAT master, RFC 7042) and taxel
payloads come from the seeded :func:`skinframes.taxel.contact_pattern`.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Callable
from typing import Final

from skinframes import ethercat, ethernet, powerlink, taxel
from skinframes.ethercat import Command, Datagram, EcatFrame
from skinframes.powerlink import (
    ASnd,
    IdentResponse,
    NmtCommand,
    NmtCommandId,
    NmtRequest,
    NmtState,
    PReq,
    PRes,
    RequestedService,
    Sdo,
    SdoCommand,
    SoA,
    SoC,
    StatusResponse,
)

__all__ = ["SCENARIOS", "build", "stamp"]

STEP_NS: Final = 10_000
BYTE_NS: Final = 8 * 1_000_000_000 // ethernet.DEFAULT_BIT_RATE_BPS  # 80 ns at 100 Mbit/s
Records = list[tuple[int, bytes]]


def _stamp(frames: list[bytes]) -> Records:
    """10 us apart, but never before the sender's (source MAC's) previous frame has left the
    wire and the inter-frame gap has passed."""
    out: Records = []
    free_ns: dict[bytes, int] = {}  # source MAC -> when it may send again
    t = 0
    for i, f in enumerate(frames):
        src = f[ethernet.MAC_BYTES : 2 * ethernet.MAC_BYTES]
        t = max(t + STEP_NS if i else 0, free_ns.get(src, 0))
        free_ns[src] = t + (ethernet.wire_bytes(len(f)) + ethernet.IFG_BYTES) * BYTE_NS
        out.append((t, f))
    return out


def stamp(frames: list[bytes]) -> Records:
    """Timestamps for ``frames`` as the golden files have them (see :func:`_stamp`)."""
    return _stamp(frames)


def _patches(n: int, seed: int = 0) -> list[bytes]:
    pattern = taxel.contact_pattern(n, 1, seed=seed)[0]
    return [taxel.patch_to_bytes(p) for p in pattern]


def epl_cycle_4cn() -> Records:
    """One EPL cycle, MN + 4 CNs: SoC, (PReq, PRes with 192 taxel bytes) x 4, SoA."""
    frames = [powerlink.frame(SoC(net_time_s=1_700_000_000, relative_time_us=1000))]
    for cn, payload in enumerate(_patches(4), start=1):
        frames.append(powerlink.frame(PReq(cn)))
        frames.append(powerlink.frame(PRes(cn, payload)))
    frames.append(powerlink.frame(SoA()))
    return _stamp([f.to_bytes() for f in frames])


def epl_asnd_services() -> Records:
    """Each ASnd service once, each invited by its SoA as in an asynchronous phase."""
    ident = IdentResponse(
        nmt_status=NmtState.PRE_OPERATIONAL_2,
        vendor_id=0x12345678,
        product_code=0x0192,
        serial_number=1,
        mtu=300,
        poll_in_size=192,
        poll_out_size=0,
        ip_address=ipaddress.IPv4Address("192.168.100.1"),
        subnet_mask=ipaddress.IPv4Address("255.255.255.0"),
        default_gateway=ipaddress.IPv4Address("192.168.100.254"),
        host_name=b"skin-patch-1".ljust(32, b"\x00"),
    )
    read_device_type = SdoCommand(transaction_id=1, command_id=2, data=bytes.fromhex("00100000"))
    answer = SdoCommand(
        transaction_id=1, command_id=2, response=True, data=(0x0191).to_bytes(4, "little")
    )
    msgs: list[powerlink.EplMessage] = [
        SoA(RequestedService.IDENT_REQUEST, 1),
        ASnd(ident, src=1),
        SoA(RequestedService.STATUS_REQUEST, 1),
        ASnd(StatusResponse(), src=1),
        SoA(RequestedService.NMT_REQUEST_INVITE, 1),
        ASnd(NmtRequest(NmtCommandId.START_NODE, 1), dest=240, src=1),
        SoA(),
        ASnd(NmtCommand(NmtCommandId.START_NODE), dest=1),
        SoA(RequestedService.UNSPECIFIED_INVITE, 240),
        ASnd(Sdo(0, 2, 1, 2, read_device_type), dest=1),
        SoA(RequestedService.UNSPECIFIED_INVITE, 1),
        ASnd(Sdo(1, 2, 1, 2, answer), dest=240, src=1),
    ]
    return _stamp([powerlink.frame(m).to_bytes() for m in msgs])


def ecat_lrd_7x192() -> Records:
    """One frame of 7 LRD datagrams of 192 taxel bytes: as sent, and as returned by 7 slaves."""
    datagrams = [
        Datagram.logical(Command.LRD, i * taxel.PATCH_BYTES, bytes(taxel.PATCH_BYTES), idx=i)
        for i in range(7)
    ]
    out = EcatFrame(tuple(datagrams))
    back = EcatFrame(
        tuple(
            Datagram.logical(Command.LRD, d.lad, p, idx=d.idx, wkc=1)
            for d, p in zip(datagrams, _patches(7), strict=True)
        )
    )
    return _stamp([ethercat.frame(out).to_bytes(), ethercat.frame(back, returned=True).to_bytes()])


def ecat_23_slaves() -> Records:
    """23 slaves x 192 bytes, one LRD per slave, packed into as few frames as fit (7+7+7+2)."""
    patches = _patches(23)
    sent = [
        Datagram.logical(Command.LRD, i * taxel.PATCH_BYTES, bytes(taxel.PATCH_BYTES), idx=i)
        for i in range(23)
    ]
    back = [
        Datagram.logical(Command.LRD, d.lad, p, idx=d.idx, wkc=1)
        for d, p in zip(sent, patches, strict=True)
    ]
    frames = [ethercat.frame(f).to_bytes() for f in ethercat.pack_datagrams(sent)]
    frames += [ethercat.frame(f, returned=True).to_bytes() for f in ethercat.pack_datagrams(back)]
    return _stamp(frames)


# One datagram per command, addressed as a master would address it (registers from ETG.1000.4
# Table 31: 0x0000 type, 0x0010 station address, 0x0120 AL control, 0x0130 AL status, 0x0910 DC).
_ALL_COMMANDS: Final = (
    Datagram(Command.NOP, 0, 0, bytes(2)),
    Datagram(Command.APRD, 0, 0x0000, bytes(2), wkc=1),
    Datagram(Command.APWR, 0xFFFF, 0x0010, (0x1001).to_bytes(2, "little"), wkc=1),
    Datagram(Command.APRW, 0xFFFE, 0x0120, (0x0002).to_bytes(2, "little"), wkc=3),
    Datagram(Command.FPRD, 0x1001, 0x0130, (0x0002).to_bytes(2, "little"), wkc=1),
    Datagram(Command.FPWR, 0x1001, 0x0120, (0x0004).to_bytes(2, "little"), wkc=1),
    Datagram(Command.FPRW, 0x1001, 0x0120, (0x0008).to_bytes(2, "little"), wkc=3),
    Datagram(Command.BRD, 0, 0x0130, (0x0008).to_bytes(2, "little"), wkc=23),
    Datagram(Command.BWR, 0, 0x0120, (0x0008).to_bytes(2, "little"), wkc=23),
    Datagram(Command.BRW, 0, 0x0120, (0x0008).to_bytes(2, "little"), wkc=69),
    Datagram.logical(Command.LRD, 0x00010000, bytes(4), wkc=1),
    Datagram.logical(Command.LWR, 0x00020000, bytes(4), wkc=1),
    Datagram.logical(Command.LRW, 0x00030000, bytes(4), wkc=3),
    Datagram(Command.ARMW, 0x0000, 0x0910, bytes(8), wkc=23),
    Datagram(Command.FRMW, 0x1001, 0x0910, bytes(8), wkc=23),
)


def ecat_all_commands() -> Records:
    """Every EtherCAT datagram command once, one frame each."""
    return _stamp([ethercat.frame(EcatFrame((d,))).to_bytes() for d in _ALL_COMMANDS])


SCENARIOS: Final[dict[str, Callable[[], Records]]] = {
    "epl_cycle_4cn": epl_cycle_4cn,
    "epl_asnd_services": epl_asnd_services,
    "ecat_lrd_7x192": ecat_lrd_7x192,
    "ecat_23_slaves": ecat_23_slaves,
    "ecat_all_commands": ecat_all_commands,
}


def build(name: str) -> Records:
    """The records of the golden scenario ``name`` (a key of :data:`SCENARIOS`)."""
    return SCENARIOS[name]()
