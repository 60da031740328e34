"""The SII EEPROM interface of ESCs, 0x0502-0x050F, over rows of their memory (datasheet I 11,
II 2.11): the interface's state at power-on, the load of configuration area A, and the commands
ECAT writes to 0x0502 (read, write, reload).

Each ESC has its own EEPROM image (``images``, bytes the ESC keeps across a reset); what a write
of 0x0500-0x050F does at once (ownership, write enable in the same frame, the masks) is
:func:`emulator.esc.write_plans.write_special`'s, and what the ESC makes of a load (PDI
operational, DL status, the firmware starting) :mod:`emulator.esc.device`'s.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.esc.registers import (
    EE_ACK_ERROR,
    EE_CHECKSUM_ERROR,
    EE_CMD_READ,
    EE_CMD_RELOAD,
    EE_CMD_WRITE,
    EE_NOT_LOADED,
    EE_READ_8_BYTES,
    EE_TWO_ADDRESS_BYTES,
    EE_WRITE_ENABLE,
    EE_WRITE_ENABLE_ERROR,
    ENHANCED_LINK_BITS,
    REG_ALIAS,
    REG_DC_PULSE_LENGTH,
    REG_DL_CONTROL,
    REG_EEPROM_ADDRESS,
    REG_EEPROM_CONTROL,
    REG_EEPROM_DATA,
    REG_PDI_CONTROL,
)
from skinframes.sii import config_area, stated_eeprom_kibit

__all__ = [
    "config_area",
    "config_writes",
    "eeprom_read",
    "execute_commands",
    "load_config_areas",
    "power_on_interface",
]

_Rows = npt.NDArray[np.intp]

_COMMAND_BITS: Final = 0x0700  # 0x0502 bits 8-10: the command (self-clearing)


def eeprom_read(image: bytearray, word: int) -> bytearray | None:
    """The 8 bytes a read command at word address ``word`` brings from the EEPROM ``image``
    to 0x0508 (datasheet I 11.2.3; a sequential read wraps around the EEPROM's end), or None
    beyond its size, where no EEPROM answers."""
    start = 2 * word
    if start >= len(image):
        return None
    return (image[start : start + 8] + image[: max(0, start + 8 - len(image))])[:8]


def config_writes(words: tuple[int, ...]) -> tuple[tuple[int, bytes], ...]:
    """What a load of configuration area A (``words``, :func:`config_area`) writes whatever the
    registers held: PDI control 0x0140, ESC configuration A5/A6 at 0x0142, PDI configuration
    A1/A3 at 0x0150 and the SYNC pulse length A2 at 0x0982 (datasheet I 11.1, Table 42; II
    0x0982: "reset value from EEPROM word 2"); the ESC configuration byte 0x0141 keeps its link
    detection bits after the first load (the caller's)."""
    return (
        (REG_PDI_CONTROL, bytes((words[0] & 0xFF,))),
        (0x0142, struct.pack("<HB", words[5], words[6] & 0xFF)),
        (0x0150, struct.pack("<HH", words[1], words[3])),
        (REG_DC_PULSE_LENGTH, struct.pack("<H", words[2])),
    )


def _put_status(memory: npt.NDArray[np.uint8], rows: _Rows, status: npt.NDArray[np.int64]) -> None:
    """EEPROM control/status 0x0502-0x0503 of ``rows`` set to ``status`` (one word a row)."""
    memory[rows, REG_EEPROM_CONTROL] = status & 0xFF
    memory[rows, REG_EEPROM_CONTROL + 1] = status >> 8


def _status(memory: npt.NDArray[np.uint8], rows: _Rows) -> npt.NDArray[np.int64]:
    """EEPROM control/status 0x0502-0x0503 of ``rows``, one word a row."""
    status: npt.NDArray[np.int64] = memory[rows, REG_EEPROM_CONTROL].astype(np.int64)
    status |= memory[rows, REG_EEPROM_CONTROL + 1].astype(np.int64) << 8
    return status


def power_on_interface(
    images: Sequence[bytes | bytearray], memory: npt.NDArray[np.uint8], rows: _Rows
) -> None:
    """EEPROM control/status at power-on, before the load (datasheet II 0x0502): reads of 8
    bytes, not loaded yet, and two address bytes where the EEPROM (SII word 0x3E) holds more
    than 16 kibit."""
    big = [stated_eeprom_kibit(image) > 16 for image in images]
    status = EE_READ_8_BYTES | EE_NOT_LOADED
    memory[rows, REG_EEPROM_CONTROL] = status & 0xFF
    memory[rows, REG_EEPROM_CONTROL + 1] = np.where(
        np.array(big, np.bool_), (status | EE_TWO_ADDRESS_BYTES) >> 8, status >> 8
    )


def load_config_areas(
    images: Sequence[bytes | bytearray],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    *,
    first: bool,
) -> list[bool]:
    """Load ESC configuration area A (SII words 0-7, :func:`config_area`) of each EEPROM of
    ``images`` into its ESC's registers ``memory[rows]``: at power-on (``first``) and on a reload
    command (datasheet I 11.1, Table 42; II 0x0502 command 4), over the rows of the ESCs whose
    words 0-7 are alike. The EEPROM status shows the checksum's verdict; the enhanced link
    detection bits of 0x0141 and, after the first load, the station alias 0x0012 and DL control
    bit 0 keep their values. Whether each load was good: "PDI operational" (DL status bit 0,
    access to process RAM, I 11.2.1) follows it, the caller's."""
    alike: dict[bytes, list[int]] = {}
    for k, image in enumerate(images):
        alike.setdefault(bytes(image[:16]), []).append(k)
    loaded = [False] * len(images)
    for head, ks in alike.items():
        at = rows[ks]
        status = _status(memory, at)
        words = config_area(head)
        if words is None:
            status |= EE_CHECKSUM_ERROR | EE_NOT_LOADED
        else:
            status &= ~(EE_CHECKSUM_ERROR | EE_NOT_LOADED)
            kept = memory[at, REG_PDI_CONTROL + 1] & ENHANCED_LINK_BITS  # first load only
            for addr, data in config_writes(words):
                memory[at, addr : addr + len(data)] = np.frombuffer(data, np.uint8)
            esc_config = (words[0] >> 8) & 0xFF
            memory[at, REG_PDI_CONTROL + 1] = (
                esc_config if first else kept | (esc_config & ~ENHANCED_LINK_BITS)
            )
            if first:
                memory[at, REG_ALIAS] = words[4] & 0xFF
                memory[at, REG_ALIAS + 1] = words[4] >> 8
                if words[6] & 0x0002:  # A6[1]: default of DL control bit 0 is 0
                    memory[at, REG_DL_CONTROL] &= 0xFE
            for k in ks:
                loaded[k] = True
        _put_status(memory, at, status)
    return loaded


def execute_commands(
    images: Sequence[bytearray], memory: npt.NDArray[np.uint8], rows: _Rows
) -> tuple[npt.NDArray[np.bool_], list[bool]]:
    """Execute the command written to 0x0502 bits 8-10 at each ESC of ``rows`` (ECAT owns the
    interface there and wrote 0x0502; datasheet I 11.2.3), with its EEPROM of ``images``: the
    command bits and write enable self-clear, no command clears the error bits, an invalid one
    sets the acknowledge error; a read, a write or a reload (:func:`load_config_areas`). Which
    of them reloaded, and whether each reload was good."""
    control = _status(memory, rows)
    command = (control >> 8) & 0x07
    status = control & ~(_COMMAND_BITS | EE_WRITE_ENABLE)
    nothing = command == 0
    read, write = command == EE_CMD_READ, command == EE_CMD_WRITE
    reload = command == EE_CMD_RELOAD
    status = np.where(nothing, status & ~(EE_ACK_ERROR | EE_WRITE_ENABLE_ERROR), status)
    status = np.where(nothing | read | write | reload, status, status | EE_ACK_ERROR)
    if read.any():
        status[read] = _reads(
            [images[k] for k in read.nonzero()[0].tolist()], memory, rows[read], status[read]
        )
    if write.any():
        status[write] = _writes(
            [images[k] for k in write.nonzero()[0].tolist()],
            memory,
            rows[write],
            status[write],
            control[write],
        )
    _put_status(memory, rows, status)
    if not reload.any():
        return reload, []
    again = [images[k] for k in reload.nonzero()[0].tolist()]
    return reload, load_config_areas(again, memory, rows[reload], first=False)


def _writes(
    images: Sequence[bytearray],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    status: npt.NDArray[np.int64],
    control: npt.NDArray[np.int64],
) -> npt.NDArray[np.int64]:
    """The write command of :func:`execute_commands` into each EEPROM of ``images`` (memory
    ``rows``, EEPROM control as written ``control``, with the command cleared ``status``): the
    word at 0x0508 at the word address 0x0504, with write enable set in the same frame, else
    the write enable error; beyond the EEPROM the acknowledge error (datasheet I 11.2.3). The
    status is returned."""
    address = memory[rows, REG_EEPROM_ADDRESS : REG_EEPROM_ADDRESS + 4].copy().view("<u4")
    data = memory[rows, REG_EEPROM_DATA : REG_EEPROM_DATA + 2]
    status = status.copy()
    enabled = (control & EE_WRITE_ENABLE) != 0
    status[~enabled] |= EE_WRITE_ENABLE_ERROR
    for k, (image, word) in enumerate(zip(images, address[:, 0].tolist(), strict=True)):
        if not enabled[k]:
            continue
        if word >= len(image) // 2:
            status[k] |= EE_ACK_ERROR
        else:
            image[2 * word : 2 * word + 2] = data[k].tobytes()
    return status


def _reads(
    images: Sequence[bytearray],
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    status: npt.NDArray[np.int64],
) -> npt.NDArray[np.int64]:
    """The read command of :func:`execute_commands` from each EEPROM of ``images`` (memory
    ``rows``, EEPROM control and status with the command cleared ``status``): 8 bytes from the
    word address 0x0504 into 0x0508 (:func:`eeprom_read`), or the acknowledge error at an
    address beyond it (datasheet I 11.2.3), into the rows at once. The status is returned."""
    address = memory[rows, REG_EEPROM_ADDRESS : REG_EEPROM_ADDRESS + 4].copy().view("<u4")
    read: list[bytearray] = []
    beyond: list[int] = []  # no EEPROM answers beyond its size
    for k, (image, word) in enumerate(zip(images, address[:, 0].tolist(), strict=True)):
        got = eeprom_read(image, word)
        if got is None:
            beyond.append(k)
        else:
            read.append(got)
    if beyond:
        status = status.copy()
        status[beyond] |= EE_ACK_ERROR
        rows = np.delete(rows, beyond)
    data = np.frombuffer(b"".join(read), np.uint8).reshape(len(read), 8)
    memory[rows, REG_EEPROM_DATA : REG_EEPROM_DATA + 8] = data
    return status
