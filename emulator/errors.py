"""The emulator's branch of the skinframes error tree::

skinframes.errors.SkinframesError
└── EmulatorError
    ├── TopologyError(…, ValueError)   impossible network: 0 nodes, > 239 CNs, bad layout
    └── ScheduleError                  frames would overlap, time runs backwards
"""

from __future__ import annotations

from skinframes.errors import SkinframesError

__all__ = ["EmulatorError", "ScheduleError", "TopologyError"]


class EmulatorError(SkinframesError):
    """Root of the emulator's errors."""


class TopologyError(EmulatorError, ValueError):
    """The requested network cannot exist (node count, payload size, layout, preset)."""


class ScheduleError(EmulatorError):
    """The emulated timeline broke a physical rule (overlapping frames on one link direction)."""
