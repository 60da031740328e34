"""skinframes.analysis against tshark: the same statistics from tshark's own fields, computed here.

The expected values come from ``tshark -T fields`` (frame.number, frame.time_epoch, epl.*,
ecat.*): times parsed to integer nanoseconds from tshark's text, statistics with Python's
``statistics`` module (quartiles: ``quantiles(method="inclusive")``), pairing and steady states
written out again below from the definitions in the module docstrings.
"""

from __future__ import annotations

import itertools
import statistics
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import pytest
import tshark_util
from conftest import PCAPS
from encap_util import over_udp, qinq

from skinframes.analysis import Summary, analyze_capture
from skinframes.analysis.ecat import pattern_text
from skinframes.pcap import read_capture

EPL_FILES = ["epl-viz_EPL_Example.cap", "epl-viz_1CN.pcapng"]
ECAT_FILES = [
    "ethercrab_replay-ek1100-el2828-el2889.pcapng",
    "ethercrab_soem-sdinfo-ek1100-el1004.pcapng",
]
LOGICAL = {0x0A, 0x0B, 0x0C}
CONFIGURED = {0x04, 0x05, 0x06, 0x0E}


def epoch_ns(text: str) -> int:
    """tshark's frame.time_epoch (``s.fffffffff``) as integer nanoseconds, without floats."""
    sec, _, frac = text.partition(".")
    return int(sec) * 1_000_000_000 + int((frac + "000000000")[:9])


def assert_summary(got: Summary, values: list[int]) -> None:
    """``got`` equals the statistics of ``values`` to the nanosecond (exact where integral)."""
    assert got.count == len(values)
    if not values:
        return
    assert got.min_ns == min(values)
    assert got.max_ns == max(values)
    if len(values) > 1:
        q1, median, q3 = statistics.quantiles(values, n=4, method="inclusive")
    else:
        q1 = median = q3 = values[0]
    expected = {
        "q1_ns": q1,
        "median_ns": median,
        "q3_ns": q3,
        "mean_ns": statistics.fmean(values),
        "std_ns": statistics.pstdev(values),
    }
    for key, want in expected.items():
        assert getattr(got, key) == pytest.approx(want, abs=1e-3), key


def _epl_rows(tshark: str, path: Path) -> list[dict[str, list[str]]]:
    names = ["frame.number", "frame.time_epoch", "epl.mtyp", "epl.src", "epl.dest"]
    return [r for r in tshark_util.fields(tshark, path, names) if r["epl.mtyp"]]


def _epl_paths(shared_captures: Path, tmp_path: Path) -> list[Path]:
    from emulator import WIRE, parse_fault, simulate_epl

    dropped = tmp_path / "epl_drops.pcapng"
    faults = (parse_fault("drop:2:0.3"), parse_fault("late:1:40"))
    simulate_epl(5, 16, WIRE, cycles=30, seed=2, asnd=True, faults=faults, pcap=dropped)
    tagged = tmp_path / "epl_vlan.pcapng"  # 802.1Q: once analyzed as no EPL at all
    simulate_epl(3, 16, WIRE, cycles=30, seed=2, faults=faults[:1], pcap=tagged, vlan=5)
    files = [shared_captures / f for f in EPL_FILES] + sorted(PCAPS.glob("epl_*.pcap"))
    return [*files, dropped, tagged, qinq(dropped, tmp_path / "epl_qinq.pcap")]


