"""Shared fixtures: golden files, tshark, the third-party captures."""

from __future__ import annotations

import os
import shutil
import signal
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# The suite checks the Python sources of the ESC path by path, standing in for functions and
# methods where it counts calls: compiled modules (emulator/esc/compiled.py) allow neither, so
# the suite and the commands it runs use the sources; test_compiled.py compares the two.
os.environ["SKINFRAMES_PURE"] = "1"

ROOT = Path(__file__).resolve().parent.parent
PCAPS = ROOT / "pcaps"
SHARED_CAPTURES = ROOT.parent / "shared" / "captures"
SHARED_ESI = ROOT.parent / "shared" / "esi"
IN_CI = os.environ.get("CI", "").lower() == "true"

settings.register_profile(
    "ci", max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "dev", max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("ci" if IN_CI else "dev")

# A shell without job control starts background commands with SIGINT ignored, and an ignored
# signal stays ignored in every child: the tests that stop a run with SIGINT would then wait for
# it in vain. The suite restores Python's own handler, which its children start with.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--update-golden",
        action="store_true",
        help="rewrite the golden files in pcaps/ instead of comparing",
    )


@pytest.fixture
def update_golden(request: pytest.FixtureRequest) -> bool:
    return bool(request.config.getoption("--update-golden"))


@pytest.fixture(scope="session")
def tshark() -> str:
    """Path of tshark; skips loudly without it, fails under CI=true."""
    path = shutil.which("tshark")
    if path is None:
        reason = (
            "tshark (Wireshark) is not installed: the Wireshark conformance tests cannot run. "
            "Install Debian's 'tshark' package (make test does so when run as root)."
        )
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    return path


@pytest.fixture(scope="session")
def shared_captures() -> Path:
    """../shared/captures; skips (fails under CI) when the folder is not beside the project."""
    if not SHARED_CAPTURES.is_dir():
        reason = f"{SHARED_CAPTURES} not found: the third-party captures are not beside the project"
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    return SHARED_CAPTURES


@pytest.fixture(scope="session")
def shared_esi() -> Path:
    """../shared/esi (third-party ESI files and their SII images); skips, or fails under
    CI=true, when the folder is not beside the project."""
    if not SHARED_ESI.is_dir():
        reason = f"{SHARED_ESI} not found: the third-party ESI files are not beside the project"
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    return SHARED_ESI


def first_difference(a: bytes, b: bytes) -> int:
    """Index of the first differing byte (or the shorter length)."""
    for i, (x, y) in enumerate(zip(a, b, strict=False)):
        if x != y:
            return i
    return min(len(a), len(b))


@pytest.fixture
def golden_file(update_golden: bool) -> Callable[[str, bytes], None]:
    """Compare ``data`` with pcaps/NAME, or rewrite it under --update-golden."""

    def check(name: str, data: bytes) -> None:
        path = PCAPS / name
        if update_golden:
            path.write_bytes(data)
            return
        assert path.exists(), f"{path} missing: run pytest --update-golden and review the diff"
        want = path.read_bytes()
        if want != data:
            at = first_difference(want, data)
            pytest.fail(
                f"{name}: differs from the golden file at byte {at} "
                f"(golden {len(want)} bytes, rebuilt {len(data)}); "
                "if intended, run pytest --update-golden and review the git diff"
            )

    return check
