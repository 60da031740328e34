"""``skinframes plot --map``: the design space, cycle time over nodes x bytes per protocol."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Final

import numpy as np
import numpy.typing as npt

from emulator.model.names import ECAT, ECAT_CLOSED_RING, EPL
from emulator.model.paper_tables import BYTES, FIGURE_MAX_NODES, NODES
from emulator.model.params import TimingParams, preset
from emulator.model.sweep import analytic_grid, cell_reason
from skinframes import ethercat
from skinframes.errors import SkinframesError
from skinframes_cli.figure import save_figure

PANELS: Final = (
    (EPL, "Ethernet POWERLINK"),
    (ECAT, "EtherCAT, open ring"),
    (ECAT_CLOSED_RING, "EtherCAT, closed ring"),
)
LEVELS_US: Final = (1_000.0, 5_000.0)  # the 1 ms and 5 ms loops
MAX_BYTES: Final = ethercat.MAX_DATAGRAM_DATA_BYTES  # 1486: the largest payload all three carry
COLOURS: Final = ("white", "orange")  # of the 1 ms and 5 ms contours
FIGSIZE_IN: Final = (17.0, 5.6)
DPI: Final = 110


@dataclass
class MapPanel:
    """One protocol's field and the contours drawn on it.

    Attributes:
        nodes, sizes: the axes (cell centres).
        cycle_us: (len(sizes), len(nodes)) analytic cycle times.
        contours: per level in us, the drawn lines as (k, 2) arrays of (nodes, bytes) points.
    """

    nodes: npt.NDArray[np.int64]
    sizes: npt.NDArray[np.int64]
    cycle_us: npt.NDArray[np.float64]
    contours: dict[float, list[npt.NDArray[np.float64]]] = field(default_factory=dict)


def make_map(
    out: Path,
    preset_name: str,
    nodes: int,
    data_bytes: int,
    *,
    params: TimingParams | None = None,
) -> dict[str, MapPanel]:
    """Draw the map into ``out`` (.png or .svg); returns what was drawn, per table. ``params``
    (``--cn-response-us``) in place of the preset's, when given."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    from matplotlib.lines import Line2D

    if out.suffix.lower() not in (".png", ".svg"):
        raise SkinframesError(f"{out}: the map is written as .png or .svg")
    if nodes < 1 or data_bytes < 0:
        raise SkinframesError(f"--nodes {nodes} --bytes {data_bytes}: no network")
    params = preset(preset_name) if params is None else params
    sizes = np.arange(1, MAX_BYTES + 1, dtype=np.int64)
    panels: dict[str, MapPanel] = {}
    for table, _ in PANELS:  # the nodes axis reaches your configuration (EPL blank past 239)
        ns = np.arange(1, max(FIGURE_MAX_NODES[table], nodes) + 1, dtype=np.int64)
        grid = analytic_grid(table, ns.tolist(), sizes.tolist(), params).T
        panels[table] = MapPanel(ns, sizes, grid)
    low = min(float(np.nanmin(p.cycle_us)) for p in panels.values())
    high = max(float(np.nanmax(p.cycle_us)) for p in panels.values())
    norm = LogNorm(vmin=low, vmax=high)
    fig, axes = plt.subplots(1, 3, figsize=FIGSIZE_IN, dpi=DPI, layout="constrained")
    mesh = None
    for ax, (table, title) in zip(axes, PANELS, strict=True):
        p = panels[table]
        mesh = ax.pcolormesh(
            p.nodes,
            p.sizes,
            p.cycle_us,
            norm=norm,
            cmap="viridis",
            shading="nearest",
            rasterized=True,
        )
        cs = ax.contour(
            p.nodes,
            p.sizes,
            p.cycle_us,
            levels=list(LEVELS_US),
            colors=list(COLOURS),
            linewidths=1.8,
        )
        for level, segs in zip(cs.levels, cs.allsegs, strict=True):
            p.contours[float(level)] = [np.asarray(s, dtype=np.float64) for s in segs if len(s)]
        px, py = np.meshgrid(NODES, BYTES)
        ax.plot(px.ravel(), py.ravel(), "x", color="red", ms=5, mew=1.2)
        fits = cell_reason(table, nodes, data_bytes) is None
        ax.plot(
            [nodes],
            [max(data_bytes, 1)],
            "*",
            ms=16,
            mfc="magenta" if fits else "none",
            mec="black",
            clip_on=False,
        )
        if fits:
            value = float(analytic_grid(table, [nodes], [data_bytes], params)[0, 0])
            title += f": {nodes} x {data_bytes} B = {value / 1000:.2f} ms"
        else:
            title += f": {nodes} x {data_bytes} B n/a"
        ax.set_yscale("log")
        ax.set_xlim(0.5, p.nodes[-1] + 0.5)
        ax.set_ylim(1, MAX_BYTES)
        ax.set_title(title)
        ax.set_xlabel("nodes")
        ax.set_ylabel("bytes per node")
    assert mesh is not None
    fig.colorbar(mesh, ax=axes, label="cycle time [us] (analytic, eqs. 3-19)", shrink=0.9)
    handles = [
        Line2D([], [], color=c, lw=2, label=f"{lv / 1000:g} ms")
        for lv, c in zip(LEVELS_US, COLOURS, strict=True)
    ]
    handles += [
        Line2D([], [], ls="", marker="x", color="red", label="the paper's 96 cells (Tables I-III)"),
        Line2D(
            [], [], ls="", marker="*", ms=12, mfc="magenta", mec="black", label="your configuration"
        ),
    ]
    fig.legend(
        handles=handles, loc="outside lower center", ncol=len(handles), fontsize=10, facecolor="0.7"
    )
    fig.suptitle(f"Cycle time over nodes x bytes per node, preset '{params.label}'")
    save_figure(fig, out, dpi=DPI)
    return panels
