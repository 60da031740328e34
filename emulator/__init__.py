"""emulator: the time of robot-skin fieldbus frames (cycle-time model and virtual daisy chain).

The names here are the stable Python interface (docs/interface.md); module paths inside the
package may move while the project is 0.x. The layout: :mod:`emulator.model` (constants, the
paper's formulas, tables and plans), :mod:`emulator.esc` (the emulated EtherCAT slave controller),
:mod:`emulator.slave` (the slave behind the ESC's PDI: its EEPROM content and firmware),
:mod:`emulator.net` (one engine per protocol, the fault plan and the run's result), and here
:mod:`emulator.live` (serving an emulated chain on a real link), :mod:`emulator.compare` (one
sample on CAN, EPL and EtherCAT), :mod:`emulator.hostile` (hostile EtherCAT traffic for tests) and
:mod:`emulator.errors`.
"""

from emulator.errors import (
    EmulatorError,
    FaultError,
    LinkError,
    PayloadError,
    PresetError,
    ScheduleError,
    TopologyError,
)
from emulator.model import analytic
from emulator.model.params import PAPER, PRESETS, WIRE, TimingParams, preset
from emulator.net import simulate_ecat, simulate_epl
from emulator.net.faults import Fault, parse_fault
from emulator.net.result import CycleDetail, SimResult

__all__ = [
    "PAPER",
    "PRESETS",
    "WIRE",
    "CycleDetail",
    "EmulatorError",
    "Fault",
    "FaultError",
    "LinkError",
    "PayloadError",
    "PresetError",
    "ScheduleError",
    "SimResult",
    "TimingParams",
    "TopologyError",
    "analytic",
    "parse_fault",
    "preset",
    "simulate_ecat",
    "simulate_epl",
]
