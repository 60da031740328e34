"""``skinframes demo [--out DIR]``: the main job on defaults."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Final

from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL, old_name
from skinframes import golden, taxel
from skinframes.atomic_file import atomic_output, output_folder
from skinframes.check import check_capture
from skinframes.errors import CaptureError
from skinframes.pcap import read_capture, write_pcap
from skinframes.text import escape
from skinframes_cli.options import file_output

NODES = taxel.BODY_PATCHES  # 160 patches
BYTES = taxel.PATCH_BYTES  # 192 bytes each
LOOPS_MS = (1, 5)
RUNS = (
    (EPL, "EPL, MN + CNs via hubs"),
    (ECAT, "EtherCAT open ring"),
    (ECAT_CLOSED_RING, "EtherCAT closed ring"),
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
    p.add_argument(
        "--out",
        type=file_output,
        default="out",
        help="output directory (default: ./out); created if its parent exists",
    )
    p.add_argument("--no-plot", action="store_true", help="write no picture (faster)")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace files of demo's names that demo did not write (and symbolic links)",
    )
    p.set_defaults(run=run)


MANIFEST: Final = ".skinframes-demo"  # in DIR: the names demo wrote there, one per line
_MANIFEST_HEAD: Final = "# files written by 'skinframes demo'; it replaces only these\n"


def _pcap_name(table: str, preset_name: str) -> str:
    """``ecat_redundant_160x192_wire.pcap``: the file names keep the closed ring's old name
    (scripts open them by name; docs/interface.md, "Old names")."""
    return f"{old_name(table)}_{NODES}x{BYTES}_{preset_name}.pcap"


def output_names(plots: bool) -> list[str]:
    """Every file name ``demo`` writes into its folder, in the order it writes them."""
    from emulator.model.params import PRESETS

    names = [_pcap_name(table, p) for table, _ in RUNS for p in PRESETS]
    names.append("skin_can.asc")
    if plots:
        names.append("compare.png")
    names += [f"{scenario}.pcap" for scenario in golden.SCENARIOS]
    if plots:
        names.append("cycle_time.png")
    return names


def _manifest(out: Path, force: bool) -> set[str]:
    """The names an earlier demo listed in ``out/.skinframes-demo``; a file of that name that
    does not start with demo's first line is not demo's: refused unless ``force`` (which
    replaces it and trusts no name on it)."""
    path = out / MANIFEST
    if path.is_symlink() or (path.exists() and not path.is_file()):
        raise CaptureError(f"{path}: not a regular file; demo keeps its list of files there")
    if not path.exists():
        return set()
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise CaptureError(f"{path}: cannot read ({exc.strerror or exc})") from exc
    if not text.startswith(_MANIFEST_HEAD):
        if force:
            return set()
        raise CaptureError(
            f"{path}: exists and was not written by demo (its first line is not demo's); "
            "move it away or use --force"
        )
    return {line for line in text.splitlines() if line and not line.startswith("#")}


def prepare_out(out: Path, names: list[str], force: bool) -> None:
    """Make sure ``demo`` may write ``names`` into ``out``, and record them in the manifest.

    Demo writes only its own files: a name that exists and is not in ``out/.skinframes-demo``
    (the list of files an earlier demo wrote), or that is a symbolic link, is refused unless
    ``force``; with ``force`` a symbolic link is removed (never followed). ``out`` is created
    when its parent exists (never ``mkdir -p``).

    Raises:
        CaptureError: a name is refused, or ``out`` is not a folder demo can use.
    """
    if out.is_symlink() and not force:
        raise CaptureError(f"{out}: is a symbolic link; demo does not write through it (--force)")
    output_folder(out)  # created if its parent exists, as every output folder
    ours = _manifest(out, force)
    for name in names:
        path = out / name
        if path.is_symlink():
            if not force:
                raise CaptureError(
                    f"{path}: is a symbolic link; demo does not write through it (--force "
                    "replaces the link)"
                )
            path.unlink()
        elif path.exists() and name not in ours and not force:
            raise CaptureError(
                f"{path}: exists and was not written by demo (not in {MANIFEST}); "
                "move it away or use --force"
            )
    with atomic_output(out / MANIFEST, "w") as f:
        f.write(_MANIFEST_HEAD + "".join(f"{n}\n" for n in sorted(ours | set(names))))


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
    prepare_out(out, output_names(not args.no_plot), args.force)
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
            path = out / _pcap_name(table, pname)
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
    files += _can_comparison(out, plots=not args.no_plot)
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
        print(f"  {escape(path)!s:<46} {what}  {status}")
    return 0


CAN_BOARDS = list(range(8, 15))  # a 7-board skin bus, as on the iCub's arm (can.md 1.5)
CAN_SAMPLES = 5


def _can_comparison(out: Path, plots: bool = True) -> list[tuple[Path, str]]:
    """Write a legacy skin CAN log (7 boards, 50 ms period) and compare the buses on it."""
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
    files = [(can_log_path, f"skin CAN log: {len(CAN_BOARDS)} boards, {CAN_SAMPLES} samples")]
    if plots:
        files.append((plot(doc, out / "compare.png"), "CAN vs EPL vs EtherCAT for that log"))
    return files
