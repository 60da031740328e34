"""``decode --protocol/--node/--frames/-c``: a display filter, checked against tshark's own
display filters on third-party captures (SOURCES.md) and against frame numbers by hand."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pytest

from skinframes_cli.options import frame_ranges

ROOT = Path(__file__).resolve().parent.parent
ECAT = "ethercrab_replay-ek1100-el2828-el2889.pcapng"  # 3578 frames, 3 real terminals
EPL = "epl-viz_1CN.pcapng"  # an MN and CN 1


def decode(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skinframes", "decode", *argv],
        capture_output=True, text=True, timeout=300, check=False, cwd=ROOT,
    )  # fmt: skip


def frames_of(result: subprocess.CompletedProcess[str]) -> list[int]:
    assert result.returncode == 0, result.stderr
    return [json.loads(line)["frame"] for line in result.stdout.splitlines()]


def tshark_frames(tshark: str, path: Path, display_filter: str) -> list[int]:
    out = subprocess.run(
        [tshark, "-r", str(path), "-Y", display_filter, "-T", "fields", "-e", "frame.number"],
        capture_output=True, text=True, timeout=300, check=True,
    ).stdout  # fmt: skip
    return [int(v) for v in out.split()]


def test_epl_node_is_tsharks_src_or_dest(tshark: str, shared_captures: Path) -> None:
    path = shared_captures / EPL
    want = tshark_frames(tshark, path, "epl.src == 1 || epl.dest == 1")
    assert want  # the filter selects something, and not everything
    got = frames_of(decode(str(path), "--node", "1", "--json"))
    assert got == want
    assert frames_of(decode(str(path), "--node", "1", "--protocol", "epl", "--json")) == want
    everything = tshark_frames(tshark, path, "epl")
    assert len(want) < len(everything)
    assert frames_of(decode(str(path), "--protocol", "epl", "--json")) == everything


@pytest.mark.parametrize("node", [0, 1, 2])
def test_ecat_node_is_the_position_address(tshark: str, shared_captures: Path, node: int) -> None:
    path = shared_captures / ECAT
    adp = (-node) % 0x10000  # ETG.1000.4: auto-increment address of position N
    want = tshark_frames(
        tshark, path, f"(ecat.cmd == 1 || ecat.cmd == 2 || ecat.cmd == 3 || ecat.cmd == 13) "
        f"&& ecat.adp == {adp:#x}",
    )  # fmt: skip
    assert frames_of(decode(str(path), "--node", str(node), "--json")) == want


def test_ethercat_alias_and_other(tshark: str, shared_captures: Path) -> None:
    path = shared_captures / ECAT
    assert len(frames_of(decode(str(path), "--protocol", "ethercat", "--json"))) == len(
        tshark_frames(tshark, path, "ecat")
    )
    assert frames_of(decode(str(path), "--protocol", "epl", "--json")) == []


def test_frame_ranges_and_count(shared_captures: Path) -> None:
    path = str(shared_captures / ECAT)
    assert frames_of(decode(path, "--frames", "3:5,100,3577:", "--json")) == [3, 4, 5, 100, 3577,
                                                                              3578]  # fmt: skip
    result = decode(path, "--frames", "10:", "-c", "3", "--json")
    assert frames_of(result) == [10, 11, 12]
    # the counts are of the records read before stopping: 12, not the file's 3578
    assert result.stderr.splitlines() == ["12 records: 12 decoded, 0 skipped; 3 shown"]
    text = decode(path, "-c", "2")
    assert [line.split()[1] for line in text.stdout.splitlines()] == ["1", "2"]


@pytest.mark.parametrize(
    "argv",
    [["--frames", "0:3"], ["--frames", "5:2"], ["--frames", "x"], ["--node", "-1"],
     ["--protocol", "can2"], ["-c", "0"], ["--taxels", "t.npy", "--node", "1"]],
)  # fmt: skip
def test_bad_selections_are_one_error_line(shared_captures: Path, argv: list[str]) -> None:
    result = decode(str(shared_captures / ECAT), *argv)
    assert result.returncode == 2 and result.stdout == ""
    (line,) = result.stderr.splitlines()
    assert line.startswith("skinframes: error: ")
    assert not (ROOT / "t.npy").exists()


def test_a_step_in_frames_names_the_whole_range() -> None:
    """1:2:3 once said ``'2:3': expected a frame number``: the part after the first colon."""
    with pytest.raises(argparse.ArgumentTypeError, match=r"^'1:2:3': expected N, A:B or A: "):
        frame_ranges("5,1:2:3")
