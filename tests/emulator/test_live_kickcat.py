"""Live: KickCAT's master brings 20 skin patches and an ESI slave to OP over veth.

KickCAT is not packaged: the test runs the master ``$KICKCAT_MASTER`` names and skips without
it (also under CI=true, which does not build KickCAT). Nothing of KickCAT is in this
repository. How the master that ran here was built (KickCAT f10386d, fetched into ``$K/src``
and built as benchmarks/bench_peer_rtt.py says, with ``-DBUILD_SIMULATION=ON``, which builds
``libkickcat.a``): its example ``examples/master/easycat/easycat_example.cc`` with three changes
made by hand -- the link timeout ``setTimeout(2ms)`` raised to 100 ms (a Python ESC answers a
21-slave frame in about 130 us, with outliers of several ms: README, Limits), the IO buffer
``io_buffer[2048]`` raised to 65536 bytes (20 patches are 3,840), and the cyclic loop after OP
replaced by a line per slave ``slave ADDRESS state STATE in BYTES out BYTES`` and ``OP
reached`` before it returns 0; compiled with ``g++ -std=c++17 -I$K/src/lib/include
-I$K/src/lib/master/include -I$K/src/lib/slave/include -I$K/src/lib/src -I<argparse> master.cc
$K/build/lib/libkickcat.a -lpthread``.

Expected values from the ESI XML (soes_linux_lan9252demo.xml: 1 input byte, 2 output bytes,
read with ElementTree in :func:`live_util.from_xml`) and the patches' size.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from live_util import from_xml, in_netns, live_net, serving

from emulator.live import VethPair

MASTER = os.environ.get("KICKCAT_MASTER", "")
PATCHES, PATCH_BYTES = 20, 192
LAN9252 = "soes_linux_lan9252demo.xml"
STATION_BASE = 1001  # KickCAT's first configured address (Bus::init: 1000 + position + 1)


@pytest.fixture(scope="module")
def net() -> Iterator[VethPair]:
    if not (MASTER and os.access(MASTER, os.X_OK)):
        pytest.skip("KICKCAT_MASTER does not name a built KickCAT master (see the docstring)")
    yield from live_net("esm")


def test_kickcat_brings_patches_and_an_esi_slave_to_op(net: VethPair, shared_esi: Path) -> None:
    x = from_xml(shared_esi / LAN9252)
    with serving(
        net,
        *("--nodes", str(PATCHES), "--bytes", str(PATCH_BYTES)),
        *("--esi", str(shared_esi / LAN9252)),
    ) as server:
        done = in_netns(net, MASTER, "-i", net.master)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert server["rc"] == 0, server["stderr"]
    slaves = re.findall(r"^slave (\d+) state (\w+) in (\d+) out (\d+)$", done.stdout, re.M)
    expected = [(STATION_BASE + p, "operational", PATCH_BYTES, 0) for p in range(PATCHES)]
    expected.append((STATION_BASE + PATCHES, "operational", x["input_bytes"], x["output_bytes"]))
    assert [(int(a), s, int(i), int(o)) for a, s, i, o in slaves] == expected
    assert "OP reached" in done.stdout
    assert server["summary"]["errors"] == 0
    print(f"\nKickCAT: {PATCHES} x {PATCH_BYTES} B + {x['type']} in OP")