@pytest.mark.tshark
@pytest.mark.parametrize("index", range(len(EPL_FILES) + 5))
def test_epl_statistics_equal_tshark_fields(
    tshark: str, shared_captures: Path, tmp_path: Path, index: int
) -> None:
    path = _epl_paths(shared_captures, tmp_path)[index]
    rows = _epl_rows(tshark, path)
    assert rows, f"{path}: tshark sees no EPL frame"
    soc_times = [epoch_ns(r["frame.time_epoch"][0]) for r in rows if r["epl.mtyp"] == ["1"]]
    periods = [b - a for a, b in itertools.pairwise(soc_times)]
    responses: dict[int, list[int]] = defaultdict(list)
    missing: list[tuple[int, int]] = []
    pending: tuple[int, int, int] | None = None  # (node, frame, time)
    # the phases of each whole cycle: SoC -> its first SoA, that SoA -> the next SoC, the
    # cycle's last EPL frame -> the next SoC
    phases: dict[str, list[int]] = {"iso": [], "async": [], "headroom": [], "used": []}
    soc = soa = last = None
    for r in rows:
        frame, t = int(r["frame.number"][0]), epoch_ns(r["frame.time_epoch"][0])
        mtyp, src = int(r["epl.mtyp"][0]), int(r["epl.src"][0])
        if mtyp == 1:
            if soc is not None and soa is not None and last is not None:
                phases["iso"].append(soa - soc)
                phases["async"].append(t - soa)
                phases["headroom"].append(t - last)
                phases["used"].append(last - soc)
            soc, soa = t, None
        elif mtyp == 5 and soc is not None and soa is None:
            soa = t
        last = t
        if src == 240 and pending is not None:
            missing.append((pending[0], pending[1]))
            pending = None
        if mtyp == 3:
            pending = (int(r["epl.dest"][0]), frame, t)
        elif mtyp == 4 and pending is not None and src == pending[0]:
            responses[src].append(t - pending[2])
            pending = None

    analysis = analyze_capture(read_capture(path))
    assert analysis.epl is not None
    assert_summary(analysis.epl.soc_period, periods)
    assert_summary(analysis.epl.isochronous, phases["iso"])
    assert_summary(analysis.epl.asynchronous, phases["async"])
    assert_summary(analysis.epl.headroom, phases["headroom"])
    assert_summary(analysis.epl.used, phases["used"])
    assert len(phases["iso"]) == len(periods)  # (every cycle of these has its SoA)
    for node, values in responses.items():
        assert_summary(analysis.epl.responses[node], values)
    assert {n for n, s in analysis.epl.responses.items() if s.count} == set(responses)
    assert [(m.node, m.frame) for m in analysis.epl.missing] == missing
    if path.name in ("epl_drops.pcapng", "epl_qinq.pcap"):
        assert len(missing) > 30, "CN 1 late beyond its timeout, CNs 3.. dropped: missing PRes"
    if path.name == "epl_vlan.pcapng":
        assert missing, "CNs 2.. dropped: missing PRes"


def _datagrams(row: dict[str, list[str]]) -> list[tuple[int, int, int, int, int, int]]:
    """(cmd, idx, adp or -1, ado or lad, length, wkc) per datagram; tshark lists ``ecat.lad``
    for logical commands and ``ecat.adp``/``ecat.ado`` for the others, each in frame order."""
    adp, ado, lad = iter(row["ecat.adp"]), iter(row["ecat.ado"]), iter(row["ecat.lad"])
    out = []
    for i, c in enumerate(row["ecat.cmd"]):
        cmd = int(c, 0)
        length = int(row["ecat.subframe.length"][i], 0)
        wkc = int(row["ecat.cnt"][i], 0)
        idx = int(row["ecat.idx"][i], 0)
        if cmd in LOGICAL:
            out.append((cmd, idx, -1, int(next(lad), 0), length, wkc))
        else:
            a, o = int(next(adp), 0), int(next(ado), 0)
            out.append((cmd, idx, a if cmd in CONFIGURED else -1, o, length, wkc))
    return out


def _ecat_expected(tshark: str, path: Path) -> dict[tuple[Any, str], dict[str, Any]]:
    """Per (pattern, master port): periods, round trips and wkc deviations from tshark."""
    names = [
        "frame.number",
        "frame.time_epoch",
        "eth.src",
        "ecat.cmd",
        "ecat.idx",
        "ecat.adp",
        "ecat.ado",
        "ecat.lad",
        "ecat.subframe.length",
        "ecat.cnt",
    ]
    streams: dict[tuple[Any, str], dict[str, Any]] = defaultdict(
        lambda: {"out": [], "back": [], "rtt": [], "rows": []}
    )
    pending: dict[tuple[Any, int, str], int] = {}
    for r in tshark_util.fields(tshark, path, names):
        if not r["ecat.cmd"]:
            continue
        frame, t = int(r["frame.number"][0]), epoch_ns(r["frame.time_epoch"][0])
        dgs = _datagrams(r)
        pattern = tuple((c, a, o, n) for c, _, a, o, n, _ in dgs)
        src = r["eth.src"][0]
        first = int(src[:2], 16)
        port = f"{first & ~0x02:02x}{src[2:]}"
        s = streams[(pattern, port)]
        key = (pattern, dgs[0][1], port)
        if first & 0x02 and key in pending:  # returned (one interface, one master port here)
            s["rtt"].append(t - pending.pop(key))
            s["rows"].append((frame, [w for *_, w in dgs]))
        else:
            pending[key] = t
            s["out"].append(t)
    for s in streams.values():
        s["period"] = [b - a for a, b in zip(s["out"], s["out"][1:], strict=False)]
        deviations = []
        if s["rows"]:
            width = len(s["rows"][0][1])
            for col in range(width):
                counts = Counter(row[col] for _, row in s["rows"])
                top = max(counts.values())
                steady = min(v for v, c in counts.items() if c == top)
                deviations += [
                    (f, col, row[col], steady) for f, row in s["rows"] if row[col] != steady
                ]
        s["deviations"] = sorted(deviations)
    return streams


