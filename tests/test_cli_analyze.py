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


@pytest.mark.tshark
@pytest.mark.parametrize("protocol", ["epl", "ecat"])
def test_vlan_tagged_frames_are_analyzed_as_tshark_dissects_them(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, tshark: str, protocol: str
) -> None:
    """802.1Q-tagged frames (once all ``other``, ``ecat: null``): tshark's vlan dissector hands
    them to epl/ecat; analyze counts the same frames and infers the emulated network."""
    import tshark_util

    pcap = tmp_path / "tagged.pcap"
    argv = (protocol, "--nodes", "5", "--bytes", "40", "--cycles", "20", "--vlan", "42")
    sim = simulate(capsys, *argv, "--pcap", str(pcap))
    doc = analyze(capsys, str(pcap))
    numbers = tshark_util.fields(tshark, pcap, ["frame.number"], f"vlan.id == 42 && {protocol}")
    assert doc["counts"][protocol] == len(numbers) == doc["records"] > 0
    (config,) = doc["config"]
    assert (config["protocol"], config["nodes"], config["bytes"]) == (protocol, 5, 40)
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


# --- the text leads with what matters; the plot stays readable (issue 42, Build 4) ----------------
def test_real_capture_leads_with_the_cyclic_process_data(
    capsys: pytest.CaptureFixture[str], shared_captures: Path, tshark: str
) -> None:
    import subprocess

    path = shared_captures / "ethercrab_replay-ek1100-el2828-el2889.pcapng"
    # tshark: the frames carrying the process data (LRW) as the master sent them (WKC 0)
    sent = subprocess.run(
        [tshark, "-r", str(path), "-Y", "ecat.cmd == 12 && ecat.cnt == 0"],
        capture_output=True, text=True, check=True, timeout=300,
    ).stdout.splitlines()  # fmt: skip
    assert main(["analyze", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    doc = analyze(capsys, str(path))
    patterns = doc["ecat"]["patterns"]
    cyclic = sorted((p for p in patterns if p["cyclic"]), key=lambda p: -p["frames"])
    assert sum(p["frames"] for p in cyclic) == len(sent) == 263
    busiest = cyclic[0]
    head = lines[:15]
    assert any(
        line.startswith(f"  pattern {busiest['pattern']} (cyclic) from ") for line in head
    ), head
    assert lines[2].startswith(f"  pattern {busiest['pattern']} (cyclic)")  # first of all
    assert f"{busiest['frames']} sent" in lines[2] and busiest["datagrams"].startswith("LRW")
    once = [p["pattern"] for p in patterns if not p["cyclic"] and p["frames"] == 1]
    (summary,) = [line for line in lines if "patterns of one frame each" in line]
    assert summary.startswith(f"  {len(once)} patterns of one frame each (first datagram ")
    assert f"{len(patterns)} patterns: {len(cyclic)} cyclic" in lines[1]


def _figure_of(monkeypatch: pytest.MonkeyPatch, argv: list[str]) -> Any:
    """Run analyze --plot and keep the figure it saves (and fail on any warning)."""
    import warnings

    import skinframes_cli.analyze as cli

    kept: list[Any] = []

    def keep(fig: Any, out: Path, **kw: Any) -> None:
        fig.canvas.draw()
        kept.append(fig)

    monkeypatch.setattr(cli, "save_figure", keep)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["analyze", *argv]) == 0
    (fig,) = kept
    return fig


def _readable(fig: Any) -> None:
    from matplotlib.ticker import MaxNLocator

    for ax in fig.axes:
        assert ax.has_data(), ax.get_title()  # no empty panel
        assert ax.xaxis.get_major_formatter().get_offset() == "", ax.get_title()
        if ax.get_ylabel() in ("frames", "nodes"):
            assert isinstance(ax.yaxis.get_major_locator(), MaxNLocator)
            assert all(float(t).is_integer() for t in ax.get_yticks())
        legend = ax.get_legend()
        if legend is not None:
            assert len(legend.get_texts()) <= 10
            box, frame = legend.get_window_extent(), ax.get_window_extent()
            assert not box.overlaps(frame), ax.get_title()  # beside the axes, not over them


def test_plot_names_patterns_as_the_json_does(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, shared_captures: Path,
    tmp_path: Path,
) -> None:  # fmt: skip
    path = shared_captures / "ethercrab_replay-ek1100-el2828-el2889.pcapng"
    doc = analyze(capsys, str(path))
    cyclic = {f"pattern {p['pattern']}" for p in doc["ecat"]["patterns"] if p["cyclic"]}
    fig = _figure_of(monkeypatch, [str(path), "--plot", str(tmp_path / "a.png")])
    capsys.readouterr()
    labels = {t.get_text() for t in fig.axes[0].get_legend().get_texts()}
    assert labels == cyclic == {"pattern 100", "pattern 101"}
    _readable(fig)


def test_plot_at_160_nodes_is_readable(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    pcap = tmp_path / "epl160.pcap"
    simulate(capsys, "epl", "--nodes", "160", "--bytes", "192", "--cycles", "20", "--pcap",
             str(pcap))  # fmt: skip
    fig = _figure_of(monkeypatch, [str(pcap), "--plot", str(tmp_path / "a.png")])
    capsys.readouterr()
    assert len(fig.axes) == 3
    assert fig.axes[1].get_xlabel() == "CN node id"  # 160 histograms would be unreadable
    assert "nodes in each state" in fig.axes[2].get_title()
    _readable(fig)
    ecat = tmp_path / "ecat.pcap"  # no state reported: two panels, none empty
    simulate(capsys, "ecat", "--nodes", "160", "--bytes", "192", "--cycles", "20", "--pcap",
             str(ecat))  # fmt: skip
    fig = _figure_of(monkeypatch, [str(ecat), "--plot", str(tmp_path / "b.png")])
    capsys.readouterr()
    assert len(fig.axes) == 2
    _readable(fig)


def test_epl_model_beside_what_it_predicts(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """A capture of 4 CNs that answer in 90 us (simulate --cn-response-us, wire preset): the
    CNs' measured PReq -> PRes lies between 90 us and 90 us plus the two frames' and the hops'
    times (by hand: PReq and PRes of 16 bytes are 84 bytes on the wire, 6.72 us each, and a hop
    is 0.46 us of hub and 0.05 ns of cable, at most 4 there and back); the model run again with
    that as D_CN predicts the emulated cycle to within that margin per CN; the used part of
    each cycle (SoC to its last frame, the SoA) is the emulated cycle less the SoA's 6.72 us."""
    pcap = tmp_path / "slow.pcapng"
    sim = simulate(capsys, "epl", "--nodes", "4", "--bytes", "16", "--preset", "wire",
                   "--cn-response-us", "90", "--cycles", "6", "--pcap", str(pcap))  # fmt: skip
    doc = analyze(capsys, str(pcap))
    (config,) = doc["config"]
    margin_us = 2 * 6.72 + 8 * 0.46 + 1  # the frames, the hops, and the cables' ns
    assert 90 <= config["cn_response_median_us"] <= 90 + margin_us
    cycle = sim["cycle_us"]["median"]
    assert cycle <= config["model_cycle_measured_cn_us"] <= cycle + 4 * margin_us
    assert config["model_cycle_us"] == pytest.approx(cycle - 4 * 89, abs=1e-6)  # 1 us CNs
    used_us = doc["epl"]["phases"]["used"]["median_ns"] / 1000
    assert used_us == pytest.approx(cycle - 6.72, abs=1e-3)
    assert main(["analyze", str(pcap)]) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if s.startswith("network (epl)"))
    assert "cycle used (SoC to its last frame)" in line and "with the CNs' measured" in line


@pytest.mark.parametrize("fault", [(), ("--fault", "cable:4@3")], ids=["steady", "broken"])
def test_closed_ring_in_classic_pcap_as_in_pcapng(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, fault: tuple[str, ...]
) -> None:
    """A closed ring's copy from the master's second port runs the ring unprocessed and comes
    back unmarked: classic pcap has no interface to tell it from a send (issue 42: every such
    frame was called sent and never returned). The same run as pcapng, where the interfaces
    tell, is the reference: every pattern's counts and times are the same."""
    docs = []
    for suffix in ("pcap", "pcapng"):
        pcap = tmp_path / f"ring.{suffix}"
        simulate(capsys, "ecat", "--nodes", "8", "--bytes", "16", "--closed-ring", "--cycles",
                 "8", *fault, "--pcap", str(pcap))  # fmt: skip
        docs.append(analyze(capsys, str(pcap))["ecat"]["patterns"])
    classic, pcapng = docs
    assert classic == pcapng
    if not fault:  # both ports' frames: 8 sent, 8 back
        assert [(p["frames"], p["returned"], p["unanswered"]) for p in pcapng] == [(8, 8, [])] * 2


# --- damaged captures: the records that could not be read are reported, as decode reports them --
def damaged(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, how: str
) -> tuple[Path, int, list[int]]:
    """A 16-node closed ring's classic pcap, damaged by hand: ``cut`` inside its 5th record,
    ``gzip`` compressed and the compressed file cut at 3000 bytes. (path, records whole, the
    frames lost), from the pcap's own record headers (16 bytes each, caplen at 8) and, for
    gzip, what Python's zlib recovers of the cut stream."""
    import gzip
    import zlib

    pcap = tmp_path / "ring.pcap"
    simulate(capsys, "ecat", "--nodes", "16", "--bytes", "192", "--closed-ring", "--pcap",
             str(pcap))  # fmt: skip
    raw = pcap.read_bytes()
    if how == "cut":
        path = tmp_path / "cut.pcap"
        data = raw[: _record_starts(raw)[4] + 16 + 10]
        path.write_bytes(data)
    else:
        path = tmp_path / "cut.pcap.gz"
        path.write_bytes(gzip.compress(raw)[:3000])
        data = zlib.decompressobj(wbits=31).decompress(path.read_bytes())
    ends = [at + 16 + _caplen(data, at) for at in _record_starts(data)]
    whole = sum(1 for end in ends if end <= len(data))
    lost = [whole + 1] if len(data) > max(ends[:whole], default=24) else []  # one cut short
    if how == "gzip":
        lost.append(len(lost) + whole + 1)  # the stream's end, never reached
    return path, whole, lost


def _caplen(data: bytes, at: int) -> int:
    return int.from_bytes(data[at + 8 : at + 12], "little")


def _record_starts(data: bytes) -> list[int]:
    """Where each record (header included) starts, while 16 header bytes are there."""
    out, at = [], 24
    while at + 16 <= len(data):
        out.append(at)
        at += 16 + _caplen(data, at)
    return out


@pytest.mark.parametrize("how", ["cut", "gzip"])
def test_a_damaged_capture_reports_its_skipped_records(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, how: str
) -> None:
    """Once, a cut capture's lost records were not mentioned at all (exit 0, stderr empty)."""
    path, whole, lost = damaged(capsys, tmp_path, how)
    assert whole > 0 and lost
    doc = analyze(capsys, str(path))
    assert doc["records"] == doc["counts"]["ecat"] == whole
    assert [(s["index"], s["frame"]) for s in doc["skipped"]] == [(f - 1, f) for f in lost]
    assert all(s["reason"] for s in doc["skipped"])
    assert main(["analyze", str(path)]) == 0
    out, err = capsys.readouterr()
    frames = f"{lost[0]}..{lost[-1]}" if len(lost) > 1 else f"{lost[0]}"
    assert out.splitlines()[1] == (
        f"skipped: {len(lost)} records could not be read, not analysed: frames {frames} "
        "(the reasons on stderr)"
    )
    lines = err.splitlines()
    assert [line.split(":")[0] for line in lines[:-1]] == [f"skipped frame {f}" for f in lost]
    assert lines[-1] == f"{whole + len(lost)} records: {whole} decoded, {len(lost)} skipped"
    assert main(["decode", str(path)]) == 0  # word for word as decode says it
    assert capsys.readouterr().err == err


@pytest.mark.tshark
@pytest.mark.parametrize("suffix", ["pcapng", "pcap"])
def test_closed_ring_every_lost_frame_is_unanswered(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, tshark: str, suffix: str
) -> None:
    """Cable 8..9 of a 16-slave closed ring breaks at cycle 2: the emulator loses 2 frames, the
    first of that cycle from each master port. Both ports send at one time stamp, and the first
    port's lost frame was taken for the second copy that runs the ring unprocessed, its next
    send for that copy's return: pattern 0 said 4 sent, 3 returned, none unanswered. Expected
    from tshark on the pcapng: the master's sends are its ports' unmarked frames on the
    interface each port sends from; one is answered when a frame of its port and first
    datagram index comes before the port's next send. The classic pcap holds the same frames."""
    import tshark_util

    pcapng = tmp_path / "f.pcapng"
    argv = ("ecat", "--nodes", "16", "--bytes", "192", "--closed-ring", "--fault", "cable:8@2")
    sim = simulate(capsys, *argv, "--pcap", str(pcapng))
    assert any(d.startswith("2 frames lost on the way") for d in sim["diagnosis"])
    rows = tshark_util.fields(
        tshark, pcapng, ["frame.number", "frame.interface_id", "eth.src", "ecat.idx"], "ecat"
    )
    home: dict[str, str] = {}  # port -> the interface it sends from
    pending: dict[tuple[str, str], int] = {}
    sent: dict[str, int] = {}
    lost: dict[str, list[int]] = {}
    for row in rows:
        (number,), (iface,), (src,), idx = (
            row["frame.number"],
            row["frame.interface_id"],
            row["eth.src"],
            row["ecat.idx"],
        )
        marked = int(src[:2], 16) & 0x02
        port = f"{int(src[:2], 16) & ~0x02:02x}{src[2:]}"
        if not marked:
            home.setdefault(port, iface)
        key = (port, idx[0])
        if not marked and home[port] == iface:  # a send
            if key in pending:
                lost.setdefault(port, []).append(pending[key])
            pending[key] = int(number)
            sent[port] = sent.get(port, 0) + 1
        else:
            del pending[key]
    assert sorted(n for frames in lost.values() for n in frames) == [25, 26]
    assert not pending  # every last send returned
    if suffix == "pcap":
        path = tmp_path / "f.pcap"
        simulate(capsys, *argv, "--pcap", str(path))
    else:
        path = pcapng
    patterns = analyze(capsys, str(path))["ecat"]["patterns"]
    assert sum(p["frames"] for p in patterns) == sum(sent.values())
    got = {p["port"]: [] for p in patterns}
    for p in patterns:
        got[p["port"]] += p["unanswered"]
        assert p["returned"] == p["frames"] - len(p["unanswered"])
    assert got == {port: lost.get(port, []) for port in got}


def test_the_model_beside_a_capture_takes_the_preset_it_was_made_with(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """simulate's default preset is paper, analyze's model wire: a capture simulate made with
    its defaults showed '1.01 x the model'. With --preset paper (new) the model is the run's."""
    pcap = tmp_path / "p.pcapng"
    argv = ["simulate", "ecat", "--nodes", "8", "--bytes", "192", "--cycles", "20"]
    assert main([*argv, "--pcap", str(pcap)]) == 0
    capsys.readouterr()
    docs = {}
    for name in ("wire", "paper"):
        assert main(["analyze", str(pcap), "--json", "--preset", name]) == 0
        docs[name] = json.loads(capsys.readouterr().out)
    (wire,), (paper,) = docs["wire"]["config"], docs["paper"]["config"]
    assert docs["paper"]["model_preset"] == "paper" and docs["wire"]["model_preset"] == "wire"
    assert paper["model_cycle_us"] * 1000 == pytest.approx(paper["measured_period_ns"], abs=1)
    assert wire["model_cycle_us"] != paper["model_cycle_us"]  # the two presets differ
