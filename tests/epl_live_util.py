"""What the live EPL tests share: the openPOWERLINK kit, root, and the MN's log.

The kit (../shared/tools/openpowerlink, or $OPENPOWERLINK_KIT) builds openPOWERLINK V2.7.2's
console MN and CN. Without root, iproute2 or the kit a test skips with the reason; under CI=true
it fails instead.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from live_util import read_line

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


def skinframes(*args: str) -> subprocess.CompletedProcess[str]:
    """``python -m skinframes ARGS`` of this checkout, its output captured."""
    return subprocess.run(
        [sys.executable, "-m", "skinframes", *args],
        cwd=ROOT,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def skinframes_in_netns(netns: str, *args: str) -> subprocess.Popen[str]:
    """``python -m skinframes ARGS`` of this checkout inside ``netns``, its stdout and stderr
    piped."""
    return subprocess.Popen(
        [*("ip", "netns", "exec", netns, sys.executable, "-m", "skinframes"), *args],
        cwd=ROOT,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def serve_epl(net: Any, serve_args: list[str]) -> subprocess.Popen[str]:
    """``skinframes serve epl --iface`` the slave end of ``net`` (a veth pair in a namespace)
    with ``serve_args``, once it says it is serving."""
    serve = skinframes_in_netns(net.netns, "serve", "epl", "--iface", net.slave, *serve_args)
    try:
        read_line(serve.stderr, "serving", 60)
    except BaseException:
        stop(serve, signal.SIGINT)
        raise
    return serve


@dataclass(frozen=True)
class ServeRun:
    """What a run of the MN against ``serve epl`` left: the seconds until every CN was
    OPERATIONAL (the MN's log), the MN's log when serve was stopped, serve's exit and output."""

    took_s: float
    log: str
    returncode: int
    out: str
    err: str


def mn_drives_serve(
    kit: Path,
    net: Any,
    serve_args: list[str],
    *,
    cdc: Path,
    mn_log: Path,
    ids: list[int],
    within_s: float,
    run_s: float,
) -> ServeRun:
    """``serve epl --iface`` the slave end of ``net`` (a veth pair in a namespace) with
    ``serve_args``, then the kit's MN with ``cdc`` on the other end; fails unless the MN reports
    every CN of ``ids`` OPERATIONAL within ``within_s``; keeps cycling ``run_s`` more; stops
    serve (SIGINT) and then the MN."""
    serve = serve_epl(net, serve_args)
    mn = None
    try:
        mn = subprocess.Popen(
            [
                *(str(kit / "run-node"), "mn", net.master, "--netns", net.netns),
                *("--cdc", str(cdc), "--log", str(mn_log)),
            ],
            text=True,
        )
        started = time.monotonic()
        while operational_nodes(mn_log) < set(ids):
            assert mn.poll() is None, mn_log.read_text(errors="replace")[-3000:]
            if time.monotonic() - started > within_s:
                pytest.fail(
                    f"OPERATIONAL after {within_s} s: only {sorted(operational_nodes(mn_log))}\n"
                    + mn_log.read_text(errors="replace")[-3000:]
                )
            time.sleep(0.2)
        took_s = time.monotonic() - started
        time.sleep(run_s)
        # the log until serve stops: its CNs then fall silent, and the MN reports that
        log = mn_log.read_text(errors="replace")
    finally:  # serve first: its CNs would leave OPERATIONAL once the MN's SoCs stop
        out, err = stop(serve, signal.SIGINT)
        if mn is not None:
            stop(mn, signal.SIGTERM)
    return ServeRun(took_s, log, serve.returncode, out, err)


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


@contextlib.contextmanager
def opl_cns(kit: Path, ids: list[int], logs: Path) -> Iterator[tuple[str, str]]:
    """The real openPOWERLINK CNs ``ids`` (the kit's ``run-node cn``, each logging to
    ``logs/cnN.log``) on one link: a private network namespace with a bridge, one veth pair per
    CN and one for the MN; yields the namespace and the MN's interface. Everything is stopped
    and deleted on the way out."""
    netns = f"mn-{os.getpid()}-{secrets.token_hex(3)}"
    _ip("netns", "add", netns)
    cns: list[subprocess.Popen[str]] = []
    try:
        _ip("-n", netns, "link", "add", "mnbr", "type", "bridge")
        _ip("-n", netns, "link", "set", "mnbr", "up")
        subprocess.run(
            ["ip", "netns", "exec", netns, "sysctl", "-qw", "net.ipv6.conf.all.disable_ipv6=1"],
            check=False,
            timeout=30,
        )
        for name in ["mnm0", *(f"mnc{n}" for n in ids)]:
            _ip("-n", netns, "link", "add", name, "type", "veth", "peer", "name", name + "p")
            _ip("-n", netns, "link", "set", name + "p", "master", "mnbr")
            for dev in (name + "p", name):
                _ip("-n", netns, "link", "set", dev, "up")
        for n in ids:
            cns.append(
                subprocess.Popen(
                    [
                        *(str(kit / "run-node"), "cn", f"mnc{n}", "--netns", netns),
                        *("--node-id", str(n), "--log", str(logs / f"cn{n}.log")),
                    ],
                    text=True,
                )
            )
        time.sleep(1.0)  # the CNs open their interfaces
        yield netns, "mnm0"
    finally:
        for cn in cns:
            stop(cn, signal.SIGTERM)
        subprocess.run(["ip", "netns", "del", netns], check=False, timeout=30)
