"""What the live tests (real masters over a veth pair in a private netns) share."""

from __future__ import annotations

import importlib.util
import os
import select
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import pytest

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
