"""Fault injection: what can break in a skin network, written as ``--fault SPEC``.

Nodes are numbered from the master: node 0 is the master (EPL: the MN), node k is the k-th slave
or CN along the chain. Link k is the cable between node k and node k + 1; in the closed EtherCAT
ring link n joins the last slave to the master's second port. Faults start at the beginning of a
cycle and are reproducible with ``--seed``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Final

from emulator.errors import FaultError

__all__ = ["FAULT_HELP", "Fault", "check_fault_cycles", "corruption_mark", "parse_fault"]

FAULT_HELP: Final = """Fault SPECs (repeat --fault for several; nodes count from the master = 0):
  cable:K@C     the cable between node K and K+1 breaks at the start of cycle C
  power:K@C     node K loses power at the start of cycle C (both its links go down)
  biterr:J:P    every frame crossing link J (node J..J+1) is corrupted with probability P
                (FCS mismatch; the receiving port's CRC error counter counts it)
  drop:J:P      every frame crossing link J is lost with probability P
  late:K:US     node K answers late: an EPL CN starts each PRes, an EtherCAT slave passes
                each frame on, US microseconds late (beyond the receive timeout: a loss)
Probabilities use --seed. Examples: --fault cable:80@2  --fault biterr:5:0.1  --fault late:3:20"""

_PATTERNS: Final = {
    "cable": re.compile(r"^cable:(\d+)@(\d+)$"),
    "power": re.compile(r"^power:(\d+)@(\d+)$"),
    "biterr": re.compile(r"^biterr:(\d+):([0-9.eE+-]+)$"),
    "drop": re.compile(r"^drop:(\d+):([0-9.eE+-]+)$"),
    "late": re.compile(r"^late:(\d+):([0-9.eE+-]+)$"),
}


@dataclass(frozen=True, slots=True)
class Fault:
    """One fault.

    Attributes:
        kind: ``cable``, ``power``, ``biterr``, ``drop`` or ``late``.
        where: link index (cable, biterr, drop) or node number (power, late).
        cycle: first cycle affected (cable, power); 0 for the others.
        value: probability (biterr, drop) or delay in us (late); 0 otherwise.
    """

    kind: str
    where: int
    cycle: int = 0
    value: float = 0.0

    def __str__(self) -> str:
        if self.kind in ("cable", "power"):
            return f"{self.kind}:{self.where}@{self.cycle}"
        return f"{self.kind}:{self.where}:{self.value:g}"


def parse_fault(spec: str) -> Fault:
    """Parse one ``--fault`` SPEC (see :data:`FAULT_HELP`).

    Raises:
        FaultError: the SPEC is not one of the forms above.
    """
    kind = spec.split(":", 1)[0]
    pattern = _PATTERNS.get(kind)
    m = pattern.match(spec.strip()) if pattern else None
    if m is None:
        raise FaultError(f"fault {spec!r}: not a fault SPEC ('--fault help' lists them)")
    a, b = m.group(1), m.group(2)
    if kind in ("cable", "power"):
        return Fault(kind, int(a), int(b))
    try:
        value = float(b)
    except ValueError:
        raise FaultError(f"fault {spec!r}: {b!r} is not a number") from None
    if not math.isfinite(value):
        raise FaultError(f"fault {spec!r}: {b!r} is not a finite number")
    if kind in ("biterr", "drop") and not 0.0 <= value <= 1.0:
        raise FaultError(f"fault {spec!r}: probability {value} outside 0..1")
    if kind == "late" and value < 0:
        raise FaultError(f"fault {spec!r}: a node cannot answer early")
    return Fault(kind, int(a), 0, value)


def check_faults(faults: tuple[Fault, ...], nodes: int, links: int, protocol: str) -> None:
    """Raise FaultError for a fault that names a node or link the network does not have."""
    for f in faults:
        if f.kind in ("cable", "biterr", "drop") and not 0 <= f.where < links:
            raise FaultError(f"fault {f}: link {f.where} does not exist (0..{links - 1})")
        if f.kind in ("power", "late") and not 1 <= f.where <= nodes:
            raise FaultError(f"fault {f}: node {f.where} does not exist (1..{nodes})")


def check_fault_cycles(faults: tuple[Fault, ...], cycles: int) -> None:
    """Raise FaultError for a cable or power fault at a cycle a run of ``cycles`` cycles
    (0 .. cycles - 1) does not reach: it would never happen, and the run would look healthy."""
    for f in faults:
        if f.kind in ("cable", "power") and f.cycle >= cycles:
            raise FaultError(
                f"fault {f}: cycle {f.cycle} is not in the run's {cycles} cycles "
                f"(0..{cycles - 1}; --cycles more)"
            )


def corruption_mark(link: int) -> str:
    """The pcapng comment of a frame a bit error on ``link`` corrupted (both protocols)."""
    return f"skinframes: corrupted on link {link}..{link + 1} (injected bit error; FCS mismatch)"
