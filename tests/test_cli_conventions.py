"""The command line keeps the conventions of the tools its users know (issue "A newcomer's day",
item "Pipes and conventions"; docs/interface.md, Conventions).

Expected values come from outside the code under test: the version from pyproject.toml, the
alias's meaning from the same run under the protocol's own name, pipes from tshark reading them.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from skinframes_cli import build_parser

ROOT = Path(__file__).resolve().parent.parent


def skinframes(*argv: str, stdin: bytes | None = None) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(
        [sys.executable, "-m", "skinframes", *argv],
        input=stdin,
        capture_output=True,
        timeout=300,
        check=False,
        cwd=ROOT,
    )


# --- --version ------------------------------------------------------------------------------------
def test_version_prints_the_packaged_version() -> None:
    pyproject = (ROOT / "pyproject.toml").read_text()
    version = re.search(r'^version = "([^"]+)"$', pyproject, re.MULTILINE)
    assert version
    result = skinframes("--version")
    assert result.returncode == 0, result.stderr
    assert result.stdout.decode() == f"skinframes {version.group(1)}\n"
    assert result.stderr == b""


# --- ethercat is ecat ------------------------------------------------------------------------------
def test_simulate_ethercat_is_simulate_ecat() -> None:
    runs = [
        skinframes("simulate", name, "--nodes", "3", "--bytes", "8", "--cycles", "2", "--json")
        for name in ("ecat", "ethercat")
    ]
    for r in runs:
        assert r.returncode == 0, r.stderr
    docs = [json.loads(r.stdout) for r in runs]
    assert docs[0]["protocol"] == "ecat"
    assert docs[1] == docs[0]


@pytest.mark.parametrize(
    ("argv", "dest"),
    [
        (["simulate", "ethercat", "--nodes", "1", "--bytes", "1"], "protocol"),
        (["serve", "ethercat", "--iface", "x", "--nodes", "1", "--bytes", "1"], "protocol"),
        (["can", "convert", "x.asc", "--to", "ethercat", "--pcap", "x.pcap"], "target"),
    ],
)
def test_every_protocol_argument_takes_ethercat(argv: list[str], dest: str) -> None:
    assert getattr(build_parser().parse_args(argv), dest) == "ecat"


@pytest.mark.parametrize("name", ["EtherCAT", "ether", "epl2"])
def test_other_protocol_names_stay_usage_errors(name: str) -> None:
    result = skinframes("simulate", name, "--nodes", "1", "--bytes", "1")
    assert result.returncode == 2 and result.stdout == b""
    (line,) = result.stderr.decode().splitlines()
    assert line.startswith("skinframes: error: ")
