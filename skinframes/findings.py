"""Findings: what a decoder or ``check`` noticed about a frame that deviates from the spec.

A finding never replaces data: the frame it belongs to still re-encodes to the bytes it came from.
"""

from __future__ import annotations

import array
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, overload

__all__ = ["Finding", "FindingList", "FrameFinding", "Severity", "error", "info", "warning"]


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


class FindingList:
    """:class:`FrameFinding` s held as columns: per finding the record index (8 bytes) and which
    distinct (finding, node) it is (4 bytes); the objects are made as they are read. A capture
    with a finding in every frame then costs 12 bytes a finding, not an object each.

    It behaves as the list ``check`` used to keep: ``append``, ``extend``/``+=``, ``len``,
    iteration, indexing, ``==`` with a sequence, ``sort(key=...)``.
    """

    __slots__ = ("_counts", "_ids", "_index", "_kinds", "_which")

    def __init__(self, items: Iterable[FrameFinding] = ()) -> None:
        self._index = array.array("q")
        self._which = array.array("i")
        self._kinds: list[tuple[Finding, int | None]] = []
        self._counts: list[int] = []  # findings of each kind
        self._ids: dict[tuple[Finding, int | None], int] = {}
        self.extend(items)

    def append(self, item: FrameFinding) -> None:
        """Add a finding at the end."""
        key = (item.finding, item.node)
        which = self._ids.get(key)
        if which is None:
            which = self._ids[key] = len(self._kinds)
            self._kinds.append(key)
            self._counts.append(0)
        self._counts[which] += 1
        self._index.append(item.index)
        self._which.append(which)

    def extend(self, items: Iterable[FrameFinding]) -> None:
        """Add findings at the end, in order."""
        for item in items:
            self.append(item)

    def __iadd__(self, items: Iterable[FrameFinding]) -> FindingList:
        self.extend(items)
        return self

    def __len__(self) -> int:
        return len(self._index)

    def _make(self, k: int) -> FrameFinding:
        finding, node = self._kinds[self._which[k]]
        return FrameFinding(self._index[k], finding, node)

    def __iter__(self) -> Iterator[FrameFinding]:
        kinds = self._kinds
        for index, which in zip(self._index, self._which, strict=True):
            finding, node = kinds[which]
            yield FrameFinding(index, finding, node)

    @overload
    def __getitem__(self, k: int) -> FrameFinding: ...
    @overload
    def __getitem__(self, k: slice) -> list[FrameFinding]: ...
    def __getitem__(self, k: int | slice) -> FrameFinding | list[FrameFinding]:
        if isinstance(k, slice):
            return [self._make(i) for i in range(*k.indices(len(self)))]
        return self._make(range(len(self))[k])

    def __eq__(self, other: object) -> bool:
        if isinstance(other, FindingList | list | tuple):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # mutable, as a list

    def __repr__(self) -> str:
        return f"FindingList({list(self)!r})"

    def sort(self, *, key: Callable[[FrameFinding], Any] | None = None) -> None:
        """Sort in place, stably (by ``key``; without one, by record index, as findings sort)."""
        if key is None:
            order = sorted(range(len(self)), key=self._index.__getitem__)
        else:
            made = list(self)
            order = sorted(range(len(made)), key=lambda i: key(made[i]))
        self._index = array.array("q", (self._index[i] for i in order))
        self._which = array.array("i", (self._which[i] for i in order))

    def count_at_least(self, floor: Severity) -> int:
        """How many are of severity ``floor`` or worse."""
        return sum(
            n for n, (f, _) in zip(self._counts, self._kinds, strict=True) if f.severity >= floor
        )

    def at_least(self, floor: Severity) -> Iterator[FrameFinding]:
        """Those of severity ``floor`` or worse, in order, one at a time."""
        return (f for f in self if f.finding.severity >= floor)
