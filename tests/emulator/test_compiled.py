"""The ESC's busiest modules compiled (emulator/esc/compiled.py) answer as their sources do.

The suite runs the Python sources (tests/conftest.py). Here two processes, one on the compiled
modules and one on the sources, answer the same hostile frames at 160 ESCs, with the master's
resets between them and the slaves' firmware after each: every answer, every dropped frame and
the ESCs' memory at the end must be the same; and the timing engine's EtherCAT runs (the
master's start-up through every ESC, a closed ring) must write the same pcaps. Without a
compiled build (no C compiler) these skip with the reason; under CI=true, where ``make test``
builds it, they fail instead.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from emulator.esc import compiled

ROOT = Path(__file__).resolve().parents[2]
IN_CI = os.environ.get("CI", "").lower() == "true"

# one process: answer the hostile frames, print a digest of the answers and of the memory after
ANSWER = """
import hashlib, sys
from emulator.esc import compiled
from emulator.esc.chain import EcatChain
from emulator.hostile import hostile_frames, master_reset_frames
nodes, size, count, seed = (int(x) for x in sys.argv[1:5])
print("compiled" if compiled.in_use() else "python")
chain = EcatChain.configured(nodes, size)
reset = master_reset_frames(nodes)
digest, dropped = hashlib.sha256(), 0
for i, frame in enumerate(hostile_frames(count, nodes=nodes, input_bytes=size, seed=seed)):
    if i % 400 == 399:  # reopen what the hostile frames closed, as a master would
        for r in reset:
            chain.answer(r)
            chain.run_firmware()
    back = chain.answer(frame)
    chain.run_firmware()
    dropped += back is None
    digest.update(b"dropped" if back is None else back)
digest.update(chain.memory.tobytes())
print(dropped, digest.hexdigest())
"""


FOUND = "from emulator.esc import compiled; print(compiled.folder())"
NOT_BUILT = (
    "no compiled ESC modules for these sources (python -m emulator.esc.build; make builds them)"
)


def python(code: str, *args: str, pure: bool) -> str:
    """What ``code`` prints, run by this Python on the sources (``pure``) or the compiled ESC."""
    env = {k: v for k, v in os.environ.items() if k != compiled.PURE_ENV}
    if pure:
        env[compiled.PURE_ENV] = "1"
    done = subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def require_build() -> None:
    """Skip with the reason where nothing is compiled for these sources; under CI=true, fail."""
    if python(FOUND, pure=False).strip() == "None":
        if IN_CI:
            pytest.fail(NOT_BUILT)
        pytest.skip(NOT_BUILT)


def answers(pure: bool, seed: int, count: int) -> list[str]:
    return python(ANSWER, "160", "8", str(count), str(seed), pure=pure).split()


def test_the_sources_are_what_the_suite_runs() -> None:
    assert os.environ.get(compiled.PURE_ENV) == "1"
    assert compiled.folder() is None
    assert not compiled.in_use()


@pytest.mark.parametrize("seed", [0, 7])
def test_compiled_escs_answer_hostile_frames_as_their_sources_do(seed: int) -> None:
    require_build()
    fast = answers(pure=False, seed=seed, count=6000)
    slow = answers(pure=True, seed=seed, count=6000)
    assert fast[0] == "compiled" and slow[0] == "python"
    assert int(slow[1]) > 0  # the chain dropped frames as a real one does (the stream bites)
    assert fast[1:] == slow[1:]


# one process: the timing engine's EtherCAT cycles at 160 patches, each run's pcap digested
ENGINE = """
import hashlib, sys
from emulator import WIRE, simulate_ecat
from emulator.esc import compiled
print("compiled" if compiled.in_use() else "python")
pcap = sys.argv[1]
for kw in (
    dict(layout="per-slave", startup=True),  # the master's start-up through every ESC first
    dict(layout="logical", closed_ring=True, every_cycle=True),
):
    simulate_ecat(160, 192, WIRE, cycles=3, pcap=pcap, fast=False, **kw)
    with open(pcap, "rb") as written:
        print(hashlib.sha256(written.read()).hexdigest())
"""


def test_compiled_escs_give_the_timing_engine_the_frames_their_sources_give(
    tmp_path: Path,
) -> None:
    require_build()
    fast = python(ENGINE, str(tmp_path / "fast.pcap"), pure=False).split()
    slow = python(ENGINE, str(tmp_path / "slow.pcap"), pure=True).split()
    assert fast[0] == "compiled" and slow[0] == "python"
    assert fast[1:] == slow[1:] and len(slow) == 3


def test_an_edited_source_runs_as_python_until_compiled_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    sources = tmp_path / "emulator"
    (sources / "esc").mkdir(parents=True)
    for name in ("mapping.py", "esc/mapping.py"):  # (any source of the packages will do)
        (sources / name).write_text("X = 1\n")
    monkeypatch.setattr(compiled, "PACKAGES", (sources,))
    monkeypatch.setattr(compiled, "COMPILED", tmp_path / "_compiled")
    monkeypatch.delenv(compiled.PURE_ENV)
    assert compiled.folder() is None  # nothing compiled
    made = tmp_path / "_compiled" / compiled.source_digest()
    made.mkdir(parents=True)
    assert compiled.folder() == made
    monkeypatch.setenv(compiled.PURE_ENV, "1")
    assert compiled.folder() is None  # the sources, whatever is compiled
    monkeypatch.delenv(compiled.PURE_ENV)
    (sources / "mapping.py").write_text("X = 2\n")
    assert compiled.folder() is None  # an edited source: not what was compiled
    (sources / "mapping.py").write_text("X = 1\n")
    assert compiled.folder() == made
    (sources / "esc" / "new.py").write_text("X = 1\n")
    assert compiled.folder() is None  # a new source too


def test_the_build_says_in_one_line_why_the_escs_run_as_python(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    sources = tmp_path / "emulator"
    sources.mkdir()
    (sources / "chain.py").write_text("X = 1\n")
    monkeypatch.setattr(compiled, "PACKAGES", (sources,))
    monkeypatch.setattr(compiled, "COMPILED", tmp_path / "_compiled")

    def failing() -> Path:
        print("emulator/esc/chain.py:958: warning: Treating generator comprehension as list")
        raise SystemExit("error: command '/bin/false' failed with exit code 1")

    monkeypatch.setattr(compiled, "build", failing)
    assert compiled.main() == 1
    said = capsys.readouterr().out.splitlines()
    assert said[0].startswith(
        "compiling al, chain, commands, device, dl, eeprom, mapping, syncmanagers, together, write_plans"
    )
    assert said[1].endswith("warning: Treating generator comprehension as list")  # mypyc's
    assert said[2:] == [
        "emulator.esc.compiled: not compiled (SystemExit: error: command '/bin/false' failed "
        "with exit code 1); the ESCs run as Python"
    ]

    def interrupted() -> Path:
        print("a remark nobody needs")
        raise KeyboardInterrupt

    monkeypatch.setattr(compiled, "build", interrupted)
    assert compiled.main() == 130
    said = capsys.readouterr().out.splitlines()
    assert said[1:] == ["emulator.esc.compiled: interrupted; the ESCs run as Python"]

    (tmp_path / "_compiled" / compiled.source_digest()).mkdir(parents=True)
    assert compiled.main() == 0  # built: nothing to do, nothing said
    assert capsys.readouterr().out == ""
