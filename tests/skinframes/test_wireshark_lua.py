"""The Lua plugin, loaded by the system tshark, shows the taxels taxels_from_capture reads."""

from __future__ import annotations

import re
import subprocess
import xml.etree.ElementTree as ET
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
import tshark_util
from conftest import IN_CI

from emulator import PAPER, simulate_ecat, simulate_epl
from skinframes import taxel, taxels_from_capture
from skinframes.errors import FieldRangeError
from skinframes.wireshark_lua import lua_plugin
from skinframes_cli import main

pytestmark = pytest.mark.tshark
TAXEL_TEXT = re.compile(r"Taxel (\d+): (\d+)")


@pytest.fixture(scope="module")
def lua_tshark(tshark: str) -> str:
    """tshark built with Lua; skips loudly without it, fails under CI=true (as tshark does)."""
    version = subprocess.run(
        [tshark, "-v"], capture_output=True, text=True, timeout=60, check=False
    ).stdout
    if "with Lua" not in version:
        reason = (
            "this tshark has no Lua (tshark -v does not say 'with Lua'): the Wireshark plugin "
            "cannot be tested. Install a Wireshark build with Lua (Debian's tshark has it)."
        )
        if IN_CI:
            pytest.fail("CI=true: " + reason)
        pytest.skip(reason)
    return tshark


def emulate(tmp_path: Path, protocol: str, layout: str, nodes: int, data_bytes: int) -> Path:
    path = tmp_path / f"{protocol}_{layout}.pcap"
    if protocol == "epl":
        simulate_epl(nodes, data_bytes, PAPER, cycles=4, seed=11, pcap=path)
    else:
        simulate_ecat(nodes, data_bytes, PAPER, layout=layout, cycles=4, seed=11, pcap=path)
    return path


def plugin_taxels(
    tshark: str, script: Path, capture: Path
) -> list[tuple[int, int, int, int, int, bool]]:
    """(frame time ns, patch, triangle, taxel, value, contact) for every taxel the plugin shows."""
    pdml = tshark_util.run(tshark, capture, "-X", f"lua_script:{script}", "-T", "pdml")
    out = []
    for packet in ET.fromstring(pdml).iter("packet"):
        epoch = packet.find(".//field[@name='frame.time_epoch']")
        assert epoch is not None
        time_ns = int(Decimal(epoch.get("show", "")) * 1_000_000_000)
        for patch in packet.iter("field"):
            if patch.get("name") != "skin.patch":
                continue
            for tri in patch.findall("field[@name='skin.triangle']"):
                contact = tri.find("field[@name='skin.contact']") is not None
                for tx in tri.findall("field[@name='skin.taxel']"):
                    m = TAXEL_TEXT.fullmatch(tx.get("showname", ""))
                    assert m, tx.get("showname")
                    out.append(
                        (
                            time_ns,
                            int(patch.get("show", "")),
                            int(tri.get("show", "")),
                            int(m.group(1)),
                            int(m.group(2)),
                            contact,
                        )
                    )
    return out


@pytest.mark.parametrize(
    ("protocol", "layout", "nodes", "data_bytes"),
    [
        ("epl", "per-slave", 5, 192),
        ("epl", "per-slave", 3, 40),
        ("ecat", "per-slave", 9, 192),
        ("ecat", "per-slave", 9, 100),
        ("ecat", "logical", 12, 192),
        ("ecat", "logical", 7, 50),
    ],
)
def test_the_plugin_shows_the_taxels_of_taxels_from_capture(
    lua_tshark: str, tmp_path: Path, protocol: str, layout: str, nodes: int, data_bytes: int
) -> None:
    capture = emulate(tmp_path, protocol, layout, nodes, data_bytes)
    script = tmp_path / "skin.lua"
    argv = ["wireshark-plugin", "--out", str(script), "--bytes", str(data_bytes)]
    assert main([*argv, "--nodes", str(nodes), "--layout", layout]) == 0
    ours = taxels_from_capture(capture, nodes=nodes, bytes_per_node=data_bytes, layout=layout)
    shown = plugin_taxels(lua_tshark, script, capture)
    width = min(data_bytes, taxel.PATCH_BYTES)
    assert len(shown) == ours.present.sum() * width  # every taxel once, nothing more
    seen = np.zeros(ours.taxels.shape, dtype=bool)
    for time_ns, patch, tri, k, value, contact in shown:
        sample = int(np.searchsorted(ours.time_ns, time_ns, side="right")) - 1
        assert ours.taxels[sample, patch, tri, k] == value, (sample, patch, tri, k)
        seen[sample, patch, tri, k] = True
        pressed = taxel.in_contact(ours.taxels[sample, patch, tri])
        # a triangle split between two datagrams (logical) judges the taxels it holds
        if not contact:
            assert value >= taxel.CONTACT_THRESHOLD
        elif (12 * tri + 12) <= width:
            assert pressed
    flat = seen.reshape(*seen.shape[:2], -1)[:, :, :width]
    assert np.array_equal(flat.all(axis=2), ours.present)


def test_the_contact_filter_selects_frames_with_touch(lua_tshark: str, tmp_path: Path) -> None:
    capture = emulate(tmp_path, "epl", "per-slave", 6, 192)
    script = tmp_path / "skin.lua"
    assert main(["wireshark-plugin", "--out", str(script)]) == 0
    ours = taxels_from_capture(capture)
    touched = int(np.count_nonzero(taxel.in_contact(ours.taxels).any(axis=2)))
    assert touched > 0  # the seeded pattern presses some patches
    frames = tshark_util.run(
        lua_tshark, capture, "-X", f"lua_script:{script}", "-Y", "skin.contact"
    ).splitlines()
    assert len(frames) == touched  # one PRes per (sample, node)


def test_plugin_arguments_are_checked(tmp_path: Path) -> None:
    with pytest.raises(FieldRangeError):
        lua_plugin(bytes_per_node=0)
    with pytest.raises(FieldRangeError):
        lua_plugin(layout="ring")
    assert main(["wireshark-plugin", "--out", str(tmp_path / "no" / "x.lua")]) == 2
    assert main(["wireshark-plugin", "--out", str(tmp_path / "x.lua"), "--nodes", "0"]) == 2
    text = lua_plugin(nodes=4, bytes_per_node=24, layout="per-slave")
    assert "@" not in text.replace("@VERSION", "") and f"= {taxel.CONTACT_THRESHOLD}" in text
