"""Hostile EtherCAT frames written from the specifications, independently of the emulator.

A second generator beside :mod:`emulator.hostile`, which is tuned to what the emulated ESC
was written for. This one is written from two documents only, and imports nothing of ours:

* ETG.1000.4 (IEC 61158-4-12) for the frame: Ethernet II with EtherType 0x88A4 (optionally
  behind an 802.1Q tag), the 2-byte EtherCAT header (Table 12: length 11 bits, reserved 1 bit,
  type 4 bits, 1 = EtherCAT commands), datagrams of a 10-byte header (Table 13: command, index,
  32-bit address, length 11 bits, 3 reserved bits, C circulating, M more datagrams, IRQ), data
  and a 2-byte working counter; the commands of Table 14 (0 NOP ... 14 FRMW, 15 reserved).
* The Beckhoff EtherCAT Slave Controller datasheet, section II (register description), for
  what each register area means and which values hurt: identity, addresses, write protection,
  ESC reset, DL control and status, AL control/status, PDI, events, error counters,
  watchdogs, the SII EEPROM interface, FMMUs, SyncManagers, distributed clocks, user and
  process RAM.

:func:`frames` streams ``count`` frames for a line of ``nodes`` slaves, deterministically for a
seed: about a third fully random datagrams, a third a master's frames mutated, a third
configuration attacks (frames that configure FMMUs, SyncManagers, clocks, the EEPROM or the
loops hostilely, followed in the next frames by accesses through what they configured).
:func:`datagrams` walks a frame as leniently as a dissector would, to describe it.
"""

from __future__ import annotations

import random
import struct
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from enum import IntEnum
from typing import Final

__all__ = ["Cmd", "datagrams", "describe", "frames"]

# --- ETG.1000.4 frame format (Tables 12-13) and Ethernet II (IEEE 802.3)
ETHERTYPE_ECAT: Final = 0x88A4
ETHERTYPE_VLAN: Final = 0x8100  # IEEE 802.1Q tag protocol identifier
WRONG_ETHERTYPES: Final = (0x0800, 0x0806, 0x86DD, 0x88A5, 0x88AB, 0x88A3, 0x8100, 0x0000, 0xFFFF)
MAC_BYTES: Final = 6
ETH_HEADER_BYTES: Final = 2 * MAC_BYTES + 2  # 14
VLAN_TAG_BYTES: Final = 4
MIN_FRAME_BYTES: Final = 60  # without FCS; shorter frames are padded
MAX_FRAME_BYTES: Final = 1514  # without FCS
ECAT_HEADER_BYTES: Final = 2
ECAT_TYPE_COMMANDS: Final = 1  # Table 12: type 1 = EtherCAT commands (DLPDU)
RESERVED_BIT: Final = 0x0800  # Table 12: length bits 0-10, reserved bit 11, type bits 12-15
TYPE_SHIFT: Final = 12
DATAGRAM_HEADER_BYTES: Final = 10
WKC_BYTES: Final = 2
DATAGRAM_OVERHEAD_BYTES: Final = DATAGRAM_HEADER_BYTES + WKC_BYTES  # 12
MAX_DATAGRAMS_BYTES: Final = MAX_FRAME_BYTES - ETH_HEADER_BYTES - ECAT_HEADER_BYTES  # 1498
MAX_DATA_BYTES: Final = MAX_DATAGRAMS_BYTES - DATAGRAM_OVERHEAD_BYTES  # 1486
LENGTH_MASK: Final = 0x07FF  # Table 13: len, 11 bits
CIRCULATING_BIT: Final = 0x4000  # Table 13: C
MORE_BIT: Final = 0x8000  # Table 13: M, another datagram follows
STATION_BASE: Final = 0x1001  # the station address a master gives position 0 (then +position)
MASTER_MAC: Final = b"\x02\x00\x00\x00\x00\x01"
BROADCAST_MAC: Final = b"\xff" * MAC_BYTES
SHOWN_DATA_BYTES: Final = 8  # describe() shows the data of datagrams this short

_DATAGRAM_HEADER: Final = struct.Struct("<BBIHH")  # cmd, idx, address, len|C|M, irq
_U16: Final = struct.Struct("<H")
_U32: Final = struct.Struct("<I")
_U64: Final = struct.Struct("<Q")
_FMMU: Final = struct.Struct("<IHBBHBBB3s")  # datasheet II 0x0600 + 16*n, 16 bytes
_SM: Final = struct.Struct("<HHBBBB")  # datasheet II 0x0800 + 8*n, 8 bytes


class Cmd(IntEnum):
    """ETG.1000.4 Table 14: the command of a datagram (15 is reserved)."""

    NOP = 0
    APRD = 1
    APWR = 2
    APRW = 3
    FPRD = 4
    FPWR = 5
    FPRW = 6
    BRD = 7
    BWR = 8
    BRW = 9
    LRD = 10
    LWR = 11
    LRW = 12
    ARMW = 13
    FRMW = 14
    RESERVED = 15


POSITION: Final = (Cmd.APRD, Cmd.APWR, Cmd.APRW, Cmd.ARMW)  # auto-increment address
NODE: Final = (Cmd.FPRD, Cmd.FPWR, Cmd.FPRW, Cmd.FRMW)  # configured station address
BROADCAST: Final = (Cmd.BRD, Cmd.BWR, Cmd.BRW)
LOGICAL: Final = (Cmd.LRD, Cmd.LWR, Cmd.LRW)
WRITES: Final = (Cmd.APWR, Cmd.APRW, Cmd.FPWR, Cmd.FPRW, Cmd.BWR, Cmd.BRW, Cmd.ARMW, Cmd.FRMW)
READS: Final = (Cmd.APRD, Cmd.FPRD, Cmd.BRD, Cmd.APRW, Cmd.FPRW, Cmd.BRW, Cmd.ARMW, Cmd.FRMW)

# logical addresses where masters map process images (SOEM from 0, TwinCAT 0x01000000)
IMAGE_BASES: Final = (0x0000_0000, 0x0001_0000, 0x0100_0000)
# physical addresses FMMUs and SyncManagers are pointed at: registers, user RAM, the usual
# mailbox and buffer places in process RAM (datasheet II: process RAM from 0x1000)
FMMU_PHYSICAL_STARTS: Final = (0x0000, 0x0120, 0x0600, 0x0800, 0x0F80, 0x1000, 0x1080, 0x1100)
SM_STARTS: Final = (0x1000, 0x1080, 0x1100, 0x1200, 0x0000, 0x0120, 0x0500, 0x0800, 0x0F80)


@dataclass(slots=True)
class _Dg:
    """One datagram before encoding; ``length``/``more`` None mean the right values."""

    cmd: int
    address: int  # 32 bits: ADP (low 16) and ADO (high 16), or the logical address
    data: bytes
    idx: int = 0
    irq: int = 0
    wkc: int = 0
    length: int | None = None
    more: bool | None = None
    circulating: bool = False

    def encoded_bytes(self) -> int:
        return DATAGRAM_OVERHEAD_BYTES + len(self.data)


