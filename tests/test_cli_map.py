"""``plot --map``: the design space per protocol, its contours checked against the model's cells."""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

from emulator.model.cycle_time import cycle_us
from emulator.model.params import PAPER
from skinframes_cli import main
from skinframes_cli.plot_map import DPI, FIGSIZE_IN, LEVELS_US, make_map


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) from the PNG's IHDR chunk (PNG spec 11.2.2)."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
    width, height = struct.unpack(">II", head[16:24])
    return width, height


def test_map_png_and_its_contours(tmp_path: Path) -> None:
    out = tmp_path / "map.png"
    panels = make_map(out, "paper", 160, 192)
    assert png_size(out) == (round(FIGSIZE_IN[0] * DPI), round(FIGSIZE_IN[1] * DPI))
    assert list(panels) == ["epl", "ecat", "ecat_closed_ring"]
    for table, p in panels.items():
        assert sorted(p.contours) == sorted(LEVELS_US)
        for level, lines in p.contours.items():
            assert lines, f"{table}: no {level} us contour"
            for xy in lines:
                for x, y in xy:
                    # the line passes between cells whose cycle times lie on both sides of it,
                    # each computed by the scalar model
                    ns = {int(np.floor(x)), int(np.ceil(x))}
                    bs = {int(np.floor(y)), int(np.ceil(y))}
                    values = [cycle_us(table, n, b, PAPER) for n in ns for b in bs]
                    assert min(values) <= level <= max(values), (table, level, x, y)
    # the paper's own numbers on both sides of 1 ms: Table II 130 x 32 = 646.03 us, 130 x 128 =
    # 1673.23 us, so the open ring's 1 ms line crosses 130 nodes between 32 and 128 bytes
    crossing = [y for xy in panels["ecat"].contours[1000.0] for x, y in xy if x == 130]
    assert crossing and all(32 < y < 128 for y in crossing)


def test_the_nodes_axis_reaches_your_configuration(tmp_path: Path) -> None:
    """1000 patches (``--nodes`` allows 1..1024): every panel's nodes axis runs to 1000, so the
    star lands inside it; EPL's field is empty beyond its 239 CNs (DS 301 node ids). Drawn
    with matplotlib's warnings as errors: once the star sat beyond the axes and the layout
    collapsed ("constrained_layout not applied")."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        panels = make_map(tmp_path / "map.png", "paper", 1000, 192)
    for p in panels.values():
        assert p.nodes[0] == 1 and p.nodes[-1] == 1000
    epl = panels["epl"].cycle_us
    assert np.isnan(epl[:, 239:]).all() and not np.isnan(epl[:, :239]).any()
    assert not np.isnan(panels["ecat"].cycle_us).any()


def test_map_cli_svg(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "map.svg"
    argv = ["plot", "--map", "--out", str(out), "--preset", "wire", "--nodes", "240"]
    assert main([*argv, "--bytes", "64"]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    assert out.read_text().lstrip().startswith("<?xml")
    assert main(["plot", "--map", "--out", str(tmp_path / "map.gif")]) == 2
    assert main(["plot", "--map", "--out", str(tmp_path / "no" / "map.png")]) == 2
    assert not (tmp_path / "map.gif").exists()


def test_options_the_other_figure_takes_are_noted_as_ignored(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--nodes/--bytes place your configuration on the map; --step spaces the plot's markers:
    given to the other figure, each was once ignored without a word."""
    argv = ["plot", "--map", "--out", str(tmp_path / "m.png"), "--step", "5"]
    assert main(argv) == 0
    assert "note: --step: not with --map; ignored" in capsys.readouterr().err
    argv = ["plot", "--out", str(tmp_path / "p.png"), "--step", "120", "--nodes", "100"]
    assert main(argv) == 0
    assert "note: --nodes: with --map only; ignored" in capsys.readouterr().err
    assert main(["plot", "--map", "--out", str(tmp_path / "m.png"), "--nodes", "100"]) == 0
    assert "note:" not in capsys.readouterr().err
