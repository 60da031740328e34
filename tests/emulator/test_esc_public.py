"""What stays public of an ESC is what docs/interface.md names: the PDI and what a line asks of
an ESC (issue 39: "EscDevice about 20 public methods"). The methods only its chain calls begin
with ``_``; their old names still answer on an ESC, with a DeprecationWarning."""

from __future__ import annotations

import inspect
import re
import warnings
from pathlib import Path

import pytest

from emulator.esc import device as esc_device
from emulator.esc.device import EscDevice
from emulator.esc.pdi import Pdi
from emulator.slave.sii import SlaveInfo

DOC = Path(__file__).resolve().parents[2] / "docs" / "interface.md"
PARAGRAPH = re.compile(r"What stays public of `emulator\.esc\.device\.EscDevice`(.*?)\n\n", re.S)


def documented() -> tuple[set[str], set[str]]:
    """(the names the paragraph says stay public, the old names it says still answer)."""
    found = PARAGRAPH.search(DOC.read_text())
    assert found is not None, "docs/interface.md names what stays public of EscDevice"
    text = found.group(1)
    public, _, renamed = text.partition("The methods only its chain calls")
    renamed = renamed.partition("On an ESC each old name")[0]
    names = re.compile(r"`([a-z][a-z0-9_]*)`")
    return set(names.findall(public)), {n for n in names.findall(renamed) if not n.startswith("_")}


def public_members() -> set[str]:
    """EscDevice's public methods and properties (its class's own, not attributes)."""
    return {
        name
        for name, member in vars(EscDevice).items()
        if not name.startswith("_")
        and (inspect.isroutine(member) or isinstance(member, (property, staticmethod)))
    }


def test_the_public_methods_are_those_the_interface_names() -> None:
    public, _ = documented()
    assert public_members() == public
    assert len(public) <= 20
    pdi = {name for name in vars(Pdi) if not name.startswith("_")} - {"config"}
    assert pdi <= public  # the firmware's side of the ESC stays whole


def test_each_old_name_answers_as_the_new_with_a_warning() -> None:
    _, renamed = documented()
    assert renamed == set(esc_device._RENAMED)  # the doc lists every alias, and no other
    dev = EscDevice(SlaveInfo.skin_patch(4, serial=1))
    for old, new in esc_device._RENAMED.items():
        assert not hasattr(EscDevice, old), old  # no public method of that name is left
        with pytest.warns(DeprecationWarning, match=f"EscDevice.{old} is now EscDevice.{new}"):
            found = getattr(dev, old)
        assert found == getattr(dev, new)
    with pytest.warns(DeprecationWarning, match="pdi_deactivate_sms"):
        dev.pdi_deactivate_sm(0, True)  # the PDI locks SyncManager 0: 0x0807 bit 0
    assert dev.registers(0x0807, 1) == b"\x01"  # (datasheet II 2.14.7)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
            dev.no_such_name  # noqa: B018
        assert getattr(dev, "plain_logical", None) is None  # gone, not an alias
