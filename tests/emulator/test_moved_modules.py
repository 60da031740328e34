"""The modules that left ``emulator.esc`` (issue 39) still import under their old names.

The slave behind the ESC is ``emulator.slave`` and the hostile traffic ``emulator.hostile``;
``emulator/esc/__init__.py`` keeps each old path as an alias of the new module (docs/interface.md,
"Python"), the very same module object, imported only when the old name is. Each check runs in a
fresh interpreter, where nothing imported it before.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# old name -> new name: what docs/interface.md lists
MOVED = {
    **{
        f"emulator.esc.{name}": f"emulator.slave.{name}"
        for name in (
            "sii",
            "state_machine",
            "mailbox",
            "coe",
            "objects",
            "esi_slave",
            "esi_objects",
            "esi_inputs",
        )
    },
    "emulator.esc.hostile": "emulator.hostile",
}


def run(code: str, *args: str) -> str:
    """What ``code`` prints, run by this Python in a fresh interpreter from the checkout."""
    out = subprocess.run(
        [sys.executable, "-c", code, *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
        check=True,
    )
    return out.stdout


IDENTITY = """
import importlib, sys
old, new = sys.argv[1:3]
module = importlib.import_module(old)  # the old name first: nothing imported the new one yet
print(module is importlib.import_module(new), module is sys.modules[old], module.__name__)
parent, _, child = old.rpartition(".")
exec(f"from {parent} import {child} as again")
print(again is module)
"""


@pytest.mark.parametrize("old", sorted(MOVED))
def test_the_old_path_imports_the_new_module(old: str) -> None:
    new = MOVED[old]
    assert (ROOT / (new.replace(".", "/") + ".py")).is_file()
    assert not (ROOT / (old.replace(".", "/") + ".py")).exists()
    assert run(IDENTITY, old, new).split() == ["True", "True", new, "True"]


LOADED = """
import json, sys
import emulator.esc
print(json.dumps(sorted(sys.modules)))
"""


def test_importing_the_esc_imports_no_alias() -> None:
    """``import emulator.esc`` loads no old name, and none of the moved modules that the package
    ``emulator`` does not load itself (its engine needs the SII and the firmware)."""
    loaded = set(json.loads(run(LOADED)))
    assert "emulator.esc" in loaded
    assert not loaded & set(MOVED)
    assert not loaded & {"emulator.hostile", "emulator.slave.mailbox", "emulator.slave.coe"}


def test_the_package_lists_the_same_moves() -> None:
    import emulator.esc

    assert emulator.esc.MOVED == MOVED


def test_the_interface_doc_lists_the_moves() -> None:
    text = (ROOT / "docs" / "interface.md").read_text().split("## Python", 1)[1]
    moved = text[text.index("Moved (issue 39") :].split("\n\n", 1)[0]
    for old, new in MOVED.items():
        assert f"`{old.rpartition('.')[2]}`" in moved or f"`{old}`" in moved, old
        assert new.rpartition(".")[0] in moved, new
    assert "alias" in moved


def test_the_master_frames_still_import_from_the_chain() -> None:
    """emulator.configure's names moved out of emulator.esc.chain (docs/interface.md): the old
    home still gives each, the very same object."""
    import emulator.configure
    import emulator.esc.chain

    names = ["STATION_BASE", "configure_frames", "configure_line_frames",
             "process_data_addresses", "process_data_writes"]  # fmt: skip
    assert sorted(emulator.configure.__all__) == sorted(names)
    for name in names:
        assert getattr(emulator.esc.chain, name) is getattr(emulator.configure, name), name
        assert name in emulator.esc.chain.__all__, name
