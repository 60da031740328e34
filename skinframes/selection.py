"""Which frames of a capture to show: a display filter of the few kinds ``decode`` offers.

A :class:`FrameSelection` judges a record by its frame number (Wireshark's, from 1) and by the
``decode --json`` object of it (:mod:`skinframes.describe`): its ``protocol`` and the nodes it
concerns.

Nodes, as a user of Wireshark names them:

- EPL: the node ids of the frame, ``src`` or ``dest`` (``epl.src == N || epl.dest == N``;
  EPL over UDP: the ids of the IP addresses, as Wireshark shows them). 255, the broadcast
  address, is a node id of its own.
- EtherCAT: a slave by its position on the ring, counting from 0 at the slave next to the
  master: a datagram of a position-addressed command (APRD, APWR, APRW, ARMW) whose ``adp`` is
  the slave's auto-increment address, ``-N`` modulo 2**16 (ETG.1000.4, 5.4.1: the first slave
  is addressed with 0, the second with 0xFFFF). Broadcast, logical and configured-address
  datagrams name no position.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Final

__all__ = ["POSITION_COMMANDS", "FrameSelection"]

# ETG.1000.4 table 13 (Wireshark's ecat.cmd values): the auto-increment (position) commands
POSITION_COMMANDS: Final = frozenset({"APRD", "APWR", "APRW", "ARMW"})
_ADP_SPAN: Final = 1 << 16


@dataclass(frozen=True, slots=True)
class FrameSelection:
    """Frames to show; a field left ``None`` selects every frame.

    Attributes:
        protocols: ``decode --json`` protocol names (``epl``, ``ecat``, ``can``, ``other``).
        nodes: EPL node ids / EtherCAT slave positions (see the module).
        frames: inclusive ranges of frame numbers (from 1); an end of None is open.
    """

    protocols: frozenset[str] | None = None
    nodes: frozenset[int] | None = None
    frames: tuple[tuple[int, int | None], ...] | None = None

    @property
    def active(self) -> bool:
        """Whether any frame may be left out."""
        return not (self.protocols is None and self.nodes is None and self.frames is None)

    def frame_wanted(self, frame: int) -> bool:
        """Whether frame number ``frame`` is in :attr:`frames`."""
        if self.frames is None:
            return True
        return any(lo <= frame and (hi is None or frame <= hi) for lo, hi in self.frames)

    def past_last(self, frame: int) -> bool:
        """Whether no frame from ``frame`` on can be wanted (reading may stop)."""
        if self.frames is None:
            return False
        return all(hi is not None and frame > hi for _, hi in self.frames)

    def matches(self, obj: dict[str, Any]) -> bool:
        """Whether the record described by ``obj`` (a ``decode --json`` object) is selected."""
        if not self.frame_wanted(obj["frame"]):
            return False
        if self.protocols is not None and obj["protocol"] not in self.protocols:
            return False
        return self.nodes is None or bool(self.nodes.intersection(nodes_of(obj)))


def nodes_of(obj: dict[str, Any]) -> Iterable[int]:
    """The nodes a ``decode --json`` object concerns (see the module)."""
    if obj["protocol"] == "epl":
        return [n for n in (obj.get("src"), obj.get("dest")) if isinstance(n, int)]
    if obj["protocol"] == "ecat":
        return [
            (-d["adp"]) % _ADP_SPAN
            for d in obj.get("datagrams", ())
            if d["cmd"] in POSITION_COMMANDS
        ]
    return []
