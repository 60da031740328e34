"""The ESC register map: addresses, bits, reset identity, ECAT write masks, and what a read of
registers does besides returning bytes (:func:`reads_dc`, :func:`cleared_events`).

Beckhoff ESC datasheet section II ("register description"), chapter 2, for the registers the
emulated ESC (:mod:`emulator.esc.device`) implements; section I 1.1 for the address space
(registers and user RAM 0x0000-0x0FFF, process RAM from 0x1000, 64 KiB in all).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, TypeAlias

from emulator.errors import TopologyError

__all__ = [
    "ADDRESS_SPACE",
    "DC_SYNC0_ACTIVE",
    "DEVICE_EMULATION",
    "DL_ENHANCED_LINK",
    "DL_PDI_OPERATIONAL",
    "DL_PORT0",
    "DL_PORT1_CLOSED",
    "DL_PORT1_LINK",
    "DL_PORTS_2_3_CLOSED",
    "EE_ACK_ERROR",
    "EE_CHECKSUM_ERROR",
    "EE_CMD_READ",
    "EE_CMD_RELOAD",
    "EE_CMD_WRITE",
    "EE_NOT_LOADED",
    "EE_READ_8_BYTES",
    "EE_TWO_ADDRESS_BYTES",
    "EE_WRITE_ENABLE",
    "EE_WRITE_ENABLE_ERROR",
    "ENHANCED_LINK_BITS",
    "EVENT_AL_STATUS",
    "EVENT_DL_STATUS",
    "FMMU_BYTES",
    "PROCESS_RAM",
    "REGISTER_END",
    "REG_ALIAS",
    "REG_AL_CODE",
    "REG_AL_CONTROL",
    "REG_AL_STATUS",
    "REG_DC_ACTIVATION",
    "REG_DC_ACTIVATION_STATUS",
    "REG_DC_CYCLIC_CONTROL",
    "REG_DC_DELAY",
    "REG_DC_DIFF",
    "REG_DC_DIFF_FILTER",
    "REG_DC_END",
    "REG_DC_NEXT_SYNC1",
    "REG_DC_OFFSET",
    "REG_DC_PULSE_LENGTH",
    "REG_DC_RECEIVE",
    "REG_DC_RECEIVE_PU",
    "REG_DC_SPEED_DIFF",
    "REG_DC_SPEED_FILTER",
    "REG_DC_SPEED_START",
    "REG_DC_START_TIME",
    "REG_DC_SYNC0_CYCLE",
    "REG_DC_SYNC0_STATUS",
    "REG_DC_SYNC1_CYCLE",
    "REG_DC_SYNC1_STATUS",
    "REG_DC_SYSTEM_TIME",
    "REG_DL_CONTROL",
    "REG_DL_STATUS",
    "REG_ECAT_EVENT",
    "REG_ECAT_EVENT_MASK",
    "REG_EEPROM_ADDRESS",
    "REG_EEPROM_CONFIG",
    "REG_EEPROM_CONTROL",
    "REG_EEPROM_DATA",
    "REG_EEPROM_PDI",
    "REG_ERROR_COUNTERS",
    "REG_FMMU",
    "REG_FORWARDED_ERRORS",
    "REG_PDI_CONTROL",
    "REG_PU_ERRORS",
    "REG_RESET_ECAT",
    "REG_RW_OFFSET",
    "REG_SAMPLE_TIME",
    "REG_SM",
    "REG_STATION",
    "REG_TYPE",
    "REG_WD_DIVIDER",
    "REG_WD_PD",
    "REG_WD_PDI",
    "REG_WD_STATUS",
    "SM_BYTES",
    "SM_ECAT_INTERRUPT",
    "SM_IRQ_READ",
    "SM_IRQ_WRITE",
    "SM_MAILBOX_FULL",
    "SM_NO_BUFFER",
    "SM_READ_OPEN",
    "SM_WRITE_OPEN",
    "EscConfig",
    "Memory",
    "cleared_events",
    "dc_write_masks",
    "reads_dc",
    "write_masks",
]

ADDRESS_SPACE: Final = 0x10000
# an ESC's 64 KiB: its own bytearray, or its row of the chain's array (EcatChain.memory)
Memory: TypeAlias = bytearray | memoryview
REGISTER_END: Final = 0x0F80  # registers 0x0000-0x0F7F have shadow buffers (datasheet I 3.4)
PROCESS_RAM: Final = 0x1000

# register addresses (datasheet II chapter 2)
REG_TYPE: Final = 0x0000
REG_STATION: Final = 0x0010
REG_ALIAS: Final = 0x0012
REG_RESET_ECAT: Final = 0x0040
REG_DL_CONTROL: Final = 0x0100
REG_RW_OFFSET: Final = 0x0108
REG_DL_STATUS: Final = 0x0110
REG_AL_CONTROL: Final = 0x0120
REG_AL_STATUS: Final = 0x0130
REG_AL_CODE: Final = 0x0134
REG_PDI_CONTROL: Final = 0x0140
REG_ECAT_EVENT_MASK: Final = 0x0200
REG_ECAT_EVENT: Final = 0x0210
REG_ERROR_COUNTERS: Final = 0x0300
REG_FORWARDED_ERRORS: Final = 0x0308  # forwarded RX error counter, port 0 (+ port)
REG_PU_ERRORS: Final = 0x030C  # ECAT processing unit error counter
REG_WD_DIVIDER: Final = 0x0400
REG_WD_PDI: Final = 0x0410
REG_WD_PD: Final = 0x0420
REG_WD_STATUS: Final = 0x0440
REG_EEPROM_CONFIG: Final = 0x0500
REG_EEPROM_PDI: Final = 0x0501
REG_EEPROM_CONTROL: Final = 0x0502
REG_EEPROM_ADDRESS: Final = 0x0504
REG_EEPROM_DATA: Final = 0x0508
REG_FMMU: Final = 0x0600
REG_SM: Final = 0x0800
FMMU_BYTES: Final = 16
SM_BYTES: Final = 8

# EEPROM control/status 0x0502 (datasheet I Table 45, II 2.11.3)
EE_WRITE_ENABLE: Final = 0x0001
EE_READ_8_BYTES: Final = 0x0040
EE_TWO_ADDRESS_BYTES: Final = 0x0080  # EEPROMs above 16 Kibit
EE_CHECKSUM_ERROR: Final = 0x0800
EE_NOT_LOADED: Final = 0x1000
EE_ACK_ERROR: Final = 0x2000  # missing acknowledge or invalid command
EE_WRITE_ENABLE_ERROR: Final = 0x4000
EE_CMD_READ: Final = 1
EE_CMD_WRITE: Final = 2
EE_CMD_RELOAD: Final = 4

# DL status 0x0110 bits (datasheet II 2.4.3, Table 2)
DL_PDI_OPERATIONAL: Final = 0x0003  # PDI operational, PDI watchdog reloaded
DL_ENHANCED_LINK: Final = 0x0004  # enhanced link detection activated for at least one port
# ESC configuration 0x0141: enhanced link detection, bit 1 for all ports, bits 4-7 per port
# (datasheet II 0x0141); DL status bit 2 shows it (II 0x0110), a reload keeps it (I 11.2.1)
ENHANCED_LINK_BITS: Final = 0xF2
DEVICE_EMULATION: Final = 0x01  # 0x0141 bit 0: AL status follows AL control (II 0x0141)
DL_PORT0: Final = 0x0010 | 0x0200  # port 0: link, open, communication established
DL_PORT1_LINK: Final = 0x0020 | 0x0800  # port 1: link, communication established
DL_PORT1_CLOSED: Final = 0x0400  # port 1 loop closed
DL_PORTS_2_3_CLOSED: Final = 0x1000 | 0x4000  # ports 2 and 3 not implemented: closed

# ECAT event request 0x0210 (datasheet II 2.7)
EVENT_DL_STATUS: Final = 0x0004
EVENT_AL_STATUS: Final = 0x0008

SM_ECAT_INTERRUPT: Final = 0x10  # SyncManager control 0x0804 bit 4: interrupt in 0x0210

# SyncManager status 0x0805 bits (datasheet II 2.14.4)
SM_IRQ_WRITE: Final = 0x01
SM_IRQ_READ: Final = 0x02
SM_MAILBOX_FULL: Final = 0x08
SM_NO_BUFFER: Final = 0x30
SM_READ_OPEN: Final = 0x40
SM_WRITE_OPEN: Final = 0x80


# distributed clocks 0x0900-0x09FF (datasheet II 2.19-2.22; what they do: emulator.esc.dc)
REG_DC_RECEIVE: Final = 0x0900  # receive time ports 0-3, 4 x 32 bit
REG_DC_SYSTEM_TIME: Final = 0x0910  # 64 bit
REG_DC_RECEIVE_PU: Final = 0x0918  # receive time ECAT processing unit, 64 bit
REG_DC_OFFSET: Final = 0x0920  # system time offset, 64 bit
REG_DC_DELAY: Final = 0x0928  # system time delay, 32 bit
REG_DC_DIFF: Final = 0x092C  # system time difference, sign + magnitude
REG_DC_SPEED_START: Final = 0x0930  # speed counter start, 15 bit
REG_DC_SPEED_DIFF: Final = 0x0932  # speed counter diff, signed 16 bit
REG_DC_DIFF_FILTER: Final = 0x0934  # system time difference filter depth, bits 0-3
REG_DC_SPEED_FILTER: Final = 0x0935  # speed counter filter depth, bits 0-3
REG_DC_CYCLIC_CONTROL: Final = 0x0980
REG_DC_ACTIVATION: Final = 0x0981
# its bits 0 and 1 both set: cyclic operation with SYNC0 active (datasheet II 0x0981)
DC_SYNC0_ACTIVE: Final = 0x03
REG_DC_PULSE_LENGTH: Final = 0x0982
REG_DC_ACTIVATION_STATUS: Final = 0x0984
REG_DC_SYNC0_STATUS: Final = 0x098E
REG_DC_SYNC1_STATUS: Final = 0x098F
REG_DC_START_TIME: Final = 0x0990  # write: start time; read: next SYNC0 pulse (system time)
REG_DC_NEXT_SYNC1: Final = 0x0998
REG_DC_SYNC0_CYCLE: Final = 0x09A0
REG_DC_SYNC1_CYCLE: Final = 0x09A4
REG_DC_END: Final = 0x0A00
REG_SAMPLE_TIME: Final = 0x0F80  # user RAM: system time of the sample's SYNC0 pulse (emulator)


@dataclass(frozen=True, slots=True)
class EscConfig:
    """The ESC's identity registers 0x0000-0x0009 (datasheet II 2.1).

    Defaults: an ET1100-type register set (type 0x11, revision 0, 8 FMMUs, 8 SyncManagers) with
    the full 60 KiB of process RAM the address space allows, two MII ports (port descriptor
    0x0F) and features 0x000C: bit-oriented FMMUs, distributed clocks (bit 2) of 64 bits
    (bit 3), LRW and the read-write commands supported.
    """

    esc_type: int = 0x11
    revision: int = 0x00
    build: int = 0x0000
    fmmus: int = 8
    syncmanagers: int = 8
    ram_kib: int = 60
    port_descriptor: int = 0x0F
    features: int = 0x000C  # emulator.esc.dc.DC_FEATURES

    def __post_init__(self) -> None:
        if not 1 <= self.fmmus <= 16 or not 1 <= self.syncmanagers <= 16:
            raise TopologyError("ESC: 1..16 FMMUs and SyncManagers (0x0600-0x06FF, 0x0800-0x087F)")


def dc_write_masks(masks: bytearray) -> None:
    """Set the ECAT write masks of the DC registers (datasheet II 2.20-2.22) in ``masks``.

    0x0900-0x0917 keep mask 0: writes there are events (latch, compare), handled by
    :func:`emulator.esc.dc.compare_together`, never stored.
    """

    def put(addr: int, *values: int) -> None:
        masks[addr : addr + len(values)] = bytes(values)

    put(REG_DC_OFFSET, *(0xFF,) * 8)
    put(REG_DC_DELAY, *(0xFF,) * 4)
    put(REG_DC_SPEED_START, 0xFF, 0x7F)
    put(REG_DC_DIFF_FILTER, 0x0F, 0x0F)
    # SYNC out / latch unit control; activation, whose bit 7 (debug pulse) self-clears: reads 0
    put(REG_DC_CYCLIC_CONTROL, 0x31, 0x7F)
    put(REG_DC_START_TIME, *(0xFF,) * 8)
    put(REG_DC_SYNC0_CYCLE, *(0xFF,) * 8)


def write_masks(cfg: EscConfig) -> bytes:
    """Bits of each register byte an ECAT write may change (datasheet II, "ECAT" column).

    Read-only and reserved bits keep their value on a write; the access still counts.
    """
    m = bytearray(REGISTER_END)

    def put(addr: int, *masks: int) -> None:
        m[addr : addr + len(masks)] = bytes(masks)

    put(REG_STATION, 0xFF, 0xFF)
    put(REG_DL_CONTROL, 0x03, 0xFF, 0x4F, 0x01)  # bits 0-1, 8-15, 16-19, 22, 24
    put(REG_RW_OFFSET, 0xFF, 0xFF)
    put(REG_AL_CONTROL, 0x7F, 0x00)  # state, ack, device identification, warning ack
    put(0x0138, 0x1F, 0x1F)  # RUN/ERR LED override
    put(REG_ECAT_EVENT_MASK, 0xFF, 0xFF)
    put(REG_WD_DIVIDER, 0xFF, 0xFF)
    put(REG_WD_PDI, 0xFF, 0xFF)
    put(REG_WD_PD, 0xFF, 0xFF)
    put(REG_EEPROM_CONFIG, 0x03)
    put(REG_EEPROM_CONTROL, 0x01, 0x07)  # write enable, command bits 8-10
    put(REG_EEPROM_ADDRESS, *(0xFF,) * 4)
    put(REG_EEPROM_DATA, *(0xFF,) * 8)
    fmmu = (0xFF,) * 6 + (0x07, 0x07, 0xFF, 0xFF, 0x07, 0x03, 0x01, 0, 0, 0)
    for y in range(cfg.fmmus):
        put(REG_FMMU + FMMU_BYTES * y, *fmmu)
    for y in range(cfg.syncmanagers):
        # start, length, control (bit 7 sequential mode not supported), activate bits 0,1,6,7
        put(REG_SM + SM_BYTES * y, 0xFF, 0xFF, 0xFF, 0xFF, 0x7F, 0x00, 0xC3, 0x00)
    dc_write_masks(m)
    return bytes(m)


def reads_dc(lo: int, hi: int) -> bool:
    """Whether a read of [lo, hi) reads DC registers, which run with the clock: the ESC brings
    them up to the frame's time first (:meth:`DcClock.refresh`)."""
    return lo < REG_DC_END and hi > REG_DC_RECEIVE


def cleared_events(lo: int, hi: int) -> int:
    """The ECAT event bits (0x0210) a read of registers [lo, hi) clears: DL status, AL status
    (datasheet I Table 3)."""
    dl = EVENT_DL_STATUS if lo <= REG_DL_STATUS + 1 and hi > REG_DL_STATUS else 0
    return dl | (EVENT_AL_STATUS if lo <= REG_AL_STATUS + 1 and hi > REG_AL_STATUS else 0)
