"""Live: KickCAT's master brings 20 skin patches and an ESI slave to OP over veth.

The master is KickCAT's own, through its Python bindings (the ``kickcat`` wheel, KickCAT 2.5,
in the test extra): tests/kickcat_master.py scans the line (``Bus.init``: addresses, SII,
mailboxes, PRE-OP), uploads 0x1018:1 by SDO, maps the process data (``Bus.create_mapping``),
requests SAFE-OP then OP and runs cycles of ``Bus.process_data``, which raises on a working
counter other than the expected one. The test checks what KickCAT found and read: station
addresses, states, input and output bytes per slave, the vendor ids, the patches' inputs (whole
samples the server published, ``--seed``/``--samples``, in time order) and the ESI slave's
input byte counting up. Root (or CAP_NET_RAW, CAP_NET_ADMIN, CAP_SYS_ADMIN), iproute2 and
kickcat are needed: without them the test skips with the reason, under CI=true it fails.

Expected values from the ESI XML (soes_linux_lan9252demo.xml: vendor 0x1337, 1 input byte,
2 output bytes, read with ElementTree in :func:`live_util.from_xml`), the README's identity of a
patch and the patches' size.

``$KICKCAT_MASTER``, optional, names a master built from KickCAT's C++ sources; only when it is
set is a second test defined, which runs it and checks its report. How the one that ran here was
built (KickCAT f10386d, fetched into ``$K/src`` and built as benchmarks/bench_peer_rtt.py says,
with ``-DBUILD_SIMULATION=ON``, which builds ``libkickcat.a``): its example
``examples/master/easycat/easycat_example.cc`` with three changes made by hand -- the link
timeout ``setTimeout(2ms)`` raised to 100 ms (a Python ESC answers a 21-slave frame in about
130 us, with outliers of several ms: README, Limits), the IO buffer ``io_buffer[2048]`` raised
to 65536 bytes (20 patches are 3,840), and the cyclic loop after OP replaced by a line per slave
``slave ADDRESS state STATE in BYTES out BYTES`` and ``OP reached`` before it returns 0;
compiled with ``g++ -std=c++17 -I$K/src/lib/include -I$K/src/lib/master/include
-I$K/src/lib/slave/include -I$K/src/lib/src -I<argparse> master.cc $K/build/lib/libkickcat.a
-lpthread``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from live_util import IN_CI, TESTS, check_taxels, counts_up, from_xml, in_netns, live_net, serving

from emulator.live import VethPair

MASTER = os.environ.get("KICKCAT_MASTER", "")
PATCHES, PATCH_BYTES = 20, 192
SEED, SAMPLES = 41, 256
PATCH_VENDOR_ID = 0x534B494E  # the README's identity of a skin patch ("SKIN")
LAN9252 = "soes_linux_lan9252demo.xml"
STATION_BASE = 1001  # KickCAT's first configured address (Bus::init: 1000 + position + 1)
CYCLES = 200


@pytest.fixture(scope="module")
def net() -> Iterator[VethPair]:
    if importlib.util.find_spec("kickcat") is None:
        reason = "kickcat (KickCAT's Python bindings) is not installed; it is in the test extra"
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    yield from live_net("kc")


def expected_slaves(x: dict[str, Any]) -> list[tuple[int, str, int, int]]:
    """(station address, state, input bytes, output bytes) of every slave, in line order."""
    patches = [(STATION_BASE + p, "operational", PATCH_BYTES, 0) for p in range(PATCHES)]
    esi = (STATION_BASE + PATCHES, "operational", x["input_bytes"], x["output_bytes"])
    return [*patches, esi]


def test_kickcat_brings_patches_and_an_esi_slave_to_op(net: VethPair, shared_esi: Path) -> None:
    x = from_xml(shared_esi / LAN9252)
    with serving(
        net,
        *("--nodes", str(PATCHES), "--bytes", str(PATCH_BYTES)),
        *("--seed", str(SEED), "--samples", str(SAMPLES)),
        *("--esi", str(shared_esi / LAN9252)),
    ) as server:
        done = in_netns(
            net,
            *(sys.executable, str(TESTS / "kickcat_master.py"), net.master),
            *("--cycles", str(CYCLES), "--sdo-slaves", "0", str(PATCHES)),
        )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert server["rc"] == 0, server["stderr"]
    doc: dict[str, Any] = json.loads(done.stdout.splitlines()[-1])
    assert doc["detected"] == PATCHES + 1
    found = [(s["address"], s["state"], s["input_bytes"], s["output_bytes"]) for s in doc["slaves"]]
    assert found == expected_slaves(x)
    assert doc["vendor_ids"] == [PATCH_VENDOR_ID, x["vendor_id"]]  # SDO 0x1018:1
    assert len(doc["inputs"]) == CYCLES
    patches = np.frombuffer(
        bytes.fromhex("".join(h for row in doc["inputs"] for h in row[:PATCHES])), np.uint8
    )
    distinct = check_taxels(patches, PATCHES, PATCH_BYTES, seed=SEED, samples=SAMPLES)
    assert distinct > 1  # the samples changed while KickCAT watched
    assert x["input_bytes"] == 1
    assert counts_up([int(row[PATCHES], 16) for row in doc["inputs"]], 256)
    assert doc["init"] is True
    summary = server["summary"]
    assert (summary["dropped"], summary["errors"]) == (0, 0)
    print(
        f"\nKickCAT (wheel): {PATCHES} x {PATCH_BYTES} B + {x['type']} in OP, {distinct} "
        f"samples seen, {summary['frames_in']} frames, phases {doc['phase_s']} s"
    )


if MASTER:  # defined only on request: nothing to skip under CI, which builds no KickCAT

    def test_built_kickcat_master_brings_patches_and_an_esi_slave_to_op(
        net: VethPair, shared_esi: Path
    ) -> None:
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
        found = [(int(a), s, int(i), int(o)) for a, s, i, o in slaves]
        assert found == expected_slaves(x)
        assert "OP reached" in done.stdout
        assert server["summary"]["errors"] == 0
