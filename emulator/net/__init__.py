"""The network, written once per protocol: engines that walk every cycle frame by frame, a fault
plan as their input, and a driver that streams (:mod:`emulator.net.run`)."""

from emulator.net.api import simulate_ecat, simulate_epl

__all__ = ["simulate_ecat", "simulate_epl"]
