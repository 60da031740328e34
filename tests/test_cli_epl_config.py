"""``skinframes epl-config``: the CDC file, its text, its defaults and its refusals."""

from __future__ import annotations

from pathlib import Path

import pytest

from skinframes.powerlink.cdc import decode_cdc
from skinframes_cli import main


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    out, err = capsys.readouterr()
    return code, out, err


def test_the_default_cycle_is_the_models_worst_rounded_up(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """8 CNs x 192 taxel bytes (PRes payload 193), PRes timeout and async slot 1000 us, by hand
    with the wire preset (12.5 bytes/us; Ethernet overhead 26 bytes, PDO header 10):
    PReq 72 bytes 5.76 us + PRes 229 bytes 18.32 us + D_MN 1 + D_CN 1000 = 1025.08 us per CN,
    x 8 = 8200.64; eq. 8's hops (2*8 + 8*9) x 0.46 us = 40.48; SoC and SoA 6.72 each;
    asynchronous slot 1000 and a 1500-byte ASnd (1526 bytes) 122.08: 9376.64 us -> 10000."""
    out = tmp_path / "skin.cdc"
    code, stdout, err = run(
        ["epl-config", "--nodes", "8", "--bytes", "192", "--out", str(out)], capsys
    )
    assert code == 0 and stdout == ""
    assert "cycle 10000 us (the model's worst cycle rounded up to 1 ms)" in err
    assert "worst cycle 9376.6 us, 623.4 us free" in err
    assert "note: 623 us free beyond the worst cycle" in err  # under 1 ms: the real MN's room
    entries = decode_cdc(out.read_bytes())
    values = {(e.index, e.subindex): e.value for e in entries if e.index != 0x1F81}
    assert values[(0x1006, 0)] == 10_000
    assert values[(0x1F92, 8)] == 1_000_000 and values[(0x1F8A, 2)] == 1_000_000
    assert sorted(e.subindex for e in entries if e.index == 0x1F22) == list(range(1, 9))
    # 4 MN objects + 17 per CN (the MN's 13 per-node objects, its 4 PDO channel entries)
    assert len(entries) == 4 + 17 * 8


def test_a_cycle_with_a_millisecond_free_has_no_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The worst cycle of 8 CNs x 192 bytes is 9376.64 us (by hand, above): 11000 us leaves
    1623.4 us free, 10376 us 999.4 us (a note), 10377 us 1000.4 us (none)."""
    argv = ["epl-config", "--nodes", "8", "--bytes", "192", "--out", str(tmp_path / "c.cdc")]
    for cycle_us, free, note in (
        ("11000", "1623.4", False),
        ("10376", "999.4", True),
        ("10377", "1000.4", False),
    ):
        code, _, err = run([*argv, "--cycle-us", cycle_us], capsys)
        assert code == 0 and f"worst cycle 9376.6 us, {free} us free" in err
        assert ("note:" in err) is note, err


def test_txt_is_the_same_configuration_as_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cdc, txt = tmp_path / "a.cdc", tmp_path / "a.txt"
    argv = ["epl-config", "--nodes", "2", "--bytes", "24", "--node-ids", "7,9"]
    code, _, err = run([*argv, "--cycle-us", "20000", "--out", str(cdc), "--txt", str(txt)], capsys)
    assert code == 0, err
    lines = txt.read_text().splitlines()
    assert lines[0] == f"{4 + 17 * 2:08X}"
    assert "1F81\t07\t00000004\t00000007" in lines
    assert "1006\t00\t00000004\t00004E20" in lines  # 20000 us
    assert "1F92\t09\t00000004\t000F4240" in lines  # 1000 us = 1,000,000 ns
    entries = decode_cdc(cdc.read_bytes())
    assert [e.subindex for e in entries if e.index == 0x1F22] == [7, 9]


def test_a_cycle_shorter_than_the_worst_is_written_with_a_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s.cdc"
    code, _, err = run(
        [
            *("epl-config", "--nodes", "8", "--bytes", "192", "--pres-timeout-us", "2000"),
            *("--cycle-us", "10000", "--out", str(out)),
        ],
        capsys,
    )
    assert code == 0 and out.exists()
    assert "shorter than the worst cycle" in err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--nodes", "41", "--bytes", "8"], "40 RPDO and 40 TPDO channels"),
        (["--nodes", "240", "--bytes", "8"], "--nodes"),
        (["--nodes", "2", "--bytes", "1490"], "--bytes"),
        (["--nodes", "2", "--bytes", "0"], "argument --bytes: 0: expected an integer in 1..1489"),
        (["--nodes", "2", "--bytes", "8", "--node-ids", "3,3"], "twice"),
        (["--nodes", "2", "--bytes", "8", "--node-ids", "3"], "1 ids for 2 nodes"),
        (["--nodes", "8", "--bytes", "192", "--cycle-us", "100"], "even with 1 us CNs"),
        (["--nodes", "1", "--bytes", "8", "--pres-timeout-us", "0"], "--pres-timeout-us"),
    ],
)
def test_what_the_mn_cannot_run_is_one_error_line(
    args: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.cdc"
    code, stdout, err = run(["epl-config", *args, "--out", str(out)], capsys)
    assert code == 2 and stdout == ""
    assert len(err.splitlines()) == 1 and err.startswith("skinframes: error: "), err
    assert message in err
    assert not out.exists()


def test_a_missing_folder_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "no" / "x.cdc"
    code, _, err = run(["epl-config", "--nodes", "1", "--bytes", "8", "--out", str(out)], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and "does not exist" in err
