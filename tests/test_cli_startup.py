"""Start-up (issue 42, item 6): reading an Ethernet capture loads no more than it needs.

``decode`` and ``check`` of a small capture should finish within tshark's own start-up; most of
Python's is imports. Measured on the shared captures (same run, 5 rounds, a loaded 2-core
machine): ``decode --json`` took tshark/skinframes 0.96-1.40x before the CAN codec (and numpy
with it) was left out, 1.43-1.56x after. What is loaded is counted here, not the time.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PROBE = """
import json, sys
from skinframes_cli import main
main(sys.argv[1:])
print(json.dumps(sorted(sys.modules)), file=sys.stderr)
"""


@pytest.mark.parametrize("command", [["decode", "--json"], ["check"], ["decode"]])
def test_an_ethernet_capture_loads_neither_numpy_nor_the_can_codec(
    shared_captures: Path, command: list[str]
) -> None:
    capture = shared_captures / "epl-viz_1CN.pcapng"
    argv = [command[0], str(capture), *command[1:]]
    out = subprocess.run(
        [sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    loaded = set(json.loads(out.stderr.strip().splitlines()[-1]))
    assert "skinframes.pcap" in loaded  # the capture was read
    assert not {m for m in loaded if m == "numpy" or m.startswith("skinframes.canbus")}
