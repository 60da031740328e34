"""The emulated EtherCAT slave controller (ESC): :mod:`.registers` (the register map),
:mod:`.device` (one ESC), :mod:`.chain` (a line of ESCs processing whole frames, for the live
transport and the timing engine alike), :mod:`.mapping` (FMMU and SyncManager tables, logical
accesses planned), :mod:`.write_plans` (what a register write does), :mod:`.eeprom` (the SII EEPROM
interface), :mod:`.syncmanagers` (a SyncManager's state and status), :mod:`.dl` (DL control and
status), :mod:`.dc` (distributed clocks) and :mod:`.pdi` (the process data interface, where the
slave's firmware in :mod:`emulator.slave` meets the ESC).

This file imports nothing of the project but :mod:`.compiled`, so that importing one module does
not load the others; where :mod:`.compiled` built them, the busiest modules are C extensions of the
same sources.

The modules that moved out (issue 39: the slave behind the ESC is a package of its own) keep their
old names as aliases, :data:`MOVED`: ``import emulator.esc.coe`` gives the very module
``emulator.slave.coe``, imported only then.
"""

import importlib
import importlib.abc
import importlib.util
import sys
from collections.abc import Sequence
from importlib.machinery import ModuleSpec
from types import ModuleType

from emulator.esc import compiled as _compiled

_found = _compiled.folder()
if _found is not None:  # the busiest modules compiled from these very sources (compiled.py)
    __path__.insert(0, str(_found))

_SLAVE = (
    "sii",
    "state_machine",
    "mailbox",
    "coe",
    "objects",
    "esi_slave",
    "esi_objects",
    "esi_inputs",
)
# the old name -> the new name of each module that moved out of this package (issue 39)
MOVED: dict[str, str] = {
    **{f"emulator.esc.{name}": f"emulator.slave.{name}" for name in _SLAVE},
    "emulator.esc.hostile": "emulator.hostile",
}


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finder (first on :data:`sys.meta_path`) and loader of the old names of :data:`MOVED`:
    loading one imports the new module and puts it in :data:`sys.modules` under the old name,
    where the import system takes it from (the module made for the old name is dropped)."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        return importlib.util.spec_from_loader(fullname, self) if fullname in MOVED else None

    def exec_module(self, module: ModuleType) -> None:
        sys.modules[module.__name__] = importlib.import_module(MOVED[module.__name__])


# one alias finder, also when this package is imported again
sys.meta_path[:] = [f for f in sys.meta_path if type(f).__module__ != __name__]
sys.meta_path.insert(0, _Alias())
