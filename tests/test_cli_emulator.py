"""The cycle-time commands: tables, simulate, plan, plot, demo (docs/interface.md shapes)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from data.paper_tables import OLD_NAMES, PAPER_TABLES

from emulator.model.cycle_time import cycle_us
from emulator.model.params import WIRE
from skinframes import read_capture
from skinframes_cli import main


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


def test_tables_json_reproduces_the_paper(capsys: pytest.CaptureFixture[str]) -> None:
    doc = run_json(capsys, "tables", "--json")
    assert (doc["model"], doc["preset"], doc["unit"]) == ("analytic", "paper", "us")
    tables = {**PAPER_TABLES, **{old: PAPER_TABLES[new] for old, new in OLD_NAMES.items()}}
    for table, rows in tables.items():  # the closed ring under its name and its old name
        for n, row in rows.items():
            for b, value in row.items():
                assert doc[table][str(n)][str(b)] == pytest.approx(value, abs=0.006)


def test_tables_emulated_with_ranges(capsys: pytest.CaptureFixture[str]) -> None:
    doc = run_json(
        capsys, "tables", "--model", "emulated", "--nodes", "160,170", "--bytes", "128", "--json"
    )
    assert doc["model"] == "emulated"
    assert set(doc["epl"]) == {"160", "170"}
    assert doc["ecat"]["160"]["128"] == pytest.approx(PAPER_TABLES["ecat"][160][128], abs=0.01)


def test_simulate_json_keys_and_pcap(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    pcap = tmp_path / "ring.pcap"
    doc = run_json(
        capsys,
        "simulate",
        "ecat",
        "--nodes",
        "23",
        "--bytes",
        "192",
        "--redundant",
        "--cycles",
        "3",
        "--pcap",
        str(pcap),
        "--json",
    )
    assert set(doc) >= {
        "protocol",
        "topology",
        "nodes",
        "bytes",
        "preset",
        "layout",
        "cycles",
        "frames",
        "cycle_us",
        "cycles_detail",
        "recovery_us",
        "diagnosis",
        "pcap",
    }
    assert (doc["protocol"], doc["topology"], doc["cycles"], doc["frames"]) == (
        "ecat",
        "closed",
        3,
        48,  # 4 frames out of each port and back, 3 cycles (cable redundancy: both ports)
    )
    assert doc["pcap"] == str(pcap)
    assert len(list(read_capture(pcap))) == 48
    detail = doc["cycles_detail"]
    # steady cycles are not repeated: the first one is listed, the others are the same
    assert [d["cycle"] for d in detail] == [0] and doc["cycles_detail_omitted"] == 0
    assert all(d["wkc"] == d["expected_wkc"] == 23 for d in detail)
    master = bytes.fromhex("00005e005301")  # frames the master sends from its first port
    starts = sorted(rec.time_ns for rec in read_capture(pcap) if rec.data[6:12] == master)
    assert starts[4] == round(detail[0]["cycle_us"] * 1000)  # cycle 1: 4 frames later, port 0


def test_simulate_epl_text(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "epl", "--nodes", "4", "--bytes", "192"]) == 0
    out = capsys.readouterr().out
    assert "cycle time" in out
    assert "working counter" not in out and "diagnosis" not in out  # healthy: nothing lost


def test_simulate_text_shows_losses_without_a_fault(capsys: pytest.CaptureFixture[str]) -> None:
    """A PRes timeout of 0 us no CN can meet (its PRes starts a cable and a response time after
    the PReq): none of the 2 PRes of each of the 4 cycles arrives, and the text report says so
    as it does under --fault; the value is accepted, as the help says."""
    argv = ["simulate", "epl", "--nodes", "2", "--bytes", "8", "--pres-timeout-us", "0"]
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "  working counter (got/expected) from cycle on: 0: 0/2" in lines
    for cn in (1, 2):
        prefix = f"  diagnosis: CN {cn}: 4 of 4 PRes lost (the MN's loss-of-PRes counter)"
        assert any(line.startswith(prefix) for line in lines)
    assert main(["simulate", "--help"]) == 0
    helped = " ".join(capsys.readouterr().out.split())  # argparse wraps the lines
    assert "rejected" not in helped and "cannot meet it loses its PRes, counted" in helped


def test_plan_prefers_the_logical_image_for_many_patches(
    capsys: pytest.CaptureFixture[str],
) -> None:
    doc = run_json(capsys, "plan", "--nodes", "160", "--bytes", "192", "--json")
    assert doc["limit_us"] == pytest.approx(160 * 192 * 0.08)  # n x B bytes at 100 Mbit/s
    assert doc["ecat"]["layout"] == "logical"
    assert doc["ecat"]["frames_per_cycle"] == 21  # ceil(30720 / 1486)
    assert doc["epl"]["cycle_us"] > doc["ecat"]["cycle_us"]


def test_plan_marks_a_network_that_cannot_have_the_cell_not_applicable(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """240 patches: beyond EPL's 239 CNs (DS 301 node ids), within EtherCAT's; 1490 bytes: an
    EPL PRes payload (C_DLL_ISOCHR_MAX_PAYL), beyond one EtherCAT datagram (1486). Once this
    was an error for every network; no network at all still is."""
    doc = run_json(capsys, "plan", "--nodes", "240", "--bytes", "8", "--json")
    assert doc["epl"] is None and doc["not_applicable"] == {"epl": ["EPL: 240 CNs (1..239)"]}
    assert doc["limit_us"] == pytest.approx(240 * 8 * 0.08)
    assert doc["ecat"]["analytic_us"] == round(cycle_us("ecat", 240, 8, WIRE), 6)
    assert doc["ecat_closed_ring"] == doc["ecat_redundant"] is not None
    doc = run_json(capsys, "plan", "--nodes", "2", "--bytes", "1490", "--json")
    assert doc["epl"]["analytic_us"] == round(cycle_us("epl", 2, 1490, WIRE), 6)
    assert doc["ecat"] is doc["ecat_closed_ring"] is doc["ecat_redundant"] is None
    reason = ["EtherCAT (emulated): 1490 bytes per slave (1..1486)"]
    assert doc["not_applicable"] == dict.fromkeys(
        ("ecat", "ecat_closed_ring", "ecat_redundant"), reason
    )
    assert main(["plan", "--nodes", "240", "--bytes", "8"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == "  EPL                    n/a: EPL: 240 CNs (1..239)"
    assert lines[2].startswith("  EtherCAT open ring     best ")
    assert main(["plan", "--nodes", "1025", "--bytes", "8"]) == 2
    err = capsys.readouterr().err
    assert err == (
        "skinframes: error: EPL: 1025 CNs (1..239); EtherCAT (emulated): 1025 slaves (1..1024)\n"
    )


def test_plot_writes_a_png(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "fig.png"
    assert main(["plot", "--out", str(out), "--step", "120"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_fault_at_a_cycle_the_run_does_not_reach_is_refused(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """4 cycles are cycles 0..3 (the default --cycles): a break at cycle 4 never happens."""
    ring = ["simulate", "ecat", "--nodes", "4", "--bytes", "8", "--closed-ring"]
    assert main([*ring, "--fault", "cable:1@4"]) == 2
    assert capsys.readouterr().err == (
        "skinframes: error: fault cable:1@4: cycle 4 is not in the run's 4 cycles "
        "(0..3; --cycles more)\n"
    )
    assert main([*ring, "--fault", "cable:1@3"]) == 0
    assert "link 1..2 down at cycle 3" in capsys.readouterr().out
    epl = ["simulate", "epl", "--nodes", "4", "--bytes", "8", "--fault", "power:2@10"]
    assert main([*epl, "--cycles", "10"]) == 2
    assert "cycle 10 is not in the run's 10 cycles" in capsys.readouterr().err
    assert main([*epl, "--cycles", "11"]) == 0


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "epl", "--nodes", "240", "--bytes", "192"],
        ["simulate", "ecat", "--nodes", "4", "--bytes", "0"],
        ["simulate", "epl", "--nodes", "4", "--bytes", "8", "--redundant"],
        ["simulate", "ecat", "--nodes", "4", "--bytes", "8", "--fault", "cable:x@1"],
        ["simulate", "ecat", "--nodes", "4", "--bytes", "8", "--fault", "cable:9@1"],
        ["tables", "--nodes", "1:x"],
        ["tables", "--nodes", "200:100"],
        ["plot", "--out", "fig.gif"],
    ],
)
def test_bad_input_is_one_error_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error:")


def test_demo_writes_pcaps_and_reports(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--out", str(tmp_path), "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert "2792.88 us" in out  # closed ring, paper preset = Table III's model at 160 x 192
    names = {p.name for p in tmp_path.glob("*.pcap")}
    assert {"epl_160x192_wire.pcap", "ecat_redundant_160x192_paper.pcap"} <= names
