"""Findings: what a decoder or ``check`` noticed about a frame that deviates from the spec.

A finding never replaces data: the frame it belongs to still re-encodes to the bytes it came from.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

__all__ = ["Finding", "FrameFinding", "Severity", "error", "info", "warning"]


class Severity(IntEnum):
    """How much a finding matters; ``check`` exits 1 when any finding is an ERROR."""

    INFO = 0
    WARNING = 1
    ERROR = 2

    def __str__(self) -> str:
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class Finding:
    """One observation about one frame.

    Attributes:
        severity: INFO (legal but unusual), WARNING (deviates, still decodable), ERROR (violates the spec).
        code: a stable short identifier, e.g. ``"eth.unpadded"``, ``"epl.size.past_frame"``.
        message: the human-readable explanation with expected and found values.
    """

    severity: Severity
    code: str
    message: str

    def to_json(self) -> dict[str, str]:
        """The JSON form used by ``decode --json`` and ``check --json``."""
        return {"severity": str(self.severity), "code": self.code, "message": self.message}


def info(code: str, message: str) -> Finding:
    """An INFO finding."""
    return Finding(Severity.INFO, code, message)


def warning(code: str, message: str) -> Finding:
    """A WARNING finding."""
    return Finding(Severity.WARNING, code, message)


def error(code: str, message: str) -> Finding:
    """An ERROR finding."""
    return Finding(Severity.ERROR, code, message)


@dataclass(frozen=True, slots=True)
class FrameFinding:
    """A finding tied to a record of a capture (index -1: the file itself).

    ``index`` counts records from 0 as :class:`skinframes.pcap.Record` does; ``frame`` is
    Wireshark's 1-based frame number (0 for the file itself). ``node``: the EPL node id of the
    frame's source (None for other frames), by which ``check`` groups identical findings.
    """

    index: int
    finding: Finding
    node: int | None = None

    @property
    def frame(self) -> int:
        """Wireshark's frame number: ``index + 1`` (0 for a finding about the whole file)."""
        return self.index + 1 if self.index >= 0 else 0