def _encode(dgs: list[_Dg]) -> bytes:
    """The datagrams as ETG.1000.4 Table 13 lays them out, M set on all but the last unless a
    datagram says otherwise."""
    out = []
    last = len(dgs) - 1
    for i, d in enumerate(dgs):
        more = (i < last) if d.more is None else d.more
        n = len(d.data) if d.length is None else d.length
        word = (
            (n & LENGTH_MASK)
            | (MORE_BIT if more else 0)
            | (CIRCULATING_BIT if d.circulating else 0)
        )
        out.append(
            _DATAGRAM_HEADER.pack(d.cmd & 0xFF, d.idx & 0xFF, d.address & 0xFFFFFFFF, word, d.irq)
        )
        out.append(d.data)
        out.append(_U16.pack(d.wkc & 0xFFFF))
    return b"".join(out)


def _address(adp: int, ado: int) -> int:
    return (adp & 0xFFFF) | (ado & 0xFFFF) << 16


def datagrams(frame: bytes) -> list[tuple[int, int, int, int, bytes]]:
    """(command, ADP, ADO, data length, data) of each datagram ``frame`` carries, walked as a lenient
    dissector does: after an optional 802.1Q tag, from the EtherCAT header, each datagram's
    length field, while the M bit is set and the bytes last (the logical address is ADO << 16 |
    ADP). Empty for anything else."""
    pos = ETH_HEADER_BYTES
    if len(frame) < pos:
        return []
    ethertype = int.from_bytes(frame[12:14], "big")
    if ethertype == ETHERTYPE_VLAN and len(frame) >= pos + VLAN_TAG_BYTES:
        ethertype = int.from_bytes(frame[16:18], "big")
        pos += VLAN_TAG_BYTES
    if ethertype != ETHERTYPE_ECAT:
        return []
    pos += ECAT_HEADER_BYTES
    out = []
    while pos + DATAGRAM_OVERHEAD_BYTES <= len(frame):
        cmd, _, address, word, _ = _DATAGRAM_HEADER.unpack_from(frame, pos)
        n = word & LENGTH_MASK
        at = pos + DATAGRAM_HEADER_BYTES
        out.append((cmd, address & 0xFFFF, address >> 16, n, frame[at : at + n]))
        pos += DATAGRAM_OVERHEAD_BYTES + n
        if not word & MORE_BIT:
            break
    return out


def describe(frame: bytes, most: int = 8) -> str:
    """The datagrams of ``frame`` in one line (``LRW@0x00010000+1280 FPRD 0x1001:0x0130+2``),
    the first ``most`` of them and how many more."""
    parts = []
    dgs = datagrams(frame)
    for cmd, adp, ado, n, data in dgs[:most]:
        name = Cmd(cmd).name if cmd < len(Cmd) else f"cmd{cmd}"
        if cmd in LOGICAL:
            parts.append(f"{name}@{ado << 16 | adp:#010x}+{n}")
        else:
            parts.append(f"{name} {adp:#06x}:{ado:#06x}+{n}")
        if 0 < len(data) <= SHOWN_DATA_BYTES:
            parts[-1] += f"={data.hex()}"
    if len(dgs) > most:
        parts.append(f"... {len(dgs)} datagrams, {sum(d[3] for d in dgs)} data bytes")
    return " ".join(parts) or f"not EtherCAT ({len(frame)} bytes)"


# --- values that hurt, register by register (datasheet section II)


def _u16(rng: random.Random) -> int:
    return rng.choice((0, 1, 0x7FFF, 0x8000, 0xFFFF, rng.randrange(0x10000)))


def _u32(rng: random.Random) -> int:
    return rng.choice((0, 1, 0x7FFF_FFFF, 0x8000_0000, 0xFFFF_FFFF, rng.randrange(1 << 32)))


def _u64(rng: random.Random) -> int:
    return rng.choice(
        (
            0,
            1,
            (1 << 63) - 1,
            1 << 63,
            (1 << 64) - 1,
            (1 << 64) - 1 - rng.randrange(1 << 32),
            rng.randrange(1 << 32),
            rng.randrange(1 << 64),
        )
    )


def _fmmu_entry(rng: random.Random, windows: list[int], image_bytes: int) -> bytes:
    """Datasheet II 0x0600 + 16n: logical start (32 bits), length, logical start/stop bit,
    physical start, physical start bit, type (bit 0 read, bit 1 write), activate (bit 0)."""
    logical = rng.choice(
        (
            rng.choice(IMAGE_BASES) + rng.randrange(image_bytes + 1),
            0,
            0xFFFF_FFFF - rng.randrange(64),
            rng.randrange(1 << 32),
        )
    )
    windows.append(logical)
    length = rng.choice((0, 1, 2, image_bytes, 0xFFFF, rng.randrange(0x10000), rng.randrange(64)))
    physical = rng.choice(
        (*FMMU_PHYSICAL_STARTS, 0xFFFF - rng.randrange(16), rng.randrange(0x10000))
    )
    bits = 8 if rng.random() < 0.8 else 256  # start/stop bits 0-7, sometimes any byte
    return _FMMU.pack(
        logical & 0xFFFF_FFFF,
        length,
        rng.randrange(bits),
        rng.randrange(bits),
        physical,
        rng.randrange(bits),
        rng.choice((1, 2, 3, 0, rng.randrange(256))),  # read, write, both, none, any
        rng.choice((1, 1, 0, rng.randrange(256))),  # enabled or not
        rng.randbytes(3) if rng.random() < 0.1 else bytes(3),
    )


def _sm_entry(rng: random.Random, starts: list[int]) -> bytes:
    """Datasheet II 0x0800 + 8n: physical start, length, control (bits 0-1 mode: 00 buffered,
    10 mailbox; bits 2-3 direction: 00 read, 01 write; bit 4/5 ECAT/AL event, bit 6 watchdog),
    status (read only), activate (bit 0 enable, bit 1 repeat, bits 6-7 latch), PDI control."""
    start = rng.choice(
        (*SM_STARTS, 0xFFFF - rng.randrange(4), 0xFFFF - rng.randrange(256), rng.randrange(0x10000))
    )
    starts.append(start)
    length = rng.choice((0, 1, 2, 3, 8, 128, 0x0400, 0xFFFF, rng.randrange(0x10000)))
    mode = rng.choice((0b00, 0b10, 0b01, 0b11))
    direction = rng.choice((0b00, 0b01, 0b10, 0b11))
    control = mode | direction << 2 | rng.randrange(8) << 4 | (rng.random() < 0.1) << 7
    activate = rng.choice((0x01, 0x03, 0x00, 0x02, 0x41, 0x81, 0xC1, rng.randrange(256)))
    return _SM.pack(start, length, control, rng.randrange(256), activate, rng.randrange(4))


