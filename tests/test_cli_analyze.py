"""``skinframes analyze`` on emulated captures with known fault plans, and its outputs.

The expected events come from the emulator's own accounting of the faults it injected (the
``simulate`` diagnosis, the working counter of every cycle), never from the analyzer; the
model's cycle time for the inferred network must equal the emulated run's.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path
from typing import Any

import pytest

from skinframes_cli import main

ROOT = Path(__file__).resolve().parent.parent


def analyze(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    assert main(["analyze", *argv, "--json"]) == 0
    doc: dict[str, Any] = json.loads(capsys.readouterr().out)
    return doc


def simulate(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    assert main(["simulate", *argv, "--json"]) == 0
    doc: dict[str, Any] = json.loads(capsys.readouterr().out)
    return doc


def lost_pres(diagnosis: list[str]) -> dict[int, int]:
    """CN -> PRes lost, from the emulator's diagnosis lines ("CN 5: 2 of 20 PRes lost ...")."""
    out = {}
    for line in diagnosis:
        m = re.match(r"CN (\d+): (\d+) of \d+ PRes lost", line)
        if m:
            out[int(m[1])] = int(m[2])
    return out


def test_epl_dropped_and_late_pres_are_the_missing_responses(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    pcap = tmp_path / "epl.pcap"
    sim = simulate(
        capsys,
        *("epl", "--nodes", "6", "--bytes", "32", "--preset", "wire", "--cycles", "40"),
        *("--fault", "late:2:40", "--fault", "drop:4:0.3", "--seed", "5", "--pcap", str(pcap)),
    )
    lost = lost_pres(sim["diagnosis"])
    assert lost[2] == 40 and lost.get(
        5
    )  # the plan did what it says: CN 2 always, CNs 5.. sometimes
    doc = analyze(capsys, str(pcap))
    missing = {n["node"]: n["missing"] for n in doc["epl"]["nodes"] if n["missing"]}
    assert missing == lost
    assert len(doc["epl"]["missing"]) == sum(lost.values())
    assert doc["epl"]["late"] == []  # no timeout given: nothing is called late


def test_epl_late_within_the_timeout(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """A CN 10 us late but within the MN's timeout answers; with a timeout between its normal
    and its late response time, every one of its responses is late, and nobody else's."""
    clean, late = tmp_path / "clean.pcap", tmp_path / "late.pcap"
    base = ("epl", "--nodes", "4", "--bytes", "16", "--preset", "wire", "--cycles", "12")
    simulate(capsys, *base, "--pcap", str(clean))
    simulate(capsys, *base, "--fault", "late:3:10", "--pcap", str(late))
    normal = analyze(capsys, str(clean))["epl"]["nodes"]
    worst_ns = max(n["response"]["max_ns"] for n in normal)
    timeout_us = (worst_ns + 5_000) / 1000  # above every normal response, 5 us below the late one
    doc = analyze(capsys, str(late), "--pres-timeout-us", str(timeout_us))
    assert {m["node"] for m in doc["epl"]["late"]} == {3}
    assert len(doc["epl"]["late"]) == 12
    assert doc["epl"]["missing"] == []
    by_node = {n["node"]: n for n in doc["epl"]["nodes"]}
    before = {n["node"]: n for n in normal}
    assert by_node[3]["response"]["min_ns"] - before[3]["response"]["min_ns"] == 10_000


@pytest.mark.parametrize(
    ("nodes", "link", "cycle", "given"),
    [(6, 3, 7, ()), (10, 1, 8, ()), (10, 1, 2, ("--expected-wkc", "1"))],
)
def test_ecat_cable_break_is_the_working_counter_deviations(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    nodes: int,
    link: int,
    cycle: int,
    given: tuple[str, ...],
) -> None:
    """Open ring, cable K breaks at cycle C. The steady state is the healthy working counter
    when most cycles are healthy; after an early break only ``--expected-wkc`` says what is
    healthy."""
    from emulator import WIRE, parse_fault, simulate_ecat

    pcap = tmp_path / "break.pcapng"
    cycles = 12
    r = simulate_ecat(
        nodes,
        16,
        WIRE,
        cycles=cycles,
        faults=(parse_fault(f"cable:{link}@{cycle}"),),
        pcap=pcap,
        every_cycle=True,
    )
    short = sum(d.expected_wkc - d.wkc for d in r.details)
    assert short > 0
    doc = analyze(capsys, str(pcap), *given)
    deviations = doc["ecat"]["wkc_deviations"]
    # slaves link+1.. (datagram positions link..) are cut off from the break on, and only they
    assert {d["datagram"] for d in deviations} == set(range(link, nodes))
    assert all(d["wkc"] == 0 and d["expected"] == 1 for d in deviations)
    lost = sum(len(p["unanswered"]) for p in doc["ecat"]["patterns"])
    assert sum(d["expected"] - d["wkc"] for d in deviations) + lost * nodes == short
    # one frame per cycle here: every cycle from the break on is unanswered or deviates
    assert [d.cycle for d in r.details if d.wkc < d.expected_wkc] == list(range(cycle, cycles))
    assert len({d["frame"] for d in deviations}) + lost == cycles - cycle
    assert min(d["time_ns"] for d in deviations) >= r.details[cycle].start_ps // 1000


@pytest.mark.parametrize(
    "argv",
    [
        ("epl", "--nodes", "5", "--bytes", "24"),
        ("ecat", "--nodes", "7", "--bytes", "40"),
        ("ecat", "--nodes", "30", "--bytes", "100", "--layout", "logical"),
        ("ecat", "--nodes", "12", "--bytes", "192", "--closed-ring"),
    ],
)
def test_inferred_network_model_equals_the_emulated_cycle(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, argv: tuple[str, ...]
) -> None:
    pcap = tmp_path / "x.pcapng"
    sim = simulate(capsys, *argv, "--preset", "wire", "--cycles", "6", "--pcap", str(pcap))
    doc = analyze(capsys, str(pcap))
    (config,) = doc["config"]
    assert (config["protocol"], config["nodes"], config["bytes"]) == (
        sim["protocol"],
        sim["nodes"],
        sim["bytes"],
    )
    assert config["topology"] == sim["topology"]
    if sim["protocol"] == "ecat":
        assert config["layout"] == sim["layout"]
    assert config["model_cycle_us"] == pytest.approx(sim["cycle_us"]["median"], abs=1e-6)
    assert config["measured_period_ns"] / 1000 == pytest.approx(sim["cycle_us"]["median"], abs=1e-3)


def test_text_csv_and_plot(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    pcap = tmp_path / "epl.pcap"
    simulate(capsys, "epl", "--nodes", "3", "--bytes", "8", "--asnd", "--pcap", str(pcap))
    out_dir = tmp_path / "tables"
    out_dir.mkdir()
    picture = tmp_path / "a.png"
    assert main(["analyze", str(pcap), "--csv", str(out_dir), "--plot", str(picture)]) == 0
    text = capsys.readouterr().out
    assert "SoC period" in text and "CN   3" in text and "model (wire)" in text
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with (out_dir / "epl_nodes.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [r["node"] for r in rows] == ["1", "2", "3"]
    assert (out_dir / "epl_asnd_services.csv").read_text().splitlines()[1] == "STATUS_RESPONSE,4"
    assert not list(tmp_path.glob("tables/.*.tmp"))


@pytest.mark.parametrize(
    "argv",
    [
        ("missing.pcap",),
        ("{pcap}", "--csv", "{tmp}/no/such/dir"),
        ("{pcap}", "--plot", "{tmp}/a.pdf"),
        ("{pcap}", "--expected-wkc", "70000"),
    ],
)
def test_bad_input_is_one_error_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, argv: tuple[str, ...]
) -> None:
    pcap = tmp_path / "e.pcap"
    simulate(capsys, "ecat", "--nodes", "2", "--bytes", "4", "--pcap", str(pcap))
    args = [a.format(pcap=pcap, tmp=tmp_path) for a in argv]
    assert main(["analyze", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error:")


@pytest.mark.parametrize(
    "path",
    [
        ROOT / "pcaps" / "epl_asnd_services.pcap",
        ROOT / "pcaps" / "ecat_all_commands.pcap",
        ROOT / "pcaps" / "epl_cycle_4cn.pcap",
    ],
    ids=lambda p: p.name,
)
def test_json_keys_are_documented(capsys: pytest.CaptureFixture[str], path: Path) -> None:
    from test_interface_doc import assert_documented, keys

    assert_documented("analyze", keys(analyze(capsys, str(path))))
