"""The emulator's branch of the skinframes error tree::

skinframes.errors.SkinframesError
└── EmulatorError
    ├── TopologyError(…, ValueError)   impossible network: 0 nodes, > 239 CNs, bad layout
    │   ├── PresetError                unknown preset, table or model name
    │   ├── FaultError                 a fault SPEC that cannot be parsed or does not fit the network
    │   └── PayloadError               given taxels/payloads of the wrong shape or type
    ├── ScheduleError                  frames would overlap, marks a classic pcap cannot carry
    ├── LinkError                      live link: no such interface, no privileges, ip failed
    └── SdoAbortError                  an emulated EPL CN refuses an SDO access (abort code)
"""

from __future__ import annotations

from skinframes.errors import SkinframesError

__all__ = [
    "EmulatorError",
    "FaultError",
    "LinkError",
    "PayloadError",
    "PresetError",
    "ScheduleError",
    "SdoAbortError",
    "TopologyError",
]


class EmulatorError(SkinframesError):
    """Root of the emulator's errors."""


class TopologyError(EmulatorError, ValueError):
    """The requested network cannot exist (node count, payload size, layout, preset)."""


class PresetError(TopologyError):
    """An unknown preset, table or model name (a TopologyError, as it was before 0.x split it)."""


class FaultError(TopologyError):
    """A fault SPEC that cannot be parsed, or names a link or node the network does not have."""


class PayloadError(TopologyError):
    """Given taxels or payloads of the wrong shape or dtype for the network."""


class ScheduleError(EmulatorError):
    """The emulated timeline broke a physical rule (overlapping frames on one link direction)."""


class LinkError(EmulatorError):
    """The live link cannot be set up: no such interface, no privileges, ``ip`` failed."""


class SdoAbortError(EmulatorError):
    """An emulated EPL CN refuses an SDO access; ``code`` is the DS 301 abort code (Table 58).

    Never escapes a served node: the SDO server answers it as an aborted transfer.
    """

    def __init__(self, code: int, message: str) -> None:
        super().__init__(f"{message} (SDO abort {code:#010x})")
        self.code = code
