"""``--cn-response-us``: a measured EPL CN response time in place of the presets' D_CN (issue 40,
item 4: the design space shows what a software CN costs).

Expected values by hand from the paper's model: Table I charges D_mn + D_cn once per CN (after
its eq. 7), so a CN answering in 90 us instead of 1 us adds 89 us per CN to the EPL cycle, and
nothing to EtherCAT's.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from data.paper_tables import PAPER_TABLES

from skinframes_cli import main

EXTRA_US = 90 - 1  # a 90 us CN against the presets' 1 us


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


def test_tables_with_a_software_cn(capsys: pytest.CaptureFixture[str]) -> None:
    doc = run_json(
        capsys, "tables", "--nodes", "160", "--bytes", "256", "--cn-response-us", "90", "--json"
    )
    assert doc["epl_cn_response_us"] == 90.0
    expected = PAPER_TABLES["epl"][160][256] + 160 * EXTRA_US  # the paper's cell + 14,240 us
    assert doc["epl"]["160"]["256"] == pytest.approx(expected, abs=0.006)
    assert doc["ecat"]["160"]["256"] == pytest.approx(PAPER_TABLES["ecat"][160][256], abs=0.006)


def test_tables_text_says_what_it_shows(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tables", "--nodes", "130", "--bytes", "2", "--cn-response-us", "92.5"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "model analytic, preset paper, EPL CN response 92.5 us"
    # EPL's paper cell is not compared (it is for 1 us); EtherCAT's still are
    assert out.count("1 cell printed in the paper") == 2


def test_emulated_model_takes_it_too(capsys: pytest.CaptureFixture[str]) -> None:
    base = run_json(capsys, "tables", "--model", "emulated", "--nodes", "10", "--bytes", "8",
                    "--jobs", "1", "--json")  # fmt: skip
    slow = run_json(capsys, "tables", "--model", "emulated", "--nodes", "10", "--bytes", "8",
                    "--jobs", "1", "--cn-response-us", "90", "--json")  # fmt: skip
    assert slow["epl"]["10"]["8"] - base["epl"]["10"]["8"] == pytest.approx(10 * EXTRA_US)
    assert slow["ecat"] == base["ecat"]


def test_simulate_and_plan(capsys: pytest.CaptureFixture[str]) -> None:
    sim = ["simulate", "epl", "--nodes", "4", "--bytes", "16", "--cycles", "2", "--json"]
    base = run_json(capsys, *sim)
    slow = run_json(capsys, *sim, "--cn-response-us", "90")
    assert (base["epl_cn_response_us"], slow["epl_cn_response_us"]) == (1.0, 90.0)
    extra = slow["cycle_us"]["median"] - base["cycle_us"]["median"]
    assert extra == pytest.approx(4 * EXTRA_US)
    doc = run_json(capsys, "plan", "--nodes", "4", "--bytes", "16", "--cn-response-us", "90",
                   "--json")  # fmt: skip
    assert doc["epl_cn_response_us"] == 90.0


def test_the_map_draws_with_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "map.png"
    argv = ["plot", "--map", "--preset", "wire", "--cn-response-us", "90", "--out", str(out)]
    assert main(argv) == 0
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("value", "why"),
    [("0", "above 0"), ("-5", "above 0"), ("nan", "above 0"), ("inf", "above 0"),
     ("1000001", "at most 1000000"), ("1e-7", "6 decimals"), ("ninety", "a time in us")],
)  # fmt: skip
def test_bad_values_are_one_error_line(
    value: str, why: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["tables", "--cn-response-us", value]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error:") and why in err[0]


def test_ecat_refuses_it(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["simulate", "ecat", "--nodes", "2", "--bytes", "2", "--cn-response-us", "90"])
    assert code == 2
    assert "apply to EPL only" in capsys.readouterr().err
