"""DL control and DL status of ESCs (datasheet I 3.1, II 2.4), over rows of their memory: where
port 1 sends a processed frame by the loop setting and the port's link
(:func:`port1_forwarding`), and DL status 0x0110 with its event (:func:`dl_status`).

Each ESC's port 1 link and whether its PDI is operational (the EEPROM's load,
:mod:`emulator.esc.eeprom`) are the caller's; what DL control 0x0100 takes of a write is
:mod:`emulator.esc.write_plans`'s.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.esc.registers import (
    DL_ENHANCED_LINK,
    DL_PDI_OPERATIONAL,
    DL_PORT0,
    DL_PORT1_CLOSED,
    DL_PORT1_LINK,
    DL_PORTS_2_3_CLOSED,
    ENHANCED_LINK_BITS,
    EVENT_DL_STATUS,
    REG_DL_CONTROL,
    REG_DL_STATUS,
    REG_ECAT_EVENT,
    REG_PDI_CONTROL,
)

__all__ = ["dl_status", "port1_forwarding"]

_Rows = npt.NDArray[np.intp]


def port1_forwarding(setting: int, link: bool) -> bool | None:
    """Where port 1 sends a processed frame under DL control bits 10-11 ``setting`` (datasheet
    II 2.4.1) and the port's ``link``: on (True), back towards the master (False, the loop is
    closed) or nowhere (None: forced open without a link, the frame is lost)."""
    if setting == 0x03:  # closed
        return False
    if setting == 0x02:  # open, whatever the link
        return True if link else None
    return link  # auto, auto close: open with a link


# port1_forwarding by DL control bits 10-11 and the port 1 link (False, True): one lookup an ESC
_FORWARDING: Final = tuple(
    (port1_forwarding(setting, False), port1_forwarding(setting, True)) for setting in range(4)
)


def dl_status(
    memory: npt.NDArray[np.uint8],
    rows: _Rows,
    links: Sequence[bool],
    pdi_operational: Sequence[bool],
) -> tuple[list[bool | None], list[bool]]:
    """DL status 0x0110 at every row of ``memory`` (after a write of DL control, a link change,
    a load of the EEPROM), each ESC with its port 1 link of ``links`` and its PDI of
    ``pdi_operational``: from the PDI, the enhanced link detection, the port 1 link and the loop
    setting (datasheet II 2.4.3, Table 2), with the DL status event where it changed. Where
    each ESC's port 1 sends a frame (:func:`port1_forwarding`), and whether it marks the source
    MAC address of the frames it forwards (DL control bit 0, II 2.4.1)."""
    setting = ((memory[rows, REG_DL_CONTROL + 1] >> 2) & 0x03).tolist()
    marks = (memory[rows, REG_DL_CONTROL] & 0x01).astype(np.bool_).tolist()
    onwards = [_FORWARDING[s][link] for s, link in zip(setting, links, strict=True)]
    link = np.array(links, np.bool_)
    pdi = np.array(pdi_operational, np.bool_)
    closed = np.array([onward is False for onward in onwards], np.bool_)
    value = np.where(pdi, DL_PDI_OPERATIONAL, 0) | DL_PORT0 | DL_PORTS_2_3_CLOSED
    # enhanced link detection on at least one port (II 0x0110)
    value |= np.where(memory[rows, REG_PDI_CONTROL + 1] & ENHANCED_LINK_BITS, DL_ENHANCED_LINK, 0)
    value |= np.where(link, DL_PORT1_LINK, 0) | np.where(closed, DL_PORT1_CLOSED, 0)
    old = memory[rows, REG_DL_STATUS].astype(np.int64)
    old |= memory[rows, REG_DL_STATUS + 1].astype(np.int64) << 8
    differs = value != old
    changed, new = rows[differs], value[differs]
    memory[changed, REG_DL_STATUS] = new & 0xFF
    memory[changed, REG_DL_STATUS + 1] = new >> 8
    memory[changed, REG_ECAT_EVENT] |= EVENT_DL_STATUS
    return onwards, marks