def _eeprom_words(rng: random.Random) -> bytes:
    """Datasheet II 0x0500-0x050F: configuration (bit 0 PDI access offered, bit 1 force
    ECAT), PDI access state, control/status (bit 0 write enable; bits 8-10 command: 1 read,
    2 write, 4 reload, others invalid; status bits 11-15), word address (32 bits, in and beyond
    the EEPROM), data (8 bytes)."""
    command = rng.choice((0x0100, 0x0201, 0x0200, 0x0400, 0x0300, 0x0500, 0x0600, 0x0700))
    control = command | rng.choice((0, 0, 1, rng.randrange(256))) | rng.choice((0, 0, 0xF800))
    address = rng.choice((0, 1, 8, 0x40, 0x7F, 0x80, 0x3FF, 0x800, 0xFFFF, rng.randrange(1 << 32)))
    return (
        bytes((rng.choice((0, 1, 2, 3)), rng.choice((0, 1))))
        + _U16.pack(control & 0xFFFF)
        + _U32.pack(address)
        + rng.randbytes(8)
    )


def _dc_block(rng: random.Random, ado: int) -> bytes:
    """Datasheet II 0x0900-0x09FF, the register at ``ado`` with a value that hurts: receive time
    latch 0x0900, system time 0x0910 (4 or 8 bytes), offset 0x0920, delay 0x0928, speed counter
    start 0x0930 (0 included), filter depths 0x0934/0x0935, cyclic unit 0x0980/0x0981 (every
    bit), pulse length 0x0982, start time 0x0990 (near 0 and near 2^64), SYNC0/1 cycle times
    0x09A0/0x09A4 (0 and huge), latch control 0x09A8."""
    if ado == 0x0910:
        return _U64.pack(_u64(rng))[: rng.choice((4, 8))]
    if ado in (0x0920, 0x0990):
        return _U64.pack(_u64(rng))
    if ado in (0x0928, 0x09A0, 0x09A4):
        return _U32.pack(rng.choice((0, 1, 10, 1000, 125_000, 1_000_000, 0xFFFF_FFFF, _u32(rng))))
    if ado == 0x0930:
        return _U16.pack(rng.choice((0, 1, 0x0FFF, 0x1000, 0x3FFF, 0x7FFF, 0xFFFF, _u16(rng))))
    if ado == 0x0934:
        return bytes((rng.randrange(256), rng.randrange(256)))
    if ado == 0x0980:
        return bytes((rng.randrange(256), rng.randrange(256)))
    if ado == 0x0981:
        return bytes((rng.randrange(256),))
    if ado == 0x0982:
        return _U16.pack(_u16(rng))
    return rng.randbytes(rng.choice((1, 2, 4, 8)))


DC_REGISTERS: Final = (0x0900, 0x0910, 0x0920, 0x0928, 0x0930, 0x0934, 0x0980, 0x0981)
DC_REGISTERS_MORE: Final = (0x0982, 0x0990, 0x09A0, 0x09A4, 0x09A8, 0x0936, 0x098E, 0x0918)


# (name, first register, one past the last) of datasheet section II
AREAS: Final = (
    ("identity", 0x0000, 0x0010),
    ("addresses", 0x0010, 0x0014),
    ("write protection", 0x0020, 0x0032),
    ("ESC reset", 0x0040, 0x0042),
    ("DL control", 0x0100, 0x0104),
    ("RW offset", 0x0108, 0x010A),
    ("DL status", 0x0110, 0x0112),
    ("AL", 0x0120, 0x0140),
    ("PDI", 0x0140, 0x0154),
    ("events", 0x0200, 0x0224),
    ("error counters", 0x0300, 0x0314),
    ("watchdogs", 0x0400, 0x0444),
    ("SII EEPROM", 0x0500, 0x0510),
    ("FMMUs", 0x0600, 0x0700),
    ("SyncManagers", 0x0800, 0x0880),
    ("distributed clocks", 0x0900, 0x0A00),
    ("user RAM", 0x0F80, 0x1000),
    ("process RAM", 0x1000, 0x10000),
)
# reads whose side effects are events cleared (datasheet II 0x0110, 0x0130, 0x098E)
CLEARING_READS: Final = ((0x0110, 2), (0x0130, 2), (0x0130, 6), (0x098E, 1), (0x0220, 4))


