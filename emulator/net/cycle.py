"""What an engine hands the driver for one cycle: timed records at the master's port(s).

A :class:`Cycle` is one cycle as the engine walked it, frame by frame. Its records carry their
bytes (or only their lengths, when nobody asked for bytes) and say which parts change from cycle
to cycle in a steady state: the taxels the ESCs wrote or a PRes carries (``runs``) or a frame the
protocol rebuilds per cycle (the EPL SoC with its time). The periodic fast path (:mod:`emulator.net.run`) repeats
such cycles with shifted timestamps and fills only those parts.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Final

__all__ = ["FILL_FRAME", "FILL_NONE", "FILL_TAXELS", "Cycle", "Record"]

FILL_NONE: Final = 0  # the same bytes every cycle
FILL_TAXELS: Final = 1  # taxel runs of the cycle's input image (``Record.runs``)
FILL_FRAME: Final = 2  # a frame the engine rebuilds per cycle (its ``rebuild``): the EPL SoC


@dataclass(frozen=True, slots=True)
class Record:
    """One frame at a master port.

    Attributes:
        rel_ps: start of its first preamble bit, from the start of the cycle.
        port: the master's port (1: the second port of a closed EtherCAT ring).
        outbound: True for a frame the master sends.
        length: frame length as captured (no FCS).
        wire_ps: its time on the wire (preamble, padding, FCS).
        frame: the bytes, or None in a timing-only run.
        fill: FILL_NONE, FILL_TAXELS or FILL_FRAME: what changes in a steady state.
        runs: FILL_TAXELS: (offset in the frame, offset in the cycle's input image, bytes).
        node: FILL_FRAME: the node whose frame it is (-1: none, e.g. the SoC).
        mark: why a frame was deliberately corrupted (a pcapng comment), or None.
    """

    rel_ps: int
    port: int
    outbound: bool
    length: int
    wire_ps: int
    frame: bytes | None
    fill: int = FILL_NONE
    runs: tuple[tuple[int, int, int], ...] = ()
    node: int = -1
    mark: str | None = None


@dataclass(frozen=True)
class Cycle:
    """One walked cycle.

    Attributes:
        records: in time order (ties: port, sent before received).
        cycle_ps: from this cycle's start to the next one's.
        wkc: EtherCAT: the sum of the returned working counters; EPL: PRes received.
        expected_wkc: what a cycle without faults gets.
        events: what the cycle counted (lost frames, CRC errors, ...), keyed by the engine.
        steady: nothing in this cycle depended on chance or on a transition, so a later cycle
            in the same state and phase is this one shifted in time.
    """

    records: tuple[Record, ...]
    cycle_ps: int
    wkc: int
    expected_wkc: int
    events: Counter[tuple[object, ...]] = field(default_factory=Counter)
    steady: bool = True
