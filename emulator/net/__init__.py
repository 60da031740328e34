"""The network, written once per protocol: engines that walk every cycle frame by frame
(:mod:`.ecat`, :mod:`.epl`, their frames in :mod:`.cycle`), the fault plan as their input
(:mod:`.faults`), a driver that streams (:mod:`.run`) into the run's result (:mod:`.result`), and
the entry points (:mod:`.api`); :mod:`.sweep` runs the engines' timing alone over many cells at
once (``tables --model emulated``). :mod:`.can_bus` arbitrates the legacy CAN bus they are compared
with."""

from emulator.net.api import simulate_ecat, simulate_epl

__all__ = ["simulate_ecat", "simulate_epl"]