class _Generator:
    """The state a stream of hostile frames keeps: the RNG, the frames an attack queued for the
    next frames, and the logical windows and SyncManager starts hostile frames configured."""

    def __init__(self, nodes: int, seed: int) -> None:
        self.rng = random.Random(seed)
        self.nodes = nodes
        self.queue: deque[bytes] = deque()
        self.windows: list[int] = [0]
        self.starts: list[int] = [0x1000]
        self.idx = 0
        self.attacks: tuple[Callable[[], list[bytes]], ...] = (
            self._fmmu_attack,
            self._sm_attack,
            self._dc_attack,
            self._reset_attack,
            self._eeprom_attack,
            self._loop_attack,
            self._rw_offset_attack,
            self._al_attack,
            self._watchdog_attack,
            self._line_fmmu_attack,
            self._line_fmmu_attack,
            self._line_sm_attack,
            self._line_sm_attack,
            self._line_dc_attack,
        )

    # --- addresses

    def _position(self) -> int:
        """A position in the line, just beyond it, or anywhere (ADP = -position)."""
        rng = self.rng
        r = rng.random()
        if r < 0.7:
            p = rng.randrange(self.nodes)
        elif r < 0.9:
            p = self.nodes + rng.randrange(4)
        else:
            p = rng.randrange(0x10000)
        return (-p) & 0xFFFF

    def _station(self) -> int:
        """A station address a master would set (0x1001 + position), one beyond, or any."""
        rng = self.rng
        r = rng.random()
        if r < 0.7:
            return STATION_BASE + rng.randrange(self.nodes)
        if r < 0.85:
            return rng.choice((STATION_BASE + self.nodes, STATION_BASE - 1, 0, 0xFFFF))
        return rng.randrange(0x10000)

    def _adp(self, cmd: int) -> int:
        if cmd in POSITION:
            return self._position()
        if cmd in NODE:
            return self._station()
        return 0 if self.rng.random() < 0.8 else self.rng.randrange(0x10000)

    def _image_bytes(self) -> int:
        return min(MAX_DATA_BYTES, self.nodes * self.rng.choice((1, 2, 4, 8, 16, 32, 192)))

    def _logical(self) -> int:
        """A logical address near an image base or a hostile window, or any 32-bit one."""
        rng = self.rng
        r = rng.random()
        if r < 0.4:
            return rng.choice(IMAGE_BASES) + rng.randrange(-8, self._image_bytes() + 8)
        if r < 0.75:
            return rng.choice(self.windows) + rng.randrange(-8, 64)
        if r < 0.85:
            return 0xFFFF_FFFF - rng.randrange(2048)
        return rng.randrange(1 << 32)

    def _length(self, room: int) -> int:
        """A data length from 0 to ``room``, mostly short, now and then all there is."""
        rng = self.rng
        room = max(0, room)
        return min(
            room, rng.choice((0, 1, 2, 4, 8, rng.randrange(64), rng.randrange(room + 1), room))
        )

    def _next_idx(self) -> int:
        self.idx = (self.idx + 1) & 0xFF
        return self.idx

    # --- datagrams

    def _random_datagram(self, room: int) -> _Dg:
        """Any command 0-15 (now and then any byte), any address, any length and data."""
        rng = self.rng
        cmd = rng.randrange(16) if rng.random() < 0.95 else rng.randrange(256)
        n = self._length(room)
        if cmd in LOGICAL:
            address = self._logical()
        else:
            address = _address(
                self._adp(cmd), rng.choice((rng.randrange(0x10000), self._register()))
            )
        return _Dg(
            cmd,
            address,
            rng.randbytes(n),
            rng.randrange(256),
            rng.randrange(0x10000),
            rng.randrange(0x10000),
        )

    def _register(self) -> int:
        """A register address in one of the areas of datasheet section II."""
        _, lo, hi = self.rng.choice(AREAS)
        return self.rng.randrange(lo, hi)

    def _aimed_data(self, ado: int, room: int) -> bytes:
        """Data for a write at ``ado`` shaped by the register there (datasheet section II)."""
        rng = self.rng
        if 0x0600 <= ado < 0x0700 and (ado - 0x0600) % 16 == 0:
            count = rng.choice((1, 1, 2, 16 - (ado - 0x0600) // 16))
            data = b"".join(
                _fmmu_entry(rng, self.windows, self._image_bytes()) for _ in range(count)
            )
        elif 0x0800 <= ado < 0x0880 and (ado - 0x0800) % 8 == 0:
            count = rng.choice((1, 1, 2, 16 - (ado - 0x0800) // 8))
            data = b"".join(_sm_entry(rng, self.starts) for _ in range(count))
        elif ado == 0x0500:
            data = _eeprom_words(rng)[: rng.choice((1, 2, 4, 8, 16))]
        elif ado == 0x0502:
            data = _eeprom_words(rng)[2 : rng.choice((4, 8, 16))]
        elif 0x0900 <= ado < 0x0A00:
            data = _dc_block(rng, ado)
        elif ado == 0x0040:
            data = rng.choice((b"R", b"E", b"S", b"RE", b"RES", rng.randbytes(2)))
        elif ado == 0x0101:
            data = bytes((rng.randrange(256),))  # loop ports 0-3: auto, auto close, open, closed
        elif ado == 0x0120:
            state = rng.choice((1, 2, 3, 4, 8, 0, 5, 6, 7, 9, 15))
            data = _U16.pack(state | rng.choice((0, 0x10, 0x20, 0x30)) | rng.choice((0, 0, 0xFFC0)))
        elif ado in (0x0010, 0x0012, 0x0108, 0x0400, 0x0410, 0x0420):
            data = _U16.pack(rng.choice((STATION_BASE + rng.randrange(self.nodes), _u16(rng))))
        else:
            data = rng.randbytes(rng.choice((1, 2, 4, 8, rng.randrange(1, 33))))
        if rng.random() < 0.1:  # on into the next registers
            data += rng.randbytes(rng.randrange(64))
        return data[: max(0, room)]

    def _aimed_datagram(self, room: int) -> _Dg:
        """A write or read aimed at one register area of datasheet section II, by any addressing
        mode: at its registers, overlapping its start, or (process RAM) across 0xFFFF."""
        rng = self.rng
        name, lo, hi = rng.choice(AREAS)
        if name == "FMMUs":
            ado = 0x0600 + 16 * rng.randrange(16) if rng.random() < 0.8 else rng.randrange(lo, hi)
        elif name == "SyncManagers":
            ado = 0x0800 + 8 * rng.randrange(16) if rng.random() < 0.8 else rng.randrange(lo, hi)
        elif name == "distributed clocks":
            ado = rng.choice(DC_REGISTERS + DC_REGISTERS_MORE + (rng.randrange(lo, hi),))
        elif name == "process RAM":
            ado = rng.choice(
                (*self.starts[-8:], 0x1000, 0xFFFF - rng.randrange(64), rng.randrange(lo, hi))
            )
        else:
            ado = rng.choice((lo, lo, rng.randrange(lo, hi), max(0, lo - rng.randrange(1, 8))))
        if rng.random() < 0.3:  # a read: of everything, including those that clear events
            cmd = rng.choice((Cmd.APRD, Cmd.FPRD, Cmd.BRD))
            if rng.random() < 0.2:
                ado, n = rng.choice(CLEARING_READS)
            else:
                n = self._length(min(room, hi - ado + 16))
            return _Dg(cmd, _address(self._adp(cmd), ado), bytes(n), self._next_idx())
        cmd = rng.choice(WRITES)
        if name == "process RAM":
            data = rng.randbytes(self._length(room))
        else:
            data = self._aimed_data(ado, room)
        return _Dg(cmd, _address(self._adp(cmd), ado), data, self._next_idx())

    def _logical_datagram(self, room: int) -> _Dg:
        rng = self.rng
        cmd = rng.choice(LOGICAL)
        n = min(room, rng.choice((self._image_bytes(), self._length(room), 1, 2)))
        return _Dg(cmd, self._logical(), rng.randbytes(n), self._next_idx())

    # --- frames

    def _frame(self, dgs: list[_Dg], *, honest: bool = False) -> bytes:
        """The datagrams in an EtherCAT frame (Table 12), padded to 60 bytes; unless
        ``honest``, now and then with a wrong length field, wrong type, an 802.1Q tag, the
        wrong EtherType, or cut short."""
        rng = self.rng
        body = _encode(dgs)
        length = len(body)
        ecat_type = ECAT_TYPE_COMMANDS
        reserved = 0
        ethertype = ETHERTYPE_ECAT
        vlan = False
        cut: int | None = None
        if not honest:
            r = rng.random()
            if r < 0.06:  # EtherCAT length too short, too long, anything
                length = rng.choice(
                    (
                        max(0, length - rng.randrange(1, 16)),
                        length + rng.randrange(1, 64),
                        rng.randrange(2048),
                    )
                )
            elif r < 0.08:
                ecat_type = rng.choice((0, 2, 3, 4, 5, 15))
            elif r < 0.09:
                reserved = RESERVED_BIT
            r = rng.random()
            if r < 0.08:
                vlan = True
            elif r < 0.11:
                ethertype = rng.choice(WRONG_ETHERTYPES)
            elif r < 0.14:
                cut = rng.randrange(ETH_HEADER_BYTES + ECAT_HEADER_BYTES + len(body) + 1)
        header = BROADCAST_MAC + MASTER_MAC
        if vlan:  # 802.1Q: TPID 0x8100, TCI (priority 3 bits, DEI, VLAN id 12 bits)
            header += ETHERTYPE_VLAN.to_bytes(2, "big") + rng.randrange(0x10000).to_bytes(2, "big")
        header += ethertype.to_bytes(2, "big")
        ecat_header = _U16.pack((length & LENGTH_MASK) | reserved | ecat_type << TYPE_SHIFT)
        frame = header + ecat_header + body
        if len(frame) > MAX_FRAME_BYTES:  # a tag took the room of the last bytes
            frame = frame[:MAX_FRAME_BYTES]
        if cut is not None:
            return frame[:cut]
        if len(frame) < MIN_FRAME_BYTES:
            frame += bytes(MIN_FRAME_BYTES - len(frame))
        return frame

    def _one(self, dg: _Dg) -> bytes:
        return self._frame([dg], honest=True)

    def _fill(self, make: Callable[[int], _Dg], first: list[_Dg] | None = None) -> list[_Dg]:
        """Datagrams from ``make`` (given the data room left) until a draw says stop or the
        frame is full."""
        rng = self.rng
        dgs = list(first or [])
        used = sum(d.encoded_bytes() for d in dgs)
        most = rng.choice((1, 1, 2, 3, 5, 10, 200))
        while len(dgs) < most and used + DATAGRAM_OVERHEAD_BYTES <= MAX_DATAGRAMS_BYTES:
            d = make(MAX_DATAGRAMS_BYTES - used - DATAGRAM_OVERHEAD_BYTES)
            dgs.append(d)
            used += d.encoded_bytes()
        return dgs

    def random_frame(self) -> bytes:
        """Fully random datagrams: one or many, any command, any length up to 1486 bytes, or as
        many 0-byte datagrams as fit (124); M right or wrong; WKC and IRQ random."""
        rng = self.rng
        if rng.random() < 0.05:
            count = MAX_DATAGRAMS_BYTES // DATAGRAM_OVERHEAD_BYTES
            dgs = [self._random_datagram(0) for _ in range(count)]
        else:
            dgs = self._fill(
                lambda room: (
                    self._random_datagram if rng.random() < 0.6 else self._aimed_datagram
                )(room)
            )
        if rng.random() < 0.15:
            for d in dgs:
                d.more = rng.random() < 0.5
        if rng.random() < 0.1:
            d = rng.choice(dgs)
            d.length = rng.randrange(2048)
        if rng.random() < 0.05:
            rng.choice(dgs).circulating = True
        return self._frame(dgs)

    def _master_datagrams(self) -> list[_Dg]:
        """A frame a master sends (ETG.1000.6 start-up and cyclic operation), unmutated."""
        rng = self.rng
        nodes = self.nodes
        kind = rng.randrange(11)
        base = rng.choice(IMAGE_BASES)
        image = self._image_bytes()
        if kind == 0:  # the process image
            return [_Dg(rng.choice(LOGICAL), base, bytes(image), self._next_idx())]
        if kind == 1:  # AL status of each station
            per = max(1, min(nodes, MAX_DATAGRAMS_BYTES // 14))
            return [
                _Dg(Cmd.FPRD, _address(STATION_BASE + p, 0x0130), bytes(2), self._next_idx())
                for p in range(per)
            ]
        if kind == 2:  # distributed clocks: the reference clock's time to the others
            return [_Dg(Cmd.FRMW, _address(STATION_BASE, 0x0910), bytes(8), self._next_idx())]
        if kind == 3:  # the cyclic frame: image, clock, states
            return [
                _Dg(Cmd.LRW, base, bytes(image), self._next_idx()),
                _Dg(Cmd.FRMW, _address(STATION_BASE, 0x0910), bytes(8), self._next_idx()),
                _Dg(Cmd.BRD, _address(0, 0x0130), bytes(2), self._next_idx()),
            ][: rng.choice((2, 3))]
        if kind == 4:  # a master's resets
            ado, data = rng.choice(
                (
                    (0x0101, b"\x00"),
                    (0x0600, bytes(256)),
                    (0x0800, bytes(128)),
                    (0x0120, b"\x11\x00"),
                    (0x0980, b"\x00\x00"),
                    (0x0500, b"\x02"),
                    (0x0200, b"\x00\x00"),
                    (0x0300, bytes(8)),
                )
            )
            return [_Dg(Cmd.BWR, _address(0, ado), data, self._next_idx())]
        if kind == 5:  # scan: count and identify
            return [
                _Dg(Cmd.BRD, _address(0, 0x0000), bytes(2), self._next_idx()),
                _Dg(Cmd.APRD, _address(self._position(), 0x0000), bytes(10), self._next_idx()),
            ]
        if kind == 6:  # station addresses
            return [
                _Dg(
                    Cmd.APWR,
                    _address((-p) & 0xFFFF, 0x0010),
                    _U16.pack(STATION_BASE + p),
                    self._next_idx(),
                )
                for p in range(min(nodes, 100))
            ]
        if kind == 7:  # SyncManager and FMMU of one station
            st = STATION_BASE + rng.randrange(nodes)
            return [
                _Dg(
                    Cmd.FPWR,
                    _address(st, 0x0800),
                    _SM.pack(0x1000, 128, 0x26, 0, 1, 0) + _SM.pack(0x1080, 128, 0x22, 0, 1, 0),
                    self._next_idx(),
                ),
                _Dg(
                    Cmd.FPWR,
                    _address(st, 0x0818),
                    _SM.pack(0x1100, 8, 0x20, 0, 1, 0),
                    self._next_idx(),
                ),
                _Dg(
                    Cmd.FPWR,
                    _address(st, 0x0600),
                    _FMMU.pack(base + 8 * (st - STATION_BASE), 8, 0, 7, 0x1100, 0, 1, 1, bytes(3)),
                    self._next_idx(),
                ),
            ]
        if kind == 8:  # distributed clocks set-up
            st = STATION_BASE + rng.randrange(nodes)
            return [
                _Dg(Cmd.BWR, _address(0, 0x0900), bytes(4), self._next_idx()),
                _Dg(Cmd.FPRD, _address(st, 0x0900), bytes(16), self._next_idx()),
                _Dg(Cmd.FPWR, _address(st, 0x0920), bytes(8), self._next_idx()),
                _Dg(Cmd.FPWR, _address(st, 0x0928), bytes(4), self._next_idx()),
                _Dg(Cmd.BWR, _address(0, 0x0930), _U16.pack(0x1000), self._next_idx()),
                _Dg(
                    Cmd.FPWR,
                    _address(st, 0x0990),
                    _U64.pack(rng.randrange(1 << 40)),
                    self._next_idx(),
                ),
                _Dg(Cmd.FPWR, _address(st, 0x09A0), _U32.pack(1_000_000), self._next_idx()),
                _Dg(Cmd.FPWR, _address(st, 0x0981), b"\x03", self._next_idx()),
            ]
        if kind == 9:  # an SII read: command, then status and data
            st = STATION_BASE + rng.randrange(nodes)
            return [
                _Dg(
                    Cmd.FPWR,
                    _address(st, 0x0502),
                    _U16.pack(0x0100) + _U32.pack(rng.randrange(0x40)),
                    self._next_idx(),
                ),
                _Dg(Cmd.FPRD, _address(st, 0x0502), bytes(2), self._next_idx()),
                _Dg(Cmd.FPRD, _address(st, 0x0508), bytes(8), self._next_idx()),
            ]
        st = STATION_BASE + rng.randrange(nodes)  # a mailbox request and a poll of the answer
        return [
            _Dg(
                Cmd.FPWR,
                _address(st, 0x1000),
                bytes(6) + b"\x03\x00\x02\x40\x00\x10\x00" + bytes(115),
                self._next_idx(),
            ),
            _Dg(Cmd.FPRD, _address(st, 0x080D), bytes(1), self._next_idx()),
            _Dg(Cmd.FPRD, _address(st, 0x1080), bytes(128), self._next_idx()),
        ]

    def mutated_frame(self) -> bytes:
        """A master's frame, then mutated: fields of its datagrams changed (command, address,
        length field, M bit, data bits), datagrams dropped or repeated, bytes flipped."""
        rng = self.rng
        dgs = self._master_datagrams()
        for _ in range(rng.choice((1, 1, 2, 3))):
            d = rng.choice(dgs)
            m = rng.randrange(9)
            if m == 0:
                d.cmd = rng.randrange(16)
            elif m == 1:
                d.address ^= 1 << rng.randrange(32)
            elif m == 2:
                d.length = rng.choice(
                    (len(d.data) + 1, max(0, len(d.data) - 1), rng.randrange(2048), 0)
                )
            elif m == 3:
                d.more = d is dgs[-1]  # M wrong: set on the last, clear before
            elif m == 4 and d.data:
                b = bytearray(d.data)
                for _ in range(rng.randrange(1, 4)):
                    b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
                d.data = bytes(b)
            elif m == 5:
                d.data = d.data + rng.randbytes(rng.randrange(1, 64))
            elif m == 6 and len(dgs) > 1:
                dgs.remove(d)
            elif m == 7:
                dgs.append(_Dg(d.cmd, d.address, d.data, d.idx))
            else:
                d.address = _address(d.address & 0xFFFF, self._register())
        while sum(d.encoded_bytes() for d in dgs) > MAX_DATAGRAMS_BYTES:
            if len(dgs) > 1:
                dgs.pop()
            else:
                dgs[0].data = dgs[0].data[:MAX_DATA_BYTES]
        frame = self._frame(dgs)
        if rng.random() < 0.3 and len(frame) > 2 * MAC_BYTES:  # bytes flipped past the MACs
            b = bytearray(frame)
            for _ in range(rng.randrange(1, 4)):
                b[rng.randrange(12, len(b))] ^= 1 << rng.randrange(8)
            frame = bytes(b)
        return frame

    # --- configuration attacks: the first frame returned now, the rest queued

    def _write(self, ado: int, data: bytes, *, cmd: int | None = None) -> _Dg:
        rng = self.rng
        c = cmd if cmd is not None else rng.choice((Cmd.FPWR, Cmd.BWR, Cmd.APWR, Cmd.BRW, Cmd.FPRW))
        return _Dg(c, _address(self._adp(c), ado), data, self._next_idx())

    def _state(self, state: int) -> bytes:
        return self._one(_Dg(Cmd.BWR, _address(0, 0x0120), _U16.pack(state), self._next_idx()))

    def _fmmu_attack(self) -> list[bytes]:
        """Hostile FMMUs (datasheet II 0x0600), maybe SAFEOP/OP, then logical accesses
        through the windows they opened (ETG.1000.4 Table 14: LRD, LWR, LRW)."""
        rng = self.rng
        before = len(self.windows)
        first = rng.randrange(16)
        data = b"".join(
            _fmmu_entry(rng, self.windows, self._image_bytes())
            for _ in range(rng.randint(1, 16 - first))
        )
        dgs = [self._write(0x0600 + 16 * first, data)]
        if rng.random() < 0.3:  # and another slave's, in the same frame
            dgs.append(
                self._write(0x0600 + 16 * rng.randrange(16), _fmmu_entry(rng, self.windows, 64))
            )
        out = [self._frame(dgs, honest=True)]
        if rng.random() < 0.4:
            out.append(self._state(rng.choice((2, 4, 8))))
        new = self.windows[before:] or [0]
        for _ in range(rng.randint(1, 4)):
            w = rng.choice(new)
            n = min(
                MAX_DATA_BYTES,
                rng.choice((1, 2, 8, 64, self._image_bytes(), rng.randrange(MAX_DATA_BYTES + 1))),
            )
            start = (w - rng.randrange(0, 16)) & 0xFFFF_FFFF
            out.append(
                self._frame([_Dg(rng.choice(LOGICAL), start, rng.randbytes(n), self._next_idx())])
            )
        return out

    def _sm_attack(self) -> list[bytes]:
        """Hostile SyncManagers (datasheet II 0x0800), then accesses at their starts and ends:
        mailbox writes and reads, buffer writes and reads, repeat requests, AL states."""
        rng = self.rng
        before = len(self.starts)
        first = rng.randrange(16)
        data = b"".join(_sm_entry(rng, self.starts) for _ in range(rng.randint(1, 16 - first)))
        out = [self._one(self._write(0x0800 + 8 * first, data))]
        if rng.random() < 0.4:
            out.append(self._state(rng.choice((2, 4, 8))))
        for _ in range(rng.randint(1, 5)):
            start = rng.choice(self.starts[before:] or [0x1000])
            n = rng.choice((1, 2, 8, 128, 0x400, rng.randrange(MAX_DATA_BYTES + 1)))
            ado = (start + rng.choice((0, 0, n - 1, rng.randrange(-4, 4)))) & 0xFFFF
            cmd = rng.choice(
                (Cmd.FPWR, Cmd.FPRD, Cmd.BWR, Cmd.BRD, Cmd.APRW, Cmd.FPRW, Cmd.BRW, Cmd.FRMW)
            )
            n = min(n, MAX_DATA_BYTES)
            out.append(
                self._frame(
                    [_Dg(cmd, _address(self._adp(cmd), ado), rng.randbytes(n), self._next_idx())]
                )
            )
            if rng.random() < 0.2:  # toggle the repeat request of an SM (activate, bit 1)
                y = rng.randrange(16)
                out.append(
                    self._one(self._write(0x0806 + 8 * y, bytes((rng.choice((0x03, 0x01, 0x02)),))))
                )
        return out

    def _dc_attack(self) -> list[bytes]:
        """Distributed clocks (datasheet II 0x0900-0x09FF) set to extremes, the cyclic unit
        activated, then the drift compensation (FRMW 0x0910) and reads of the SYNC0 status."""
        rng = self.rng
        writes = [
            self._write(ado, _dc_block(rng, ado))
            for ado in rng.sample(DC_REGISTERS + DC_REGISTERS_MORE, rng.randint(1, 8))
        ]
        writes.append(self._write(0x0990, _U64.pack(_u64(rng))))
        writes.append(self._write(0x09A0, _U32.pack(rng.choice((0, 1, 0xFFFF_FFFF, _u32(rng))))))
        writes.append(self._write(0x0981, bytes((rng.randrange(256),))))
        out = [
            self._frame(
                writes[: rng.randint(1, len(writes))] if rng.random() < 0.3 else writes, honest=True
            )
        ]
        for _ in range(rng.randint(1, 4)):
            dgs = [
                _Dg(
                    Cmd.FRMW,
                    _address(self._station(), 0x0910),
                    bytes(rng.choice((4, 8))),
                    self._next_idx(),
                )
            ]
            if rng.random() < 0.5:
                dgs.append(
                    _Dg(
                        rng.choice((Cmd.BRD, Cmd.FPRD)),
                        _address(self._station(), 0x098E),
                        bytes(rng.choice((1, 2, 18))),
                        self._next_idx(),
                    )
                )
            out.append(self._frame(dgs))
        return out

    def _reset_attack(self) -> list[bytes]:
        """ESC reset (datasheet II 0x0040 ECAT, 0x0041 PDI): 'R', 'E', 'S' in consecutive
        frames, sometimes broken off or written to another register between."""
        rng = self.rng
        ado = rng.choice((0x0040, 0x0040, 0x0041))
        cmd = rng.choice((Cmd.BWR, Cmd.FPWR, Cmd.APWR))
        out = []
        for letter in b"RES":
            out.append(self._one(self._write(ado, bytes((letter,)), cmd=cmd)))
            if rng.random() < 0.15:
                out.append(self.random_frame())
        if rng.random() < 0.2:
            out.insert(
                rng.randrange(len(out)),
                self._one(self._write(ado, bytes((rng.randrange(256),)), cmd=cmd)),
            )
        return out

    def _eeprom_attack(self) -> list[bytes]:
        """The SII EEPROM interface (datasheet II 0x0500-0x050F): ownership to ECAT or PDI,
        then a command (read, write, reload, invalid) at an address in or beyond the EEPROM,
        then polls of the status and reads of the data in the next frames."""
        rng = self.rng
        out = [
            self._one(self._write(0x0500, bytes((rng.choice((0, 1, 2, 3)), rng.choice((0, 1))))))
        ]
        out.append(self._one(self._write(0x0502, _eeprom_words(rng)[2:8])))
        for _ in range(rng.randint(1, 3)):
            st = self._station()
            out.append(
                self._frame(
                    [
                        _Dg(Cmd.FPRD, _address(st, 0x0502), bytes(2), self._next_idx()),
                        _Dg(
                            Cmd.FPRD,
                            _address(st, 0x0508),
                            bytes(rng.choice((4, 8))),
                            self._next_idx(),
                        ),
                    ]
                )
            )
        return out

    def _loop_attack(self) -> list[bytes]:
        """DL control (datasheet II 0x0100-0x0103): loops closed or opened on some slaves
        (0x0101: two bits per port), forwarding rule and alias, then frames through the line."""
        rng = self.rng
        out = []
        for _ in range(rng.randint(1, 3)):
            cmd = rng.choice((Cmd.APWR, Cmd.FPWR, Cmd.BWR))
            ado = rng.choice((0x0100, 0x0101, 0x0101, 0x0102, 0x0103))
            out.append(self._one(self._write(ado, rng.randbytes(rng.choice((1, 2, 4))), cmd=cmd)))
        for _ in range(rng.randint(1, 3)):
            out.append(
                self._frame(
                    [
                        _Dg(
                            rng.choice((Cmd.BRD, Cmd.APRD, Cmd.BWR)),
                            _address(self._position(), rng.choice((0x0000, 0x0110, 0x0130))),
                            bytes(2),
                            self._next_idx(),
                        )
                    ]
                )
            )
        return out

    def _rw_offset_attack(self) -> list[bytes]:
        """RW offset (datasheet II 0x0108): the read/write commands' write address moved, then
        APRW/FPRW/BRW/ARMW/FRMW across the register areas."""
        rng = self.rng
        out = [self._one(self._write(0x0108, _U16.pack(_u16(rng))))]
        for _ in range(rng.randint(1, 3)):
            cmd = rng.choice((Cmd.APRW, Cmd.FPRW, Cmd.BRW, Cmd.ARMW, Cmd.FRMW))
            out.append(
                self._frame(
                    [
                        _Dg(
                            cmd,
                            _address(self._adp(cmd), self._register()),
                            rng.randbytes(self._length(64)),
                            self._next_idx(),
                        )
                    ]
                )
            )
        return out

    def _al_attack(self) -> list[bytes]:
        """AL control (datasheet II 0x0120): states requested out of order, invalid ones,
        acknowledge and identification bits; reads of AL status and status code."""
        rng = self.rng
        out = []
        for _ in range(rng.randint(1, 4)):
            state = rng.choice((1, 2, 3, 4, 8, 0, 5, 6, 7, 9, 15)) | rng.choice((0, 0x10, 0x20))
            out.append(self._one(self._write(0x0120, _U16.pack(state))))
            if rng.random() < 0.5:
                out.append(
                    self._frame(
                        [
                            _Dg(
                                Cmd.BRD,
                                _address(0, 0x0130),
                                bytes(rng.choice((2, 6))),
                                self._next_idx(),
                            )
                        ]
                    )
                )
        return out

    def _watchdog_attack(self) -> list[bytes]:
        """Watchdogs (datasheet II 0x0400-0x0443): divider and times 0, 1 or huge, then
        process-data writes that trigger them and reads of their status and counters."""
        rng = self.rng
        out = [
            self._one(
                self._write(
                    rng.choice((0x0400, 0x0410, 0x0420)),
                    _U16.pack(rng.choice((0, 1, 0xFFFF, _u16(rng)))),
                )
            )
        ]
        out.append(self._frame([self._logical_datagram(MAX_DATA_BYTES)]))
        out.append(self._frame([_Dg(Cmd.BRD, _address(0, 0x0440), bytes(4), self._next_idx())]))
        return out

    def _per_station(self, make: Callable[[int], list[_Dg]]) -> list[bytes]:
        """The datagrams ``make`` gives for each station of the line (0x1001 + position), in as
        few frames as they fit (ETG.1000.4: up to 1,498 bytes of datagrams a frame)."""
        out: list[bytes] = []
        batch: list[_Dg] = []
        used = 0
        for p in range(self.nodes):
            for d in make(STATION_BASE + p):
                if used + d.encoded_bytes() > MAX_DATAGRAMS_BYTES and batch:
                    out.append(self._frame(batch, honest=True))
                    batch, used = [], 0
                batch.append(d)
                used += d.encoded_bytes()
        if batch:
            out.append(self._frame(batch, honest=True))
        return out

    def _through_image(self, base: int, image: int) -> list[bytes]:
        """1-4 frames of logical accesses over ``image`` bytes from ``base`` (Table 14)."""
        rng = self.rng
        out = []
        for _ in range(rng.randint(1, 4)):
            start = (
                base + rng.choice((0, 0, -rng.randrange(1, 16), rng.randrange(image)))
            ) & 0xFFFF_FFFF
            n = min(
                MAX_DATA_BYTES,
                rng.choice((image, image + rng.randrange(64), rng.randrange(1, image + 1))),
            )
            dgs = [_Dg(rng.choice(LOGICAL), start, rng.randbytes(n), self._next_idx())]
            if rng.random() < 0.3 and n + 40 < MAX_DATA_BYTES:  # as a cyclic frame: DC and states
                dgs.append(
                    _Dg(Cmd.FRMW, _address(STATION_BASE, 0x0910), bytes(8), self._next_idx())
                )
                dgs.append(_Dg(Cmd.BRD, _address(0, 0x0130), bytes(2), self._next_idx()))
            out.append(self._frame(dgs))
        return out

    def _line_fmmu_attack(self) -> list[bytes]:
        """Every station its own hostile FMMUs (datasheet II 0x0600), their windows side by side
        or overlapping near an image base, then SAFEOP/OP and logical accesses over them all."""
        rng = self.rng
        base = rng.choice(IMAGE_BASES)
        stride = rng.choice((1, 2, 4, 8, 9, 16))
        image = min(MAX_DATA_BYTES, self.nodes * stride)
        entries = rng.choice((1, 1, 2, 3))
        first = rng.randrange(16 - entries + 1)

        def fmmus(station: int) -> list[_Dg]:
            p = station - STATION_BASE
            data = b""
            for _ in range(entries):
                entry = bytearray(_fmmu_entry(rng, [], stride))
                logical = base + p * stride + rng.choice((0, 0, 0, rng.randrange(-4, 5)))
                entry[0:4] = _U32.pack(logical & 0xFFFF_FFFF)
                if rng.random() < 0.7:
                    entry[4:6] = _U16.pack(rng.choice((stride, stride, stride + 1, 1)))
                data += bytes(entry)
            return [_Dg(Cmd.FPWR, _address(station, 0x0600 + 16 * first), data, self._next_idx())]

        out = self._per_station(fmmus)
        if rng.random() < 0.5:
            out.extend(self._state(s) for s in rng.choice(((2,), (2, 4), (2, 4, 8), (4,), (8,))))
        return out + self._through_image(base, image)

    def _line_sm_attack(self) -> list[bytes]:
        """Every station its own hostile SyncManagers (datasheet II 0x0800) and an FMMU onto
        them, then SAFEOP/OP, logical accesses over the line and physical ones at the SMs."""
        rng = self.rng
        base = rng.choice(IMAGE_BASES)
        stride = rng.choice((2, 8, 16, 64))
        image = min(MAX_DATA_BYTES, self.nodes * stride)
        y = rng.randrange(16)

        def sm_and_fmmu(station: int) -> list[_Dg]:
            p = station - STATION_BASE
            sm = bytearray(_sm_entry(rng, self.starts))
            if rng.random() < 0.5:
                sm[6] = 0x01  # enabled
            start = _U16.unpack_from(sm, 0)[0]
            fmmu = _FMMU.pack(
                base + p * stride, stride, 0, 7, start, 0, rng.choice((1, 2, 3)), 1, bytes(3)
            )
            return [
                _Dg(Cmd.FPWR, _address(station, 0x0800 + 8 * y), bytes(sm), self._next_idx()),
                _Dg(
                    Cmd.FPWR,
                    _address(station, 0x0600 + 16 * rng.randrange(16)),
                    fmmu,
                    self._next_idx(),
                ),
            ]

        out = self._per_station(sm_and_fmmu)
        if rng.random() < 0.5:
            out.extend(self._state(s) for s in rng.choice(((2,), (2, 4), (2, 4, 8), (4,), (8,))))
        out += self._through_image(base, image)
        start = rng.choice(self.starts[-self.nodes :])
        n = rng.choice((1, 8, 128, rng.randrange(MAX_DATA_BYTES + 1)))
        out.append(
            self._frame(
                [
                    _Dg(
                        rng.choice((Cmd.BRD, Cmd.BWR, Cmd.BRW)),
                        _address(0, start),
                        rng.randbytes(n),
                        self._next_idx(),
                    )
                ]
            )
        )
        return out

    def _line_dc_attack(self) -> list[bytes]:
        """Every station's cyclic unit (datasheet II 0x0980-0x09A7) started with extreme start
        and cycle times, then frames of the drift compensation (FRMW 0x0910) and SYNC0 status
        reads (0x098E, which clear it)."""
        rng = self.rng
        start = _u64(rng)
        cycle = rng.choice((0, 1, 10, 1000, 0xFFFF_FFFF, _u32(rng)))

        def cyclic(station: int) -> list[_Dg]:
            return [
                _Dg(Cmd.FPWR, _address(station, 0x0990), _U64.pack(start), self._next_idx()),
                _Dg(
                    Cmd.FPWR,
                    _address(station, 0x09A0),
                    _U32.pack(cycle) + _U32.pack(_u32(rng)),
                    self._next_idx(),
                ),
                _Dg(
                    Cmd.FPWR,
                    _address(station, 0x0980),
                    bytes((rng.randrange(256), rng.randrange(256))),
                    self._next_idx(),
                ),
            ]

        out = self._per_station(cyclic)
        for _ in range(rng.randint(1, 4)):
            out.append(
                self._frame(
                    [
                        _Dg(Cmd.FRMW, _address(STATION_BASE, 0x0910), bytes(8), self._next_idx()),
                        _Dg(
                            Cmd.BRD,
                            _address(0, 0x098E),
                            bytes(rng.choice((1, 2))),
                            self._next_idx(),
                        ),
                    ]
                )
            )
        return out

    def attack(self) -> bytes:
        """A configuration attack: its first frame, the rest queued for the next frames."""
        frames = self.rng.choice(self.attacks)()
        self.queue.extend(frames[1:])
        return frames[0]

    def next_frame(self) -> bytes:
        if self.queue:
            return self.queue.popleft()
        r = self.rng.random()
        if r < 1 / 3:
            return self.random_frame()
        if r < 2 / 3:
            return self.mutated_frame()
        return self.attack()


def frames(count: int, *, nodes: int, seed: int) -> Iterator[bytes]:
    """``count`` hostile EtherCAT frames (at most 1514 bytes each) for a line of ``nodes``
    slaves, the same for the same seed (:class:`random.Random`), made as they are taken."""
    if count < 0 or nodes < 1:
        raise ValueError(f"frames: count {count}, nodes {nodes} (count >= 0, nodes >= 1)")
    gen = _Generator(nodes, seed)
    for _ in range(count):
        yield gen.next_frame()
