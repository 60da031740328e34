"""Hostile EtherCAT traffic for robustness tests: random and mutated frames, and a master's reset.

Every frame these functions build has a valid Ethernet II and EtherCAT header (ETG.1000.4
Table 12); what follows is random: commands (the 15 of Table 14 and reserved values), addresses,
lengths, and register writes aimed where a configuration does harm: the FMMUs (0x0600-0x06FF,
datasheet II 2.13, with physical starts up to 0xFFFF, bit offsets and lengths up to 0xFFFF), the
SyncManagers (0x0800-0x087F, II 2.14, overlapping and beyond 64 KiB), AL control (0x0120) and
the EEPROM interface (0x0500-0x050F). EEPROM writes keep the write-enable bit (0x0502 bit 0)
clear, so the SII itself survives: a real slave whose EEPROM a master overwrote is broken too.
A quarter of the frames are mutations of ordinary configuration and process-data frames.

:func:`master_reset_frames` is what a master sends before it configures a line it knows nothing
about (SOEM's ``ecx_config_init``: loop control auto, no alias, ECAT owns the EEPROM, event
mask, FMMUs and SyncManagers cleared, SYNC0/SYNC1 deactivated, INIT with acknowledge), so that a chain that received
hostile frames can be configured again (:func:`emulator.esc.chain.configure_frames`).
"""

from __future__ import annotations

import random
import struct
from collections.abc import Iterator
from typing import Final

from emulator.esc.write_plans import EEPROM_INTERFACE
from skinframes import ethercat
from skinframes.ethercat import Command, Datagram, EcatFrame

__all__ = ["hostile_frames", "master_reset_frames"]

_AREAS: Final = ((0x0600, 0x0700), (0x0800, 0x0880), (0x0120, 0x0122), EEPROM_INTERFACE)
_WRITES: Final = (
    Command.APWR,
    Command.FPWR,
    Command.BWR,
    Command.APRW,
    Command.FPRW,
    Command.BRW,
    Command.ARMW,
    Command.FRMW,
)
_FRAME_DATA_BYTES: Final = ethercat.MAX_DATAGRAM_DATA_BYTES + ethercat.DATAGRAM_OVERHEAD_BYTES


CONFIG_AREA_WORDS: Final = 8  # SII words 0-7: ESC configuration area A (datasheet I 11.1)


def eeprom_repair_frames(areas: list[bytes]) -> list[bytes]:
    """What a master sends to rewrite each slave's EEPROM configuration area (words 0-7, with
    its checksum; ``areas[p]`` the 16 bytes for the slave at position ``p``) and reload it:
    one word a slave a frame, each an address, the word and the write command with write
    enable in one frame (datasheet I 11.2.3, II 0x0502-0x050F), then a reload at every slave.
    Hostile frames of a generator that sets write enable can corrupt an EEPROM; a real slave
    then stays without its PDI until its EEPROM is written again (as this does, in the way
    eeprom tools of masters do). ECAT must own the EEPROM interface
    (:func:`master_reset_frames` gives it to ECAT)."""
    frames = []
    for word in range(CONFIG_AREA_WORDS):
        batch: list[Datagram] = []
        for p, area in enumerate(areas):
            adp = -p & 0xFFFF
            value = area[2 * word : 2 * word + 2]
            batch += [
                Datagram(Command.APWR, adp, 0x0504, struct.pack("<I", word)),
                Datagram(Command.APWR, adp, 0x0508, value),
                Datagram(Command.APWR, adp, 0x0502, struct.pack("<H", 0x0201)),
            ]
            if len(batch) >= 3 * 32 or p == len(areas) - 1:  # 32 slaves a frame: 1,280 bytes
                frames.append(ethercat.frame(EcatFrame(tuple(batch))).to_bytes())
                batch = []
    reload = Datagram(Command.BWR, 0, 0x0502, struct.pack("<H", 0x0400))
    return [*frames, ethercat.frame(EcatFrame((reload,))).to_bytes()]


def master_reset_frames(nodes: int) -> list[bytes]:
    """Broadcast writes that bring a line of ``nodes`` back to a state a master can configure.

    The loop-control write is repeated ``nodes`` times: an ESC whose port 1 a hostile frame
    closed returns each frame early, and opens it only at the end of the frame that reset it.
    """
    writes = [
        *((0x0101, b"\x00") for _ in range(nodes)),  # DL control: loop ports auto
        (0x0103, b"\x00"),  # no station alias
        (0x0500, b"\x02"),  # EEPROM: force ECAT access
        (0x0500, b"\x00"),
        (0x0200, b"\x00\x00"),  # ECAT event mask
        (0x0108, b"\x00\x00"),  # RW offset
        (0x0600, bytes(16 * 16)),  # FMMUs off
        (0x0806, b"\x00"),  # SyncManagers off (their configuration is locked while enabled)
        *((0x0806 + 8 * y, b"\x00") for y in range(1, 16)),
        (0x0800, bytes(8 * 16)),
        (0x0980, b"\x00\x00"),  # distributed clocks: SYNC units to ECAT, deactivated
        (0x0120, struct.pack("<H", 0x11)),  # INIT + error acknowledge
    ]
    return [
        ethercat.frame(EcatFrame((Datagram(Command.BWR, 0, ado, data),))).to_bytes()
        for ado, data in writes
    ]


