"""What the live tests (real masters over a veth pair in a private netns) share."""

from __future__ import annotations

import contextlib
import importlib.util
import itertools
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import pytest

if TYPE_CHECKING:
    from emulator.live import VethPair

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"
IN_CI = os.environ.get("CI") == "true"
CAP_NET_ADMIN, CAP_NET_RAW, CAP_SYS_ADMIN = 12, 13, 21
# serve as users run it: the ESC's busiest modules compiled where make built them (tests/conftest.py
# has the suite itself run their sources)
ENV = {**{k: v for k, v in os.environ.items() if k != "SKINFRAMES_PURE"}, "PYTHONPATH": str(ROOT)}


def missing_requirement() -> str | None:
    """Why the live tests cannot run here, or None."""
    if not sys.platform.startswith("linux"):
        return "live EtherCAT tests need Linux (AF_PACKET, network namespaces)"
    cap_eff = 0
    with open("/proc/self/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("CapEff:"):
                cap_eff = int(line.split()[1], 16)
    needed = (CAP_NET_RAW, CAP_NET_ADMIN, CAP_SYS_ADMIN)
    if os.geteuid() != 0 and not all(cap_eff >> c & 1 for c in needed):
        return "needs root or CAP_NET_RAW + CAP_NET_ADMIN + CAP_SYS_ADMIN (raw sockets, netns)"
    if shutil.which("ip") is None:
        return "'ip' (iproute2) is not installed"
    if importlib.util.find_spec("pysoem") is None:
        return "pysoem is not installed (pip install pysoem; it is in the test extra)"
    return None


def read_line(stream: Any, needle: str, timeout_s: float) -> str:
    """Read lines until one contains ``needle`` (fails after ``timeout_s``)."""
    deadline = time.monotonic() + timeout_s
    seen = []
    while time.monotonic() < deadline:
        if select.select([stream], [], [], 0.1)[0]:
            line = stream.readline()
            if not line:
                break
            seen.append(line)
            if needle in line:
                return str(line)
    pytest.fail(f"no line with {needle!r} within {timeout_s} s: {seen}")


def xml_number(text: str | None) -> int:
    s = (text or "").strip()
    return int(s[2:], 16) if s.startswith("#x") else int(s)


def from_xml(path: Path) -> dict[str, Any]:
    """What the ESI says, read with ElementTree: identity, Type text, objects, the bits of the
    default PDO assignment (PDOs with an Sm attribute) per direction."""
    root = ET.parse(path).getroot()
    device = root.find("Descriptions/Devices/Device")
    assert device is not None
    type_el = device.find("Type")
    assert type_el is not None

    def bits(tag: str) -> int:
        return sum(
            xml_number(e.findtext("BitLen"))
            for p in device.iterfind(tag)
            if p.get("Sm") is not None
            for e in p.iterfind("Entry")
        )

    return {
        "vendor_id": xml_number(root.findtext("Vendor/Id")),
        "product_code": xml_number(type_el.get("ProductCode")),
        "revision": xml_number(type_el.get("RevisionNo")),
        "type": type_el.text,
        "objects": {
            xml_number(o.findtext("Index"))
            for o in device.iterfind("Profile/Dictionary/Objects/Object")
        },
        "output_bytes": (bits("RxPdo") + 7) // 8,
        "input_bytes": (bits("TxPdo") + 7) // 8,
        "byte_size": xml_number(device.findtext("Eeprom/ByteSize")),
    }


def counts_up(values: list[int], modulo: int) -> bool:
    """Each value the one before or later (modulo), and not all equal."""
    steps = [(b - a) % modulo for a, b in itertools.pairwise(values)]
    return all(s < modulo // 2 for s in steps) and any(steps)


def samples_of_rows(
    rows: npt.NDArray[np.uint8], payloads: npt.NDArray[np.uint8], take: int | None = None
) -> list[set[int]]:
    """For each slave's row, the indices k of the published samples it equals (fails if none).
    Short rows may equal several samples: 8 bytes of 5 levels collide now and then."""
    found = []
    for p, row in enumerate(rows):
        hits = np.flatnonzero((payloads[:, p, :take] == row).all(axis=1))
        assert hits.size >= 1, f"slave {p}: {row.tobytes().hex()} is no published sample"
        found.append({int(k) for k in hits})
    return found


def sample_of_rows(
    rows: npt.NDArray[np.uint8], payloads: npt.NDArray[np.uint8], take: int | None = None
) -> list[int]:
    """For each slave's row, the index k of the published sample it equals (fails if none, or
    if several: for rows long enough that a slave's samples are distinct)."""
    found = samples_of_rows(rows, payloads, take)
    for p, ks in enumerate(found):
        assert len(ks) == 1, f"slave {p}: {rows[p].tobytes().hex()} is samples {sorted(ks)}"
    return [ks.pop() for ks in found]


def check_taxels(
    inputs: npt.NDArray[np.uint8],
    nodes: int,
    size: int,
    take: int | None = None,
    *,
    seed: int,
    samples: int,
) -> int:
    """Every cycle of ``inputs`` (the patches' rows, cycle after cycle) holds whole samples the
    patches published (``serve ecat --seed SEED --samples SAMPLES``; their first ``take``
    bytes), in time order; returns the samples seen."""
    from skinframes import taxel

    payloads = taxel.sample_payloads(nodes, samples, size, seed=seed)
    for p in range(nodes):  # each slave's samples are distinct, so matching is unambiguous
        assert len({payloads[k, p, :take].tobytes() for k in range(samples)}) == samples
    seen: set[int] = set()
    previous = None
    for cycle in inputs.reshape(-1, nodes, size if take is None else take):
        ks = sample_of_rows(cycle, payloads, take)
        steps = [(b - a) % samples for a, b in itertools.pairwise(ks)]
        # publications happen between frames: inside a cycle the sample only moves forward,
        # at most once per frame of the cycle (a few), never backwards
        assert all(s < samples // 2 for s in steps), ks
        assert sum(1 for s in steps if s) <= 3, ks
        if previous is not None:
            assert (ks[0] - previous) % samples < samples // 2
        previous = ks[-1]
        seen.update(ks)
    return len(seen)


def live_net(prefix: str) -> Iterator[VethPair]:
    """A module's veth pair in a private netns (``prefix``: its name's start), or a skip with
    the missing requirement (a failure under CI=true)."""
    from emulator.live import veth_netns

    reason = missing_requirement()
    if reason is not None:
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    with veth_netns(prefix=prefix) as pair:
        yield pair


def in_netns(net: VethPair, *cmd: str) -> subprocess.CompletedProcess[str]:
    """Run ``cmd`` (a master) in the netns of ``net`` to its end (5 minutes at most), its output
    captured as text."""
    return subprocess.run(
        ["ip", "netns", "exec", net.netns, *cmd],
        cwd=ROOT,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


@contextlib.contextmanager
def serving(net: VethPair, *args: str, period_ms: float = 2) -> Iterator[dict[str, Any]]:
    """``skinframes serve ecat ARGS --json`` on the slave end, stopped with SIGINT."""
    cmd = [
        *("ip", "netns", "exec", net.netns, sys.executable, "-m", "skinframes", "serve", "ecat"),
        *("--iface", net.slave, "--json", "--period-ms", str(period_ms), *args),
    ]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    result: dict[str, Any] = {}
    try:
        read_line(proc.stderr, "serving", 60)
        yield result
    finally:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
        result["rc"], result["stderr"] = proc.returncode, err
        if proc.returncode == 0:
            result["summary"] = json.loads(out)
