"""MN frames for the offline EPL CN tests, typed in byte by byte from DS 301.

EPSG DS 301 V1.4.0 4.6.1.1 (SoC, PReq, SoA layouts), 7.3.1 (NMTCommand), 6.3.2 (SDO over
ASnd): each helper takes the fields as numbers or hex and writes the bytes in the spec's order,
so an expected value never comes from the code under test.
"""

from __future__ import annotations

import random

from emulator.epl.skin import EplSkin

MN_MAC = "020000000af0"
ASND_MAC = "01111e000004"  # C_DLL_MULTICAST_ASND
SOC_MAC, PRES_MAC, SOA_MAC = "01111e000001", "01111e000002", "01111e000003"
TAXELS = 24


def mn(dst: str, epl: str) -> bytes:
    """An MN frame: destination MAC, the MN's MAC, EtherType 0x88AB, the EPL bytes, padded."""
    frame = bytes.fromhex(dst + MN_MAC + "88ab" + epl.replace(" ", ""))
    return frame.ljust(60, b"\0")


def soc(net_time: str = "00" * 8) -> bytes:
    """SoC (4.6.1.1.1): 01 ff f0, reserved, flags, reserved, NetTime (s u32, ns u32, as hex),
    RelativeTime (u64)."""
    return mn(SOC_MAC, "01 ff f0 00 00 00" + net_time + "00" * 8)


def soa(service: int, target: int, *, er: bool = False, state: int = 0xFD) -> bytes:
    """SoA (DS 301 4.6.1.1.5): 05 ff f0, NMTStatus, flags1 (ER 0x02), reserved, svid, target,
    EPLVersion 0x20, flags3."""
    return mn(
        SOA_MAC, f"05 ff f0 {state:02x} {0x02 if er else 0:02x} 00 {service:02x} {target:02x} 20 00"
    )


def preq(node: int, payload: str = "00", rd: bool = True) -> bytes:
    """PReq (4.6.1.1.3): 03 node f0, reserved, flags1 (RD), flags2, PDOVersion, reserved, size."""
    size = len(bytes.fromhex(payload))
    return mn(
        f"020000000a{node:02x}",
        f"03 {node:02x} f0 00 {int(rd):02x} 00 00 00 {size:02x} 00 {payload}",
    )


def nmt_command(dest: int, command: int, data: str = "") -> bytes:
    """ASnd NMTCommand (7.3.1): 06 dest f0 04, NMTCommandID, reserved, data."""
    return mn(ASND_MAC, f"06 {dest:02x} f0 04 {command:02x} 00 {data}")


def sdo(dest: int, seq: str, command: str = "") -> bytes:
    """ASnd SDO (6.3.2): 06 dest f0 05, the sequence layer (4 bytes), the command layer."""
    return mn(ASND_MAC, f"06 {dest:02x} f0 05 {seq} {command}")


def feed(skin: EplSkin, frame: bytes, now_ns: int = 1) -> bytes | None:
    """One frame in, as the live loop does: the immediate answer, then the nodes react."""
    back = skin.answer(frame)
    skin.after(frame, back, now_ns)
    return back


def epl(frame: bytes | None) -> bytes:
    assert frame is not None
    return frame[14:]


def invite(skin: EplSkin, node: int) -> bytes | None:
    """SoA UnspecifiedInvite (svid 0xFF) to ``node``: what it sends from its queue."""
    return feed(skin, soa(0xFF, node))


def booted(*ids: int) -> EplSkin:
    """CNs in PreOperational2: a SoA (NotActive -> PreOp1, NMT_CT2), a SoC (-> PreOp2, CT4)."""
    skin = EplSkin(list(ids), TAXELS)
    feed(skin, soa(0, 0))
    feed(skin, soc())
    return skin


def status_of(skin: EplSkin, node: int) -> int:
    """The NMTStatus a StatusResponse (SoA svid 2) reports: ASnd byte 6 (DS 301 7.3.3.3.1)."""
    return epl(feed(skin, soa(2, node)))[6]


def hostile(rng: random.Random) -> bytes:
    """One hostile frame: random EPL bytes, a mutated MN frame, or a random SDO."""
    kind = rng.randrange(4)
    if kind == 0:  # any bytes, any length, EPL EtherType
        body = rng.randbytes(rng.randrange(0, 1500))
        return bytes(6) + bytes(6) + b"\x88\xab" + body
    if kind == 1:  # a valid MN frame with random bytes changed
        frame = bytearray(
            rng.choice(
                [soc(), soa(rng.randrange(256), rng.randrange(256)), preq(rng.randrange(256))]
            )
        )
        for _ in range(rng.randrange(1, 6)):
            frame[rng.randrange(14, len(frame))] = rng.randrange(256)
        return bytes(frame)
    if kind == 2:  # SDO with random sequence layer and command layer
        seq = rng.randbytes(4).hex()
        command = rng.randbytes(rng.choice([0, 4, 8, 12, 20, 40])).hex()
        return sdo(rng.choice([1, 2, 255, 7]), seq, command)
    # NMT commands, any id, any data, to anyone
    return nmt_command(
        rng.choice([1, 2, 255]), rng.randrange(256), rng.randbytes(rng.randrange(40)).hex()
    )
