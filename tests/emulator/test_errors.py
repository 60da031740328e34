"""One error class per kind: the subclasses of TopologyError name what went wrong."""

from __future__ import annotations

import numpy as np
import pytest

import emulator
from emulator import FaultError, PayloadError, PresetError, TopologyError
from emulator.net.run import MemorySink


def test_an_unknown_preset_is_a_preset_error() -> None:
    with pytest.raises(PresetError, match="unknown preset 'fibre'"):
        emulator.preset("fibre")


@pytest.mark.parametrize(
    ("spec", "nodes", "reason"),
    [
        ("cable", 4, "not a fault SPEC"),
        ("drop:1:2", 4, "outside 0..1"),
        ("late:2:1e400", 4, "not a finite number"),
        ("power:9@1", 4, "node 9"),
    ],
)
def test_a_bad_fault_is_a_fault_error(spec: str, nodes: int, reason: str) -> None:
    with pytest.raises(FaultError, match=reason):
        emulator.simulate_ecat(
            nodes, 8, emulator.PAPER, cycles=2, faults=(emulator.parse_fault(spec),)
        )


def test_payloads_of_the_wrong_shape_are_a_payload_error() -> None:
    with pytest.raises(PayloadError, match=r"expected uint8 \(2, 3, 8\)"):
        emulator.simulate_ecat(
            3,
            8,
            emulator.PAPER,
            cycles=2,
            payloads=np.zeros((2, 3, 7), np.uint8),
            sink=MemorySink(),
        )


def test_every_kind_is_still_a_topology_error_for_old_scripts() -> None:
    for kind in (PresetError, FaultError, PayloadError):
        assert issubclass(kind, TopologyError) and issubclass(kind, ValueError)
