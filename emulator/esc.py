"""What a chain of EtherCAT slave controllers does to the datagrams of a passing frame.

Addressing and working-counter rules follow ETG.1000.4 (5.4 "Addressing", Table 14) and the
Beckhoff ESC datasheet section I ("Working Counter"): each slave increments the ADP of
auto-increment and broadcast datagrams as they pass; position-addressed commands act on the slave that sees ADP 0, configured
addresses on the slave whose station address equals ADP, broadcasts on all, and logical commands
on every slave whose FMMU maps part of the datagram's logical range. A read adds 1 to the working
counter, a write 1, a read-write 3 (1 read + 2 write); ARMW/FRMW add 1 at the addressed slave
(it reads) and 1 at every other slave (it writes), also when no slave is addressed (datasheet I
Table 7); a logical read-write adds 1 for the input part and 2 for the output part, so input-only skin patches add 1 to LRD/LRW and 0 to LWR.

Each skin patch is an input-only slave: its taxel bytes are mapped by one FMMU at logical address
``logical_base + position * input_bytes``. Register reads return a small, realistic register image.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from skinframes.ethercat import Command, Datagram

__all__ = ["STATION_BASE", "ByteCopy", "DatagramEffect", "EscChain"]

STATION_BASE: Final = (
    0x1001  # configured station address of position 0 (SOEM/ethercrab use 0x1001+)
)

POSITION_CMDS: Final = frozenset({Command.APRD, Command.APWR, Command.APRW, Command.ARMW})
STATION_CMDS: Final = frozenset({Command.FPRD, Command.FPWR, Command.FPRW, Command.FRMW})
BROADCAST_CMDS: Final = frozenset({Command.BRD, Command.BWR, Command.BRW})
READS: Final = frozenset({Command.APRD, Command.FPRD, Command.BRD, Command.LRD})
WRITES: Final = frozenset({Command.APWR, Command.FPWR, Command.BWR, Command.LWR})
READ_WRITES: Final = frozenset({Command.APRW, Command.FPRW, Command.BRW, Command.LRW})

# ESC registers (ETG.1000.4 Table 31 / ESC datasheet section II) seen by register reads
REG_TYPE: Final = 0x0000
REG_STATION: Final = 0x0010
REG_AL_STATUS: Final = 0x0130
AL_OP: Final = 0x08
ESC_TYPE: Final = 0x11  # ET1100


@dataclass(frozen=True, slots=True)
class ByteCopy:
    """One slave writes ``length`` of its input bytes, from ``src``, into datagram data at ``dst``."""

    slave: int
    src: int
    dst: int
    length: int


@dataclass(frozen=True, slots=True)
class DatagramEffect:
    """What the chain does to one datagram: the returned header fields and the data written."""

    adp: int  # ADP when the datagram returns (incremented by every slave)
    wkc_increment: int
    copies: tuple[ByteCopy, ...]  # taxel bytes written (logical reads)
    constant: tuple[tuple[int, bytes], ...]  # (offset, bytes) written from registers
    slaves: tuple[int, ...]  # positions that acted on the datagram


@dataclass(frozen=True)
class EscChain:
    """n input-only skin patches in a line, each with ``input_bytes`` of taxels."""

    n: int
    input_bytes: int
    logical_base: int = 0

    def station(self, position: int) -> int:
        """Configured station address of the slave at ``position``."""
        return STATION_BASE + position

    def register(self, position: int, ado: int, length: int) -> bytes:
        """The register image of one slave from ``ado`` (zeros where not modelled)."""
        image = bytearray(max(ado + length, REG_AL_STATUS + 2))
        image[REG_TYPE] = ESC_TYPE
        image[REG_STATION : REG_STATION + 2] = self.station(position).to_bytes(2, "little")
        image[REG_AL_STATUS] = AL_OP
        return bytes(image[ado : ado + length])

    def effect(self, d: Datagram) -> DatagramEffect:
        """Apply the chain's addressing and working-counter rules to datagram ``d``."""
        n, cmd, length = self.n, d.cmd, len(d.data)
        # auto-increment and broadcast commands: every slave increments ADP as the frame passes
        counted = cmd in POSITION_CMDS or cmd in BROADCAST_CMDS
        adp_back = (d.adp + n) & 0xFFFF if counted else d.adp
        if cmd in POSITION_CMDS or cmd in STATION_CMDS:
            # position addressing: the slave at position p sees ADP + p == 0
            p = (-d.adp) & 0xFFFF if cmd in POSITION_CMDS else d.adp - STATION_BASE
            if cmd in (Command.ARMW, Command.FRMW):  # addressed slave reads, all others write
                if not 0 <= p < n:  # nobody reads, so every slave writes (+1 each)
                    return DatagramEffect(adp_back, n, (), (), tuple(range(n)))
                data = self.register(p, d.ado, length)
                return DatagramEffect(adp_back, n, (), ((0, data),), tuple(range(n)))
            if not 0 <= p < n:
                return DatagramEffect(adp_back, 0, (), (), ())
            inc = 1 if cmd in READS | WRITES else 3
            read = ((0, self.register(p, d.ado, length)),) if cmd not in WRITES else ()
            return DatagramEffect(adp_back, inc, (), read, (p,))
        if cmd in BROADCAST_CMDS:
            inc = n if cmd in (Command.BRD, Command.BWR) else 3 * n
            const: tuple[tuple[int, bytes], ...] = ()
            if cmd != Command.BWR:  # broadcast reads OR the registers of all slaves together
                merged = bytearray(length)
                for p in range(n):
                    for i, b in enumerate(self.register(p, d.ado, length)):
                        merged[i] |= b
                const = ((0, bytes(merged)),)
            return DatagramEffect(adp_back, inc, (), const, tuple(range(n)))
        if cmd in (Command.LRD, Command.LWR, Command.LRW):
            start = d.lad - self.logical_base
            first = max(0, start // self.input_bytes) if self.input_bytes else 0
            copies = []
            for p in range(first, n):
                s_lo = p * self.input_bytes
                lo, hi = max(start, s_lo), min(start + length, s_lo + self.input_bytes)
                if lo >= hi:
                    if s_lo >= start + length:
                        break
                    continue
                copies.append(ByteCopy(p, lo - s_lo, lo - start, hi - lo))
            if cmd == Command.LWR:  # input-only slaves map no outputs: a write reaches nobody
                return DatagramEffect(adp_back, 0, (), (), ())
            slaves = tuple(c.slave for c in copies)
            return DatagramEffect(adp_back, len(slaves), tuple(copies), (), slaves)
        return DatagramEffect(adp_back, 0, (), (), ())  # NOP and unknown commands
