"""CAN vs EPL vs EtherCAT: `compare`, `can convert`, and the skin bus behind them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from emulator.net.can_bus import skin_bus
from skinframes import decode_frame, ethercat, powerlink, read_capture, taxel
from skinframes.canbus import frame_bits
from skinframes.canbus.log import write_can_log
from skinframes_cli import main

BOARDS = [8, 9, 10]
SAMPLES = 3
PERIOD_PS = 50_000_000_000  # 50 ms, the firmware default


@pytest.fixture(scope="module")
def skin_trace(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    taxels = taxel.contact_pattern(len(BOARDS), SAMPLES, seed=11)
    frames, _ = skin_bus(BOARDS, taxels, PERIOD_PS)
    path = tmp_path_factory.mktemp("can") / "skin.log"
    write_can_log(path, frames)
    return path, taxels


def test_can_figure_is_the_sum_of_exact_frame_times(
    skin_trace: tuple[Path, np.ndarray], capsys: pytest.CaptureFixture[str]
) -> None:
    path, taxels = skin_trace
    assert main(["compare", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    # hand sum: every frame of every board, frame_bits each, 1 us per bit at 1 Mbit/s
    per_sample = []
    for k in range(SAMPLES):
        bits = 0
        for i, board in enumerate(BOARDS):
            for t in range(16):
                head = bytes([0x40, *taxels[k, i, t, :7]])
                tail = bytes([0xC0, *taxels[k, i, t, 7:], 0, 0])
                ident = 4 << 8 | board << 4 | t
                bits += frame_bits(ident, head) + frame_bits(ident, tail)
        per_sample.append(bits)
    assert doc["can"]["cycle_us"] == pytest.approx(float(np.median(per_sample)))
    assert doc["period_us"] == pytest.approx(50_000)
    assert doc["can"]["bus_load"] == pytest.approx(doc["can"]["cycle_us"] / 50_000)
    # the bus re-emulated from the same frames: they were scheduled back to back
    assert doc["can"]["emulated"]["cycle_us"] == pytest.approx(doc["can"]["cycle_us"], rel=0.02)
    for bus in ("can", "epl", "ecat"):
        assert set(doc[bus]) >= {
            "cycle_us",
            "bus_load",
            "wire_bytes_per_sample",
            "max_nodes_1ms",
            "max_nodes_5ms",
        }
        # the old keys stay beside the new ones with the same values (interface doc, Old names)
        assert doc[bus]["max_patches_1ms"] == doc[bus]["max_nodes_1ms"]
        assert doc[bus]["max_patches_5ms"] == doc[bus]["max_nodes_5ms"]
    assert doc["ecat"]["cycle_us"] < doc["epl"]["cycle_us"] < doc["can"]["cycle_us"]
    # arbitration: lower board addresses have lower ids and finish first; the last one finishes
    # with the sample (per-board latency from the period start)
    latency = doc["can"]["emulated"]["latency_us"]
    assert list(latency) == [str(b) for b in BOARDS]
    assert latency["8"] < latency["9"] < latency["10"] == doc["can"]["emulated"]["cycle_us"]
    assert doc["can"]["max_nodes_1ms"] == 0  # 32 frames of ~115 bits > 1 ms per board
    assert doc["ecat"]["max_nodes_5ms"] > doc["epl"]["max_nodes_5ms"] > 1


@pytest.mark.parametrize("target", ["epl", "ecat"])
def test_convert_carries_every_taxel_of_every_sample_in_order(
    skin_trace: tuple[Path, np.ndarray],
    tmp_path: Path,
    target: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path, taxels = skin_trace
    out = tmp_path / f"{target}.pcap"
    assert main(["can", "convert", str(path), "--to", target, "--pcap", str(out)]) == 0
    got: list[bytes] = []
    for rec in read_capture(out):
        frame = decode_frame(rec.data)
        m = frame.payload
        if isinstance(m, powerlink.PRes):
            got.append(m.payload)
        elif isinstance(m, ethercat.EcatFrame) and frame.src[0] & ethercat.RETURNED_MAC_BIT:
            got += [d.data for d in m.datagrams]
    want = [taxels[k, i].tobytes() for k in range(SAMPLES) for i in range(len(BOARDS))]
    assert got == want


def test_compare_plot_and_text(
    skin_trace: tuple[Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    png = tmp_path / "cmp.png"
    assert main(["compare", str(skin_trace[0]), "--plot", str(png)]) == 0
    text = capsys.readouterr().out
    assert "CAN as recorded" in text and "EtherCAT" in text
    # the nodes columns count whole 192-byte patches, whatever the log's boards carry
    assert text.splitlines()[2].endswith("192-B nodes  192-B nodes")
    assert text.splitlines()[3].endswith("in 1 ms      in 5 ms")
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_compare_without_skin_data_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from skinframes.canbus import CanFrame

    path = tmp_path / "other.log"
    write_can_log(path, [CanFrame(0x123, b"\x01\x02", time_ns=1000)])
    assert main(["compare", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("skinframes: error:")


def test_compare_and_convert_report_a_truncated_log_as_can_decode_does(
    skin_trace: tuple[Path, np.ndarray], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import gzip

    packed = gzip.compress(skin_trace[0].read_bytes())
    cut = tmp_path / "cut.log.gz"
    cut.write_bytes(packed[: len(packed) // 2])  # the reader stops at the end: EOFError
    assert main(["can", "decode", str(cut)]) == 0
    (stopped,) = [
        line for line in capsys.readouterr().err.splitlines() if line.startswith("skipped record")
    ]
    assert "EOFError" in stopped and stopped.endswith("rest of file unread")
    out = tmp_path / "cut.pcap"
    assert main(["can", "convert", str(cut), "--to", "epl", "--pcap", str(out)]) == 0
    assert stopped in capsys.readouterr().err.splitlines()
    assert main(["compare", str(cut), "--json"]) == 0
    captured = capsys.readouterr()
    assert stopped in captured.err.splitlines()
    assert json.loads(captured.out)["left_out"]["damaged_records"] == 1


def test_convert_and_compare_keep_every_complete_sample_and_say_what_they_left_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from can_hand_log import TRIANGLES, hand_built_log, taxels_of

    path = hand_built_log(tmp_path)
    out = tmp_path / "hand.pcap"
    assert main(["can", "convert", str(path), "--to", "ecat", "--pcap", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("3 samples of 2 boards (13, 14)")
    (left,) = captured.err.splitlines()
    assert left.startswith("left out: 2 incomplete board samples; 3 stray skin frames")
    assert "board 10: 1 incomplete, 0 stray" in left and "0x4e1: 2" in left
    assert "not carried: 10" in left and "board 13: 1" in left
    got = [
        d.data
        for rec in read_capture(out)
        if (frame := decode_frame(rec.data)).src[0] & ethercat.RETURNED_MAC_BIT
        and isinstance(frame.payload, ethercat.EcatFrame)
        for d in frame.payload.datagrams
    ]
    no_load = bytes([taxel.NO_LOAD]) * (12 * TRIANGLES)
    want = [
        no_load
        if (period, board) == (1, 13)
        else b"".join(bytes(taxels_of(board, period, t)) for t in range(TRIANGLES))
        for period in range(3)
        for board in (13, 14)
    ]
    assert got == want
    assert main(["compare", str(path), "--json"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert doc["samples"] == 3 and doc["boards"] == [13, 14]
    lo = doc["left_out"]
    assert (lo["incomplete_samples"], lo["stray_frames"]) == (2, 3)
    assert lo["boards_without_sample"] == [10]
    assert lo["cycles_missing_board"] == {"13": 1}
    assert [b["board"] for b in lo["boards"]] == [10, 13, 14]
    assert captured.err.startswith("left out:")


def test_the_most_patches_within_a_budget_are_where_simulate_crosses_it(
    skin_trace: tuple[Path, np.ndarray], capsys: pytest.CaptureFixture[str]
) -> None:
    """compare finds the limits with the timing-only sweep; simulate itself puts each limit
    exactly there: k patches of 192 bytes fit the budget, k + 1 do not."""
    from emulator import WIRE, simulate_ecat, simulate_epl

    assert main(["compare", str(skin_trace[0]), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    runs = {"epl": simulate_epl, "ecat": simulate_ecat}
    for bus, simulate in runs.items():
        for budget_us in (1_000, 5_000):
            k = doc[bus][f"max_nodes_{budget_us // 1000}ms"]
            assert simulate(k, 192, WIRE, cycles=1).cycle_us()["max"] <= budget_us
            assert simulate(k + 1, 192, WIRE, cycles=1).cycle_us()["max"] > budget_us
