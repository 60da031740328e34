"""``skinframes plot``: cycle time vs nodes per protocol and payload (the paper's Figs. 9-11)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Final

from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL, is_closed_ring
from emulator.model.paper_tables import FIGURE_MAX_NODES
from emulator.model.params import PRESETS, TimingParams
from skinframes import taxel
from skinframes.atomic_file import check_target
from skinframes.errors import SkinframesError
from skinframes.text import escape
from skinframes_cli.figure import save_figure
from skinframes_cli.options import add_cn_response, bounded_int, file_output, timing

STEP_NODES: Final = 20  # nodes between the emulated markers, unless --step

PAYLOADS = (2, 32, 128, 192, 256)
PANELS = (
    (EPL, "Ethernet POWERLINK (Fig. 9)"),
    (ECAT, "EtherCAT, open ring (Fig. 10)"),
    (ECAT_CLOSED_RING, "EtherCAT, closed ring (Fig. 11)"),
)


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "plot",
        help="cycle time vs nodes, analytic and emulated overlaid (PNG or SVG)",
        description="Plot cycle time against the number of nodes "
        f"(1..{FIGURE_MAX_NODES[EPL]} for EPL, 1..{FIGURE_MAX_NODES[ECAT]} for "
        "EtherCAT) for several payloads: the analytic model as lines, the emulator as markers, "
        "and the paper's printed table cells.",
    )
    p.add_argument(
        "--out",
        type=file_output,
        default=None,
        help="output file, .png or .svg (default cycle_time.png, with --map map.png)",
    )
    p.add_argument(
        "--preset", choices=list(PRESETS), default="paper", help="timing constants (default: paper)"
    )
    add_cn_response(p)
    p.add_argument(
        "--step",
        type=bounded_int(1, max(FIGURE_MAX_NODES.values())),
        default=None,
        help=f"nodes between emulated points, 1..240 (default {STEP_NODES}; not with --map)",
    )
    p.add_argument(
        "--map",
        action="store_true",
        help="the design space instead: cycle time over nodes x bytes per protocol, with the "
        "1 ms and 5 ms contours",
    )
    p.add_argument(
        "--nodes",
        type=bounded_int(1, 1024),
        default=None,
        help=f"--map: your configuration's nodes, drawn as a point, 1..1024 "
        f"(default {taxel.BODY_PATCHES})",
    )
    p.add_argument(
        "--bytes",
        type=bounded_int(1, 1490),
        default=None,
        help=f"--map: your configuration's bytes per node, 1..1490 (default {taxel.PATCH_BYTES})",
    )
    p.set_defaults(run=run)


def make_plot(
    out: Path, preset_name: str, step: int = STEP_NODES, *, params: TimingParams | None = None
) -> Path:
    """Draw the figure into ``out``; ``params`` (``--cn-response-us``) in place of the
    preset's, when given."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from tqdm import tqdm

    from emulator import analytic
    from emulator.model.paper_tables import BYTES, NODES, paper_value
    from emulator.model.params import PAPER, preset
    from emulator.model.units import PS_PER_US
    from emulator.net.sweep import cycle_ps_row

    if out.suffix.lower() not in (".png", ".svg"):
        raise SkinframesError(f"{out}: the plot is written as .png or .svg")
    if step < 1:
        raise SkinframesError("--step must be >= 1")
    check_target(out)  # a refused path or a missing folder fails now, not after the work
    params = preset(preset_name) if params is None else params
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2), constrained_layout=True)
    rows = [(t, n) for t, _ in PANELS for n in range(step, FIGURE_MAX_NODES[t] + 1, step)]
    emulated: dict[tuple[str, int], list[tuple[int, float]]] = {}
    sizes = np.array(PAYLOADS, dtype=np.int64)
    for t, n in tqdm(rows, desc="emulating", unit="row", disable=not sys.stderr.isatty()):
        # the engines' timing-only sweep: one cycle per payload (tests: equal to simulate)
        for b, ps in zip(PAYLOADS, cycle_ps_row(t, n, sizes, params).tolist(), strict=True):
            emulated.setdefault((t, b), []).append((n, ps / PS_PER_US))
    colors = plt.get_cmap("viridis")(np.linspace(0, 0.9, len(PAYLOADS)))
    for ax, (table, title) in zip(axes, PANELS, strict=True):
        nodes = np.arange(1, FIGURE_MAX_NODES[table] + 1)
        for b, color in zip(PAYLOADS, colors, strict=True):
            if table == EPL:
                y = analytic.epl_cycle_us(nodes, b, params)
            else:
                y = analytic.ecat_cycle_us(nodes, b, params, closed_ring=is_closed_ring(table))
            ax.plot(nodes, np.asarray(y) / 1000, color=color, lw=1.5, label=f"{b} B analytic")
            points_tb = emulated.get((table, b), [])  # none when --step exceeds this panel
            if points_tb:
                en, ey = zip(*points_tb, strict=True)
                ax.plot(en, np.asarray(ey) / 1000, "o", color=color, ms=4, mfc="none")
        if params == PAPER or (params.name == "paper" and table != EPL):  # (D_CN 1 us)
            px = [(n, paper_value(table, n, b)) for n in NODES for b in BYTES]
            ax.plot(
                [n for n, _ in px],
                [v / 1000 for _, v in px if v is not None],
                "kx",
                ms=5,
                label="paper's table",
            )
        for limit_ms, style in ((1.0, ":"), (5.0, "--")):
            ax.axhline(limit_ms, color="grey", ls=style, lw=0.8)
        ax.axvline(taxel.BODY_PATCHES, color="firebrick", lw=0.6, alpha=0.5)
        ax.set_title(title)
        ax.set_xlabel("nodes (patches)")
        ax.set_ylabel("cycle time [ms]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, title="o = emulated", title_fontsize=8)
    fig.suptitle(
        f"Cycle time vs nodes, preset '{params.label}' (dotted: 1 ms, dashed: 5 ms; "
        f"red: {taxel.BODY_PATCHES} patches)"
    )
    save_figure(fig, out)
    return out


def run(args: argparse.Namespace) -> int:
    """Draw and report the file."""
    ignored = ["--step"] if args.map else ["--nodes", "--bytes"]
    given = [o for o in ignored if getattr(args, o[2:]) is not None]
    if given:  # (information: a script that passes them keeps working)
        where = "not with --map" if args.map else "with --map only"
        print(f"note: {' and '.join(given)}: {where}; ignored", file=sys.stderr)
    if args.map:
        from skinframes_cli.plot_map import make_map

        out = Path("map.png" if args.out is None else args.out)
        nodes = taxel.BODY_PATCHES if args.nodes is None else args.nodes
        data_bytes = taxel.PATCH_BYTES if args.bytes is None else args.bytes
        make_map(out, args.preset, nodes, data_bytes, params=timing(args))
        print(f"wrote {escape(out)}")
        return 0
    step = STEP_NODES if args.step is None else args.step
    path = make_plot(Path(args.out or "cycle_time.png"), args.preset, step, params=timing(args))
    print(f"wrote {escape(path)}")
    return 0
