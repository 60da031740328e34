"""The emulator's branch of the skinframes error tree::

skinframes.errors.SkinframesError
└── EmulatorError
    ├── TopologyError(…, ValueError)   impossible network: 0 nodes, > 239 CNs, bad layout, fault
    ├── ScheduleError                  frames would overlap, marks a classic pcap cannot carry
    └── LinkError                      live link: no such interface, no privileges, ip failed
"""

from __future__ import annotations

from skinframes.errors import SkinframesError

__all__ = ["EmulatorError", "LinkError", "ScheduleError", "TopologyError"]


class EmulatorError(SkinframesError):
    """Root of the emulator's errors."""


class TopologyError(EmulatorError, ValueError):
    """The requested network cannot exist (node count, payload size, layout, preset)."""


class ScheduleError(EmulatorError):
    """The emulated timeline broke a physical rule (overlapping frames on one link direction)."""


class LinkError(EmulatorError):
    """The live link cannot be set up: no such interface, no privileges, ``ip`` failed."""
