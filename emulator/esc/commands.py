"""EtherCAT commands as plain ints for the ESC's hot path, and their classes (ETG.1000.4 Table 14;
datasheet I Table 6): the values of :class:`skinframes.ethercat.Command`, stated there once."""

from __future__ import annotations

from typing import Final

from skinframes.ethercat import Command

__all__ = [
    "APRD",
    "APRW",
    "APWR",
    "ARMW",
    "AUTO_INCREMENT",
    "BRD",
    "BRW",
    "BWR",
    "CONFIGURED",
    "EVERYONE",
    "FPRD",
    "FPRW",
    "FPWR",
    "FRMW",
    "INCREMENTS",
    "LOGICAL",
    "LRD",
    "LRW",
    "LWR",
]

APRD: Final = int(Command.APRD)  # auto-increment physical read (1)
APWR: Final = int(Command.APWR)
APRW: Final = int(Command.APRW)
FPRD: Final = int(Command.FPRD)  # configured-address physical read (4)
FPWR: Final = int(Command.FPWR)
FPRW: Final = int(Command.FPRW)
BRD: Final = int(Command.BRD)  # broadcast read (7)
BWR: Final = int(Command.BWR)
BRW: Final = int(Command.BRW)
LRD: Final = int(Command.LRD)  # logical read (10)
LWR: Final = int(Command.LWR)
LRW: Final = int(Command.LRW)
ARMW: Final = int(Command.ARMW)  # auto-increment read, multiple write (13)
FRMW: Final = int(Command.FRMW)  # configured-address read, multiple write (14)

AUTO_INCREMENT: Final = frozenset({APRD, APWR, APRW})
CONFIGURED: Final = frozenset({FPRD, FPWR, FPRW})
LOGICAL: Final = frozenset({LRD, LWR, LRW})
EVERYONE: Final = frozenset({BRD, BWR, BRW, ARMW, FRMW})  # every ESC acts on them
INCREMENTS: Final = frozenset({APRD, APWR, APRW, BRD, BWR, BRW, ARMW})  # ADP + 1 at each ESC