def _fmmu_entry(rng: random.Random) -> bytes:
    phys = rng.choice((0xFFFF, 0xFFF0, 0x1000, 0x0F00, 0x0000, rng.randrange(0x10000)))
    length = rng.choice((1, 2, 0xFFFF, rng.randrange(0x10000)))
    logical = rng.choice((0, 0xFFFFFFFF - rng.randrange(64), rng.randrange(1 << 32)))
    return struct.pack(
        "<IHBBHBBB3x",
        logical,
        length,
        rng.randrange(8),
        rng.randrange(8),
        phys,
        rng.randrange(8),
        rng.randrange(4),
        1,
    )


def _sm_entry(rng: random.Random) -> bytes:
    start = rng.choice((0xFFFF, 0xFFFE, 0x1000, 0x0F7F, 0x0000, rng.randrange(0x10000)))
    length = rng.choice((0, 1, 2, 0xFFFF, rng.randrange(0x10000)))
    return struct.pack("<HHBBBB", start, length, rng.randrange(256), 0, 1, rng.randrange(256))


def _aimed(rng: random.Random) -> Datagram:
    lo, hi = rng.choice(_AREAS)
    cmd = rng.choice(_WRITES)
    if lo == 0x0600 and rng.random() < 0.7:
        ado = lo + 16 * rng.randrange(16)
        data = b"".join(_fmmu_entry(rng) for _ in range(rng.randint(1, 4)))
    elif lo == 0x0800 and rng.random() < 0.7:
        ado = lo + 8 * rng.randrange(16)
        data = b"".join(_sm_entry(rng) for _ in range(rng.randint(1, 4)))
    else:
        ado = rng.randrange(lo, hi)
        raw = bytearray(rng.randbytes(rng.randint(1, hi - ado + 2)))
        if ado <= 0x0502 < ado + len(raw):
            raw[0x0502 - ado] &= 0xFE  # no EEPROM write enable: the SII survives
        data = bytes(raw)
    return Datagram(
        cmd, rng.choice((0, 0x1000 + rng.randrange(4), rng.randrange(0x10000))), ado, data
    )


def _random(rng: random.Random, room: int) -> Datagram:
    cmd = rng.randrange(16) if rng.random() < 0.9 else rng.randrange(256)
    n = min(room, rng.choice((0, 1, 2, 8, rng.randrange(room + 1))))
    return Datagram(cmd, rng.randrange(0x10000), rng.randrange(0x10000), rng.randbytes(n))


def _logical(rng: random.Random, room: int, image_bytes: int) -> Datagram:
    cmd = rng.choice((Command.LRD, Command.LWR, Command.LRW))
    lad = rng.choice((0, rng.randrange(max(1, image_bytes)), rng.randrange(1 << 32)))
    n = min(room, rng.choice((1, image_bytes, rng.randrange(room + 1))))
    return Datagram.logical(cmd, lad, rng.randbytes(n))


def _mutated(rng: random.Random, ordinary: list[bytes]) -> bytes:
    frame = bytearray(rng.choice(ordinary))
    header = 14 + ethercat.FRAME_HEADER_BYTES
    for _ in range(rng.randint(1, 6)):
        if len(frame) > header:
            frame[rng.randrange(header, len(frame))] = rng.randrange(256)
    return bytes(frame)


def hostile_frames(
    count: int, *, nodes: int, input_bytes: int, seed: int = 0, max_datagrams: int = 4
) -> Iterator[bytes]:
    """``count`` seeded hostile frames for a line of ``nodes`` patches of ``input_bytes``.

    Each frame holds 1..``max_datagrams`` datagrams: register writes aimed at FMMU, SM, AL and
    EEPROM registers, random commands and addresses, logical accesses; or it is an ordinary
    configuration or LRD frame with up to 6 random bytes changed after the EtherCAT header.
    """
    from emulator.configure import configure_frames
    from emulator.slave.sii import SlaveInfo

    rng = random.Random(seed)
    image = nodes * input_bytes
    lrd = Datagram.logical(Command.LRD, 0, bytes(min(image, ethercat.MAX_DATAGRAM_DATA_BYTES)))
    ordinary = [
        *configure_frames(SlaveInfo.skin_patch(input_bytes), min(nodes, 4)),
        ethercat.frame(EcatFrame((lrd,))).to_bytes(),
    ]
    for _ in range(count):
        if rng.random() < 0.25:
            yield _mutated(rng, ordinary)
            continue
        dgs: list[Datagram] = []
        room = _FRAME_DATA_BYTES
        for _ in range(rng.randint(1, max_datagrams)):
            free = room - ethercat.DATAGRAM_OVERHEAD_BYTES
            if free < 0:
                break
            kind = rng.random()
            if kind < 0.5:
                d = _aimed(rng)
            elif kind < 0.8:
                d = _random(rng, free)
            else:
                d = _logical(rng, free, image)
            if d.size_bytes > room:
                break
            dgs.append(d)
            room -= d.size_bytes
        if not dgs:
            dgs.append(_aimed(rng))
        yield ethercat.frame(EcatFrame(tuple(dgs))).to_bytes()
