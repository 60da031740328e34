"""``skinframes demo [--out DIR]``: the main job on defaults."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from skinframes import golden, taxel
from skinframes.check import check_capture
from skinframes.pcap import read_capture, write_pcap

NODES = taxel.BODY_PATCHES  # 160 patches
BYTES = taxel.PATCH_BYTES  # 192 bytes each
LOOPS_MS = (1, 5)
RUNS = (
    ("epl", "EPL, MN + CNs via hubs"),
    ("ecat", "EtherCAT open ring"),
    ("ecat_redundant", "EtherCAT closed ring"),
)


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "demo",
        help=f"the main job: a {NODES}-patch skin over EPL and EtherCAT",
        description=f"Emulate a {NODES}-patch skin ({BYTES} bytes each) over EPL, EtherCAT "
        "open ring and closed ring with both timing presets; write the pcaps, a "
        "plot and the reference captures under DIR; print the cycle times.",
    )
    p.add_argument("--out", default="out", help="output directory (default: ./out)")
    p.add_argument("--no-plot", action="store_true", help="skip the figure (faster)")
    p.set_defaults(run=run)


def _status(path: Path) -> str:
    report = check_capture(read_capture(path))
    if report.errors or report.warnings:
        return f"check: {report.errors} errors, {report.warnings} warnings"
    return "check: clean"


def run(args: argparse.Namespace) -> int:
    """Emulate, write and report."""
    from emulator.model.cycle_time import simulate
    from emulator.model.params import PRESETS
    from skinframes_cli.plot import make_plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"A {NODES}-patch skin, {BYTES} taxel bytes per patch, measured at the master's port\n")
    print(
        f"{'network':<24}"
        + "".join(f"{name + ' preset':>16}" for name in PRESETS)
        + "".join(f"{f'fits {ms} ms':>11}" for ms in LOOPS_MS)
    )
    files = []
    for table, name in RUNS:
        cycle = {}
        for pname, params in PRESETS.items():
            path = out / f"{table}_{NODES}x{BYTES}_{pname}.pcap"
            r = simulate(table, NODES, BYTES, params, cycles=3, seed=1, pcap=path)
            files.append((path, f"{name}, {pname} preset, {r.cycles} cycles, {r.frames} frames"))
            cycle[pname] = r.cycle_us()["median"]
        worst = max(cycle.values())
        fits = "".join(f"{'yes' if worst <= ms * 1000 else 'no':>11}" for ms in LOOPS_MS)
        print(f"{name:<24}" + "".join(f"{cycle[p]:>13.2f} us" for p in PRESETS) + fits)
    print(
        "\n('fits' uses the slower preset: a reactive loop of that period can read every taxel"
        " once per cycle)"
    )
    files += _can_comparison(out)
    for scenario in golden.SCENARIOS:
        path = out / f"{scenario}.pcap"
        write_pcap(path, golden.build(scenario))
        files.append((path, "reference frames (same bytes as pcaps/)"))
    if not args.no_plot:
        plot = make_plot(out / "cycle_time.png", "paper")
        files.append((plot, "cycle time vs nodes, analytic and emulated, paper preset"))
    print("\nFiles:")
    for path, what in files:
        status = _status(path) if path.suffix == ".pcap" else ""
        print(f"  {path!s:<46} {what}  {status}")
    return 0


CAN_BOARDS = list(range(8, 15))  # a 7-board skin bus, as on the iCub's arm (can.md 1.5)
CAN_SAMPLES = 5


def _can_comparison(out: Path) -> list[tuple[Path, str]]:
    """Write a legacy skin CAN trace (7 boards, 50 ms period) and compare the buses on it."""
    import math

    from emulator.compare import compare, samples_of
    from emulator.model.params import WIRE
    from emulator.net.can_bus import skin_bus
    from skinframes.canbus import DEFAULT_PERIOD_MS, MAX_BOARD
    from skinframes.canbus.log import read_can_log, write_can_log
    from skinframes_cli.compare import plot, print_table

    taxels = taxel.contact_pattern(len(CAN_BOARDS), CAN_SAMPLES, seed=2)
    frames, _ = skin_bus(CAN_BOARDS, taxels, DEFAULT_PERIOD_MS * 1_000_000_000)
    can_log_path = out / "skin_can.asc"
    write_can_log(can_log_path, frames)
    doc = compare(samples_of(read_can_log(can_log_path)), WIRE)
    print(
        "\nThe legacy CAN bus against EPL and EtherCAT, on the same taxels (skinframes compare):\n"
    )
    print_table(doc)
    per_board_us = doc["can"]["cycle_us"] / len(CAN_BOARDS)
    per_bus = min(MAX_BOARD - 1, int(DEFAULT_PERIOD_MS * 1000 // per_board_us))
    print(
        f"\n{NODES} patches on CAN: {per_bus} boards fit one 1 Mbit/s bus at "
        f"{DEFAULT_PERIOD_MS} ms, so {math.ceil(NODES / per_bus)} buses; one EtherCAT ring "
        "carries them all in under 3 ms."
    )
    png = plot(doc, out / "compare.png")
    return [
        (can_log_path, f"skin CAN trace: {len(CAN_BOARDS)} boards, {CAN_SAMPLES} samples"),
        (png, "CAN vs EPL vs EtherCAT for that trace"),
    ]