def _ecat_paths(shared_captures: Path, tmp_path: Path) -> list[Path]:
    from emulator import WIRE, parse_fault, simulate_ecat

    broken = tmp_path / "open_break.pcap"
    simulate_ecat(
        6, 16, WIRE, cycles=8, faults=(parse_fault("cable:3@4"),), pcap=broken
    )  # slaves 3.. cut off from cycle 4: working-counter deviations
    tagged = tmp_path / "ecat_vlan.pcapng"  # 802.1Q: once analyzed as no EtherCAT at all
    simulate_ecat(4, 16, WIRE, cycles=8, faults=(parse_fault("cable:2@4"),), pcap=tagged, vlan=9)
    files = [shared_captures / f for f in ECAT_FILES] + sorted(PCAPS.glob("ecat_*.pcap"))
    udp = over_udp(broken, tmp_path / "open_break_udp.pcap", 0x88A4)
    return [*files, broken, tagged, qinq(broken, tmp_path / "open_break_qinq.pcap"), udp]


@pytest.mark.tshark
@pytest.mark.parametrize("index", range(len(ECAT_FILES) + 7))
def test_ecat_statistics_equal_tshark_fields(
    tshark: str, shared_captures: Path, tmp_path: Path, index: int
) -> None:
    path = _ecat_paths(shared_captures, tmp_path)[index]
    expected = _ecat_expected(tshark, path)
    analysis = analyze_capture(read_capture(path))
    assert analysis.ecat is not None
    got = {(p.text, p.port.replace(":", "")): (i, p) for i, p in enumerate(analysis.ecat.patterns)}
    assert len(got) == len(expected)
    deviations = []
    for (pattern, port), want in expected.items():
        i, report = got[(pattern_text(pattern), port.replace(":", ""))]
        assert_summary(report.period, want["period"])
        assert_summary(report.round_trip, want["rtt"])
        assert report.returned == len(want["rows"])
        deviations += [(f, i, col, w, e) for f, col, w, e in want["deviations"]]
    assert [
        (d.frame, d.pattern, d.datagram, d.wkc, d.expected) for d in analysis.ecat.wkc_deviations
    ] == sorted(deviations)
    if path.name.startswith(("open_break", "ecat_vlan")):
        assert deviations, "the cable break must show in the working counters"


@pytest.mark.tshark
@pytest.mark.parametrize("name", ["epl_cycle_4cn.pcap", "epl_asnd_services.pcap"])
def test_epl_over_udp_is_analyzed_as_the_same_frames_over_ethernet(
    tshark: str, tmp_path: Path, name: str
) -> None:
    """EPL over UDP: tshark dissects every frame as EPL; the analysis is that of the same
    messages sent over Ethernet (whose figures the tshark tests above check), node ids from
    the IP addresses."""
    udp = over_udp(PCAPS / name, tmp_path / name, 3819)
    rows = tshark_util.fields(tshark, udp, ["frame.number"], "epl && udp.port == 3819")
    plain = analyze_capture(read_capture(PCAPS / name)).to_json()
    doc = analyze_capture(read_capture(udp)).to_json()
    assert doc["counts"]["epl"] == len(rows) == plain["counts"]["epl"] > 0
    assert doc == plain


def test_cached_layouts_give_what_the_walk_gives(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Frames of a layout seen before are read with one struct call; without that cache every
    frame is walked datagram by datagram. Both give the same document, faults included."""
    from emulator import WIRE, parse_fault, simulate_ecat
    from skinframes.analysis import ecat

    path = tmp_path / "ring.pcapng"
    faults = (parse_fault("cable:4@3"), parse_fault("biterr:2:0.2"))
    simulate_ecat(9, 24, WIRE, closed_ring=True, cycles=12, seed=3, faults=faults, pcap=path)
    cached = analyze_capture(read_capture(path)).to_json()
    monkeypatch.setattr(ecat, "_LAYOUT_MIN_DATAGRAMS", 10**6)
    walked = analyze_capture(read_capture(path)).to_json()
    assert cached == walked
    assert cached["ecat"]["wkc_deviations"]
