"""What networks can exist: node counts and payload sizes each protocol allows."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from emulator.errors import TopologyError
from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL
from skinframes import ethercat, powerlink

__all__ = [
    "MAX_EMULATED_SLAVES",
    "MAX_SERVED_SLAVES",
    "MAX_SLAVES",
    "RANGES",
    "Range",
    "check_cycles",
    "check_ecat",
    "check_emulated_ecat",
    "check_epl",
    "check_served_ecat",
]

MAX_SLAVES: Final = 0xFFFF  # EtherCAT: 16-bit position addresses (ETG.1000.4)
# An emulated chain (``simulate``, ``serve``): each emulated ESC is the register-level model with
# its own 64 KiB address space, and the engine asks each one about each frame once: the bound is
# memory and set-up time (about 2 s at 1024 slaves), not the protocol.
MAX_EMULATED_SLAVES: Final = 1024
MAX_SERVED_SLAVES: Final = MAX_EMULATED_SLAVES


@dataclass(frozen=True, slots=True)
class Range:
    """The node counts and payload sizes a protocol allows, and how its messages name them."""

    protocol: str
    min_nodes: int
    max_nodes: int
    nodes_word: str
    min_bytes: int
    max_bytes: int
    bytes_word: str

    def nodes_text(self, nodes: str) -> str:
        """Why ``nodes`` (a count or ``lo..hi``) cannot be: ``EPL: 240 CNs (1..239)``."""
        return f"{self.protocol}: {nodes} {self.nodes_word} ({self.min_nodes}..{self.max_nodes})"

    def bytes_text(self, data_bytes: str) -> str:
        """Why ``data_bytes`` cannot be: ``EtherCAT: 1487 bytes per slave (1..1486)``."""
        return (
            f"{self.protocol}: {data_bytes} {self.bytes_word} ({self.min_bytes}..{self.max_bytes})"
        )


# EPL: DS 301 node ids 1..239 for CNs; PRes payload up to C_DLL_ISOCHR_MAX_PAYL (1490 bytes).
EPL_RANGE: Final = Range(
    "EPL", 1, powerlink.MAX_CN_NODE_ID, "CNs", 0, powerlink.MAX_PDO_PAYLOAD_BYTES, "payload bytes"
)
# EtherCAT: 16-bit position addresses; one datagram of one frame per slave (ETG.1000.4).
ECAT_RANGE: Final = Range(
    "EtherCAT", 1, MAX_SLAVES, "slaves", 1, ethercat.MAX_DATAGRAM_DATA_BYTES, "bytes per slave"
)
RANGES: Final = {EPL: EPL_RANGE, ECAT: ECAT_RANGE, ECAT_CLOSED_RING: ECAT_RANGE}  # per table


def _check(r: Range, nodes: int, data_bytes: int) -> None:
    if not r.min_nodes <= nodes <= r.max_nodes:
        raise TopologyError(r.nodes_text(str(nodes)))
    if not r.min_bytes <= data_bytes <= r.max_bytes:
        raise TopologyError(r.bytes_text(str(data_bytes)))


def check_epl(nodes: int, data_bytes: int) -> None:
    """EPL: 1..239 CNs (DS 301 node ids), PRes payload 0..1490 bytes (C_DLL_ISOCHR_MAX_PAYL)."""
    _check(EPL_RANGE, nodes, data_bytes)


def check_ecat(nodes: int, data_bytes: int) -> None:
    """EtherCAT: 1..65535 slaves, 1..1486 bytes per slave (one datagram in one frame)."""
    _check(ECAT_RANGE, nodes, data_bytes)


def check_served_ecat(nodes: int, data_bytes: int, samples: int, period_s: float) -> None:
    """A chain served on a live link: 1..1024 slaves of 1..1486 bytes, fed >= 1 taxel samples
    at a period > 0 s."""
    if not 1 <= nodes <= MAX_SERVED_SLAVES:
        raise TopologyError(f"served EtherCAT chain: {nodes} slaves (1..{MAX_SERVED_SLAVES})")
    check_ecat(nodes, data_bytes)
    if samples < 1:
        raise TopologyError(f"taxel feed: {samples} samples (at least 1)")
    if not period_s > 0:
        raise TopologyError(f"taxel feed: a period of {period_s} s (more than 0)")


def check_served_epl(nodes: int, data_bytes: int, samples: int, period_s: float) -> None:
    """EPL CNs served on a live link: 1..239 CNs of 1..1490 taxel bytes (the PRes payload),
    fed >= 1 taxel samples at a period > 0 s."""
    check_epl(nodes, data_bytes)
    if data_bytes < 1:
        raise TopologyError(f"served EPL CN: {data_bytes} taxel bytes (1..{EPL_RANGE.max_bytes})")
    if samples < 1:
        raise TopologyError(f"taxel feed: {samples} samples (at least 1)")
    if not period_s > 0:
        raise TopologyError(f"taxel feed: a period of {period_s} s (more than 0)")


def check_emulated_ecat(nodes: int, data_bytes: int) -> None:
    """An emulated EtherCAT chain: 1..1024 slaves of 1..1486 bytes."""
    check_ecat(nodes, data_bytes)
    if nodes > MAX_EMULATED_SLAVES:
        raise TopologyError(
            f"emulated EtherCAT chain: {nodes} slaves (1..{MAX_EMULATED_SLAVES}; the analytic "
            "model takes up to 65535)"
        )


def check_cycles(cycles: int) -> None:
    """At least one cycle."""
    if cycles < 1:
        raise TopologyError(f"cycles must be >= 1, not {cycles}")
