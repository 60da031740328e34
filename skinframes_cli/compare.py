"""``skinframes compare LOG``: a CAN log's taxel load on CAN, EPL and EtherCAT side by side."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from emulator.model.params import PRESETS
from skinframes import taxel
from skinframes.errors import SkinframesError
from skinframes_cli.can import damage_report
from skinframes_cli.figure import save_figure
from skinframes_cli.options import add_can_log, can_log_suffix, file_output
from skinframes_cli.progress import progress_bar
from skinframes_cli.streams import input_path

ROWS = (
    ("can", "CAN as recorded"),
    ("can_emulated", "CAN re-emulated"),
    ("epl", "EPL"),
    ("ecat", "EtherCAT (open ring)"),
)


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "compare",
        help="a CAN log's taxels on CAN vs EPL vs EtherCAT, side by side",
        description="Read a skin CAN log (any python-can format or a SocketCAN pcap) and report, "
        "for its boards and samples, the cycle time, bus load and wire bytes per sample on the "
        "CAN bus (as recorded and as re-emulated), EPL and EtherCAT, and how many "
        f"{taxel.PATCH_BYTES}-byte patches each bus serves within 1 ms and 5 ms.",
    )
    add_can_log(p, "CAN log (.log .asc .blf .trc .csv, or a SocketCAN pcap)")
    p.add_argument(
        "--preset",
        choices=list(PRESETS),
        default="wire",
        help="Ethernet timing constants (default: wire)",
    )
    p.add_argument(
        "--plot",
        type=file_output,
        metavar="FILE",
        help="also draw the comparison (.png or .svg)",
    )
    p.add_argument("--json", action="store_true", help="one JSON document")
    p.set_defaults(run=run)


def comparison(trace_path: str, preset_name: str) -> dict[str, Any]:
    """The comparison document for a CAN log file."""
    from emulator.compare import SkinLog, compare
    from emulator.model.params import preset

    return compare(SkinLog.open(trace_path), preset(preset_name))


def _rows(doc: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    can = dict(doc["can"])
    emulated = dict(can.pop("emulated"))
    emulated.pop("latency_us", None)
    emulated.update(
        {k: can[k] for k in ("wire_bytes_per_sample", "max_nodes_1ms", "max_nodes_5ms")}
    )
    values = {"can": can, "can_emulated": emulated, "epl": doc["epl"], "ecat": doc["ecat"]}
    return [(label, values[key]) for key, label in ROWS]


def print_table(doc: dict[str, Any]) -> None:
    """The side-by-side table."""
    print(
        f"{len(doc['boards'])} board{'s' * (len(doc['boards']) != 1)} x {doc['triangles']} "
        f"triangles ({doc['bytes_per_board']} "
        f"bytes each), {doc['samples']} samples every {doc['period_us'] / 1000:g} ms; "
        f"Ethernet preset {doc['preset']}\n"
    )
    nodes = f"{taxel.PATCH_BYTES}-B nodes"  # whole patches, whatever the log's boards carry
    print(f"{'bus':<22}{'cycle':>13}{'bus load':>10}{'wire bytes':>12}{nodes:>13}{nodes:>13}")
    print(f"{'':<22}{'[us]':>13}{'':>10}{'per sample':>12}{'in 1 ms':>13}{'in 5 ms':>13}")
    for label, v in _rows(doc):
        print(
            f"{label:<22}{v['cycle_us']:>13.2f}{100 * v['bus_load']:>9.2f}%"
            f"{v['wire_bytes_per_sample']:>12.0f}{v['max_nodes_1ms']:>13}"
            f"{v['max_nodes_5ms']:>13}"
        )


def plot(doc: dict[str, Any], out: Path) -> Path:
    """Bars of cycle time per bus, log scale, with the 1 ms and 5 ms loops."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if out.suffix.lower() not in (".png", ".svg"):
        raise SkinframesError(f"{out}: the plot is written as .png or .svg")
    rows = _rows(doc)
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    labels = [label for label, _ in rows]
    values = [v["cycle_us"] / 1000 for _, v in rows]
    bars = ax.bar(labels, values, color=["#8c564b", "#c49c94", "#1f77b4", "#2ca02c"])
    ax.bar_label(bars, [f"{v:.3g} ms" for v in values])
    ax.set_yscale("log")
    for ms, style in ((1, ":"), (5, "--")):
        ax.axhline(ms, color="grey", ls=style, lw=0.8)
    ax.axhline(doc["period_us"] / 1000, color="firebrick", lw=0.8)
    ax.set_ylabel("time to move one sample of every board [ms]")
    ax.set_title(
        f"{len(doc['boards'])} skin boards: CAN vs EPL vs EtherCAT "
        f"(dotted 1 ms, dashed 5 ms, red: sample period)"
    )
    save_figure(fig, out)
    return out


def run(args: argparse.Namespace) -> int:
    """Compare and report."""
    from emulator.compare import SkinLog, compare
    from emulator.model.params import preset

    with input_path(args.trace, can_log_suffix(args)) as trace:
        with progress_bar(None, "frames") as seen:  # read twice, never held (skin_samples)
            samples = SkinLog.open(trace, progress=seen)
        with progress_bar(samples.samples, "cycles") as done:
            doc = compare(samples, preset(args.preset), progress=done)
    if samples.left_out.anything:
        print(samples.left_out.text(), file=sys.stderr)
    damage_report(samples.left_out.damaged, samples.left_out.damaged_records)
    if args.plot:
        plot(doc, Path(args.plot))
    if args.json:
        print(json.dumps(doc, indent=2))
    else:
        print_table(doc)
        if args.plot:
            print(f"\nplot: {args.plot}")
    return 0
