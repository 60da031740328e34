"""What the live EPL tests share: the openPOWERLINK kit, root, and the MN's log.

The kit (../shared/tools/openpowerlink, or $OPENPOWERLINK_KIT) builds openPOWERLINK V2.7.2's
console MN and CN. Without root, iproute2 or the kit a test skips with the reason; under CI=true
it fails instead.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
KIT = Path(os.environ.get("OPENPOWERLINK_KIT", ROOT.parent / "shared" / "tools" / "openpowerlink"))
IN_CI = os.environ.get("CI", "").lower() == "true"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def missing_root() -> str | None:
    """Why no live EPL test can run here, or None."""
    if not sys.platform.startswith("linux"):
        return "live EPL tests need Linux (AF_PACKET, network namespaces)"
    if os.geteuid() != 0:
        return "needs root (network namespaces, raw sockets, the MN's real-time threads)"
    if shutil.which("ip") is None:
        return "'ip' (iproute2) is not installed"
    return None


def missing_requirement() -> str | None:
    """Why the live test against openPOWERLINK cannot run here, or None."""
    if (reason := missing_root()) is not None:
        return reason
    if not (KIT / "build").is_file():
        return f"no openPOWERLINK kit at {KIT} (set OPENPOWERLINK_KIT)"
    return None


def skip_or_fail(reason: str | None) -> None:
    """Skip with ``reason`` (fail under CI=true); nothing for None."""
    if reason is not None:
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)


def built_kit() -> Path:
    """The kit, its MN and CN built (``build``), or skip (fail under CI=true)."""
    reason = missing_requirement()
    if reason is None:
        done = subprocess.run(
            [str(KIT / "build")], capture_output=True, text=True, timeout=900, check=False
        )
        if done.returncode != 0:
            reason = (
                f"the openPOWERLINK kit's build failed: {done.stdout[-2000:]}{done.stderr[-2000:]}"
            )
    skip_or_fail(reason)
    return KIT


def operational_nodes(log: Path) -> set[int]:
    """CNs the MN's log reports OPERATIONAL (``Node=  1, NmtNodeEventNmtState
    State:NmtCsOperational``)."""
    text = log.read_text(errors="replace") if log.exists() else ""
    pattern = r"Node=\s*(\d+), NmtNodeEventNmtState State:NmtCsOperational"
    return {int(n) for n in re.findall(pattern, text)}


def stop(proc: subprocess.Popen[str], sig: int) -> tuple[str, str]:
    """Send ``sig`` to ``proc`` unless it ended; its output (killed after 30 s)."""
    if proc.poll() is None:
        proc.send_signal(sig)
    try:
        return proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate()
