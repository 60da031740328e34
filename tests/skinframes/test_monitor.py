"""skinframes.monitor (what ``watch`` shows) against ``analyze --json`` of the same capture.

``watch`` feeds its frames to ``analyze``'s analyzers: on the third-party captures and on
emulated ones (a closed ring in classic pcap and pcapng, EPL with dropped PRes, VLAN tags) every
figure it shows must be ``analyze``'s (and over UDP/IPv4 that of the same frames over
Ethernet). Where a figure can be known without either, it is checked
against that too: the emulator's fault-free closed ring returns every frame it sends (the monitor
once paired the second port's unprocessed copy as a new send: 600 sent, 599 lost), tshark's SoC
times give the window's statistics, and a hand-made EPL cycle whose CN sends an ASnd before its
late PRes has no missing response (DS 301: missing when the MN's next frame comes first).
"""

from __future__ import annotations

import itertools
import json
import statistics
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import tshark_util
from encap_util import over_udp
from memory_util import traced_peak
from pty_util import ROOT

from skinframes.capture_writer import pcap_bytes
from skinframes.monitor import WINDOW, Monitor
from skinframes.pcap import read_capture

SHARED = [
    "epl-viz_EPL_Example.cap",
    "epl-viz_1CN.pcapng",
    "epl-viz_MultiWriteRead_example.pcapng",
    "ethercrab_replay-ek1100-el2828-el2889.pcapng",
    "ethercrab_soem-sdinfo-ek1100-el1004.pcapng",
]
CYCLES = 300  # of the emulated EtherCAT captures


def skinframes(*argv: str) -> str:
    done = subprocess.run([sys.executable, "-m", "skinframes", *argv], capture_output=True,
                          text=True, timeout=300, check=True, cwd=ROOT)  # fmt: skip
    return done.stdout


@pytest.fixture(scope="module")
def emulated(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Captures from ``skinframes simulate``: name -> path."""
    folder = tmp_path_factory.mktemp("monitor")
    ring = f"ecat --nodes 6 --bytes 192 --closed-ring --cycles {CYCLES}"
    runs = {
        "ring.pcap": ring,
        "ring.pcapng": ring,
        "epl_drops.pcap": "epl --nodes 4 --bytes 192 --cycles 400 --fault drop:2:0.03 --seed 3",
        "epl_asnd_vlan.pcapng": "epl --nodes 3 --bytes 192 --cycles 200 --asnd "
        "--fault drop:1:0.05 --vlan 7",
        "ecat_break.pcap": "ecat --nodes 6 --bytes 16 --cycles 120 --fault cable:3@40",
        "ecat_vlan.pcap": "ecat --nodes 4 --bytes 192 --cycles 60 --vlan 12",
    }
    out = {}
    for name, argv in runs.items():
        out[name] = folder / name
        skinframes("simulate", *argv.split(), "--pcap", str(out[name]))
    out["ring_udp.pcap"] = over_udp(out["ring.pcap"], folder / "ring_udp.pcap", 0x88A4)
    out["epl_udp.pcap"] = over_udp(out["epl_drops.pcap"], folder / "epl_udp.pcap", 3819)
    return out


def watched(path: Path, window: int = WINDOW) -> dict[str, Any]:
    monitor = Monitor(window)
    for rec in read_capture(path):
        monitor.feed(rec)
    return monitor.snapshot()


def us(stats: dict[str, Any]) -> dict[str, float] | None:
    """analyze's statistics (ns) as watch shows them (us)."""
    if not stats["count"]:
        return None
    return {
        "median_us": stats["median_ns"] / 1000,
        "min_us": stats["min_ns"] / 1000,
        "max_us": stats["max_ns"] / 1000,
        "jitter_us": stats["std_ns"] / 1000,
    }


def assert_same(path: Path) -> dict[str, Any]:
    """Every figure of watch's snapshot equals analyze's; the snapshot."""
    doc = watched(path)
    a = json.loads(skinframes("analyze", str(path), "--json"))
    assert doc["frames"] == a["records"]
    assert doc["other"] == a["counts"]["other"]
    if a["epl"] is None:
        assert "epl" not in doc
    else:
        e, w = a["epl"], doc["epl"]
        assert w["frames"] == a["counts"]["epl"]
        assert w["cycles"] == e["message_counts"].get("SOC", 0)
        assert e["soc_period"]["count"] <= WINDOW  # the window holds the whole capture
        assert w["soc_period"] == us(e["soc_period"])
        states = {s["node"]: s["after"] for s in e["nmt_states"]}  # the last one each
        cns = {c["node"]: c for c in w["cns"]}
        assert set(cns) == {n["node"] for n in e["nodes"]}
        for n in e["nodes"]:
            c = cns[n["node"]]
            assert (c["polled"], c["missing"]) == (n["polled"], n["missing"]), n["node"]
            assert c["response"] == us(n["response"])
            assert c["state"] == states.get(n["node"])
    if a["ecat"] is None:
        assert "ecat" not in doc
    else:
        e, w = a["ecat"], doc["ecat"]
        assert w["frames"] == a["counts"]["ecat"]
        want, want_keys = {}, ("datagrams", "port")
        for p in e["patterns"]:
            if p["cyclic"]:
                assert p["frames"] <= WINDOW
                off = sum(1 for d in e["wkc_deviations"] if d["pattern"] == p["pattern"])
                want[(p["datagrams"], p["port"])] = {
                    "sent": p["frames"],
                    "returned": p["returned"],
                    "lost": len(p["unanswered"]),
                    "period": us(p["period"]),
                    "round_trip": us(p["round_trip"]),
                    "wkc": p["expected_wkc"],
                    "wkc_deviations": off,
                }
        got = {
            (p["datagrams"], p["port"]): {k: v for k, v in p.items() if k not in want_keys}
            for p in w["patterns"]
        }
        assert got == want  # the same floats: analyze's JSON keeps them exactly
        assert [p["sent"] for p in w["patterns"]] == sorted(
            (p["sent"] for p in w["patterns"]), reverse=True
        )
        reported = {x["target"]: x["state"] for x in e["al_states"] if x["kind"] == "reported"}
        assert w["al_states"] == reported
    return doc


@pytest.mark.parametrize("name", SHARED)
def test_real_captures(shared_captures: Path, name: str) -> None:
    assert_same(shared_captures / name)


@pytest.mark.parametrize("name", ["ring.pcap", "ring.pcapng"])
def test_closed_ring_every_frame_returns_in_pcap_and_pcapng(
    emulated: dict[str, Path], name: str
) -> None:
    doc = assert_same(emulated[name])
    patterns = doc["ecat"]["patterns"]
    assert len({p["port"] for p in patterns}) == 2  # both master ports send each cycle
    assert all((p["sent"], p["returned"], p["lost"]) == (CYCLES, CYCLES, 0) for p in patterns)


@pytest.mark.parametrize("name", ["epl_drops.pcap", "epl_asnd_vlan.pcapng"])
def test_epl_with_missing_responses(emulated: dict[str, Path], name: str) -> None:
    doc = assert_same(emulated[name])
    assert sum(c["missing"] for c in doc["epl"]["cns"]) > 0


@pytest.mark.parametrize("name", ["ring_udp.pcap", "epl_udp.pcap"])
def test_over_udp_as_over_ethernet(emulated: dict[str, Path], name: str) -> None:
    """EPL and EtherCAT over IPv4/UDP: the figures and taxels of the same frames over
    Ethernet (EPL node ids from the IP addresses)."""
    plain = watched(emulated[name.replace("_udp", "_drops" if "epl" in name else "")])
    assert assert_same(emulated[name]) == plain
    assert plain["contact"]


@pytest.mark.parametrize("name", ["ecat_break.pcap", "ecat_vlan.pcap"])
def test_ecat_deviations_and_vlan(emulated: dict[str, Path], name: str) -> None:
    doc = assert_same(emulated[name])
    deviations = sum(p["wkc_deviations"] for p in doc["ecat"]["patterns"])
    assert (deviations > 0) == (name == "ecat_break.pcap")


# --- hand-made: a CN's ASnd between its PReq and its PRes -----------------------------------------
MN_MAC = "020000000af0"


def frame(dst: str, src_node: int, epl: str) -> bytes:
    """An EPL frame (EtherType 0x88AB) from node ``src_node``'s MAC (02:00:00:00:00:NN)."""
    return bytes.fromhex(dst + f"0200000000{src_node:02x}" + "88ab" + epl.replace(" ", "")).ljust(
        60, b"\0"
    )


def cycle() -> Iterator[bytes]:
    """DS 301 4.6.1.1: SoC (01), PReq (03) to CN 1 and CN 2, CN 1's ASnd (06, StatusResponse
    0x02) before its PRes (04, NMTStatus 0xFD OPERATIONAL, size 0), CN 2's PRes, SoA (05)."""
    yield frame("01111e000001", 240, "01 ff f0 00 00 00" + "00" * 16)
    for node in (1, 2):
        yield frame(f"0200000000{node:02x}", 240, f"03 {node:02x} f0 00 00 00 20 00 00 00")
        if node == 1:
            yield frame("01111e000004", 1, "06 f0 01 02" + "00" * 10)
        yield frame("01111e000002", node, f"04 ff {node:02x} fd 00 00 20 00 00 00")
    yield frame("01111e000003", 240, "05 ff f0 fd 00 00 00 00 20 00")


def test_a_cns_asnd_before_its_pres_is_no_missing_response(tmp_path: Path) -> None:
    path = tmp_path / "asnd_first.pcap"
    frames = [f for _ in range(3) for f in cycle()]
    path.write_bytes(pcap_bytes((1000 * i, f) for i, f in enumerate(frames)))
    doc = assert_same(path)
    cns = {c["node"]: (c["polled"], c["missing"], c["state"]) for c in doc["epl"]["cns"]}
    assert cns == {1: (3, 0, "OPERATIONAL"), 2: (3, 0, "OPERATIONAL")}
    # CN 1 answers 2 frames (2 us) after its PReq, CN 2 1 us after
    assert [c["response"]["median_us"] for c in doc["epl"]["cns"]] == [2.0, 1.0]


# --- the window -----------------------------------------------------------------------------------
def test_a_window_keeps_the_last_values_and_counts_everything(
    tshark: str, emulated: dict[str, Path]
) -> None:
    path = emulated["epl_drops.pcap"]
    rows = tshark_util.fields(tshark, path, ["frame.time_epoch"], "epl.mtyp == 1")
    socs = [int(r["frame.time_epoch"][0].replace(".", "")) for r in rows]  # 9 decimals: ns
    periods = [b - a for a, b in itertools.pairwise(socs)][-50:]
    full, last = watched(path), watched(path, window=50)
    assert last["epl"]["cycles"] == full["epl"]["cycles"] == len(socs) == 400
    assert last["epl"]["soc_period"] == pytest.approx(
        {
            "median_us": statistics.median(periods) / 1000,
            "min_us": min(periods) / 1000,
            "max_us": max(periods) / 1000,
            "jitter_us": statistics.pstdev(periods) / 1000,
        }
    )
    counts = {(c["node"], c["polled"], c["missing"]) for c in full["epl"]["cns"]}
    assert {(c["node"], c["polled"], c["missing"]) for c in last["epl"]["cns"]} == counts
    # working-counter deviations counted over the whole capture, whatever the window
    broken = emulated["ecat_break.pcap"]
    total = [p["wkc_deviations"] for p in watched(broken)["ecat"]["patterns"]]
    assert [p["wkc_deviations"] for p in watched(broken, window=10)["ecat"]["patterns"]] == total


def test_memory_does_not_grow_with_the_traffic(tmp_path: Path) -> None:
    short, long = tmp_path / "short.pcap", tmp_path / "long.pcap"
    argv = ["simulate", "epl", "--nodes", "4", "--bytes", "192", "--fault", "drop:2:0.02"]
    skinframes(*argv, "--cycles", "1000", "--pcap", str(short))
    skinframes(*argv, "--cycles", "8000", "--pcap", str(long))

    def peak(path: Path) -> int:
        return traced_peak(lambda: watched(path, window=200))

    watched(short)  # what the first run imports and caches is not the traffic's
    small, large = peak(short), peak(long)
    assert large < 1.2 * small, (small, large)  # unbounded series: 4x (1.2 MB against 0.3)
