"""Three layers, imports going down only: skinframes (bytes) <- emulator (time) <- skinframes_cli.

The rules, proved two ways (STYLE 2.1):

1. ``skinframes`` never imports ``emulator`` or ``skinframes_cli``;
2. ``emulator`` never imports ``skinframes_cli``;
3. ``skinframes_cli`` sits on top and may import both;
4. inside ``emulator``, no import loop, and the slave behind the ESC (``emulator.slave``) sees of
   the ESC (``emulator.esc``) only the PDI and the register constants (issue 39).

Statically, every ``import`` statement of every module (module level, inside functions and under
``TYPE_CHECKING`` alike) is read with :mod:`ast`; dynamically, every module of a package is
imported in a fresh interpreter and ``sys.modules`` is checked afterwards. The one exception is
``skinframes/__main__.py``: an entry point (``python -m skinframes``), not library code.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

# package -> the top-level packages it must never import
FORBIDDEN = {
    "skinframes": ("emulator", "skinframes_cli"),
    "emulator": ("skinframes_cli",),
}
ENTRY_POINTS = {ROOT / "skinframes" / "__main__.py"}


def modules_of(package: str) -> list[tuple[str, Path]]:
    """Every module of a package as (dotted name, path), entry points left out."""
    out = []
    for path in sorted((ROOT / package).rglob("*.py")):
        if path in ENTRY_POINTS:
            continue
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out.append((".".join(parts), path))
    return out


def imported_names(path: Path, module: str) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import statement in a source file."""
    found = []
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the importing module's package
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                name = ".".join([*base, node.module] if node.module else base)
            else:
                name = node.module or ""
            found.append((node.lineno, name))
    return found


def top(name: str) -> str:
    return name.partition(".")[0]


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_no_import_statement_goes_up(package: str) -> None:
    modules = modules_of(package)
    assert len(modules) > 5  # the walk found the package
    bad = [
        f"{path.relative_to(ROOT)}:{line}: imports {name}"
        for module, path in modules
        for line, name in imported_names(path, module)
        if top(name) in FORBIDDEN[package]
    ]
    assert not bad, "\n".join(bad)


def test_the_scan_sees_every_kind_of_import(tmp_path: Path) -> None:
    src = tmp_path / "m.py"
    src.write_text(
        "import a.b\n"
        "from c import d\n"
        "def f():\n    import e\n"
        "if TYPE_CHECKING:\n    from g.h import i\n"
        "from . import j\n"
        "from ..k import m\n"
    )
    names = sorted(name for _, name in imported_names(src, "p.q.m"))
    assert names == ["a.b", "c", "e", "g.h", "p.k", "p.q"]


PROBE = """
import importlib, json, sys
for name in json.loads(sys.argv[1]):
    importlib.import_module(name)
print(json.dumps(sorted(sys.modules)))
"""


def loaded_after(names: list[str], first: str = "") -> set[str]:
    """Every module a fresh interpreter holds after importing ``names``, ``first`` run before."""
    out = subprocess.run(
        [sys.executable, "-c", first + PROBE, json.dumps(names)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
        check=True,
    )
    return set(json.loads(out.stdout))


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_importing_every_module_loads_no_upper_layer(package: str) -> None:
    loaded = {top(m) for m in loaded_after([module for module, _ in modules_of(package)])}
    assert package in loaded
    assert not loaded & set(FORBIDDEN[package])


def test_the_cli_sits_on_top() -> None:
    """The command line is its own package; the libraries keep no command modules."""
    assert not (ROOT / "skinframes" / "cli").exists()
    assert (ROOT / "skinframes_cli" / "__init__.py").is_file()
    names = {
        name
        for module, path in modules_of("skinframes_cli")
        for _, name in imported_names(path, module)
    }
    assert {"skinframes", "emulator"} <= {top(n) for n in names}


def test_python_m_skinframes_runs_the_cli() -> None:
    """The entry point the interface promises, and the only module of skinframes that may go up."""
    for module in ("skinframes", "skinframes_cli"):
        out = subprocess.run(
            [sys.executable, "-m", module, "--help"],
            capture_output=True,
            text=True,
            cwd=ROOT,
            timeout=60,
            check=True,
        )
        assert out.stdout.startswith("usage: skinframes ")


def import_graph(package: str) -> dict[str, set[str]]:
    """Module -> the modules of ``package`` it imports, every import statement counted (module
    level, inside functions, under ``TYPE_CHECKING``); ``from p import m`` of a module ``m``
    counts as importing ``p.m``. A module's own packages are left out: Python imports them
    before the module, whatever it says."""
    modules = dict(modules_of(package))
    graph: dict[str, set[str]] = {}
    for module, path in modules.items():
        found: set[str] = set()
        bases = dict(imported_names(path, module))  # line -> the module a statement names
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = bases[node.lineno]
                names = [base, *(f"{base}.{alias.name}" for alias in node.names)]
            found |= {
                name
                for name in names
                if name in modules and name != module and not module.startswith(f"{name}.")
            }
        graph[module] = found
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every import loop of ``graph`` found by a depth-first walk, each once (by its members)."""
    out: list[list[str]] = []
    seen: set[frozenset[str]] = set()

    def walk(path: list[str]) -> None:
        for nxt in sorted(graph[path[-1]]):
            if nxt in path:
                loop = path[path.index(nxt) :]
                if frozenset(loop) not in seen:
                    seen.add(frozenset(loop))
                    out.append([*loop, nxt])
            elif len(path) < 12:
                walk([*path, nxt])

    for module in sorted(graph):
        walk([module])
    return out


def test_no_import_loop_in_emulator() -> None:
    """Issue "One ESC": no module of ``emulator`` imports, however indirectly, a module that
    imports it, counting imports under ``TYPE_CHECKING`` (the firmware types against the PDI,
    emulator/esc/pdi.py, not against the ESC)."""
    graph = import_graph("emulator")
    assert graph.get("emulator.esc.device")  # the walk found the ESC and its imports
    found = cycles(graph)
    assert not found, "\n".join(" -> ".join(loop) for loop in found)


# what the slave behind the ESC (emulator.slave) may import of the ESC: the PDI it is written
# against and the ESC's constants (register map, DC registers, commands), issue 39
SLAVE_SEES_OF_THE_ESC = {
    "emulator.esc",  # the package, which Python imports before any of its modules
    "emulator.esc.pdi",
    "emulator.esc.registers",
    "emulator.esc.dc",
    "emulator.esc.commands",
}
# the one exception: esi_slave.esi_device(slave) builds the ESC an ESI slave runs behind (an
# EscDevice with its application), the public way to get an ESI slave (docs/interface.md)
SLAVE_BUILDS_AN_ESC = {("emulator.slave.esi_slave", "emulator.esc.device")}


def test_the_slave_meets_the_esc_at_the_pdi() -> None:
    """Issue 39: the ESC and its firmware meet at one narrow interface. A module of
    ``emulator.slave`` imports of ``emulator.esc`` only :data:`SLAVE_SEES_OF_THE_ESC`, never the
    ESC itself (device, chain, mapping, together, write_plans), but for
    :data:`SLAVE_BUILDS_AN_ESC`; the ESC imports of the slave only the SII and the state machine
    (its default application), without a loop (:func:`test_no_import_loop_in_emulator`)."""
    graph = import_graph("emulator")
    slave = {m: found for m, found in graph.items() if m.startswith("emulator.slave.")}
    assert len(slave) >= 8  # the walk found the slave's modules
    beyond = {
        (module, name)
        for module, found in slave.items()
        for name in found
        if name.startswith("emulator.esc") and name not in SLAVE_SEES_OF_THE_ESC
    }
    assert beyond == SLAVE_BUILDS_AN_ESC
    esc_imports = {
        name
        for module, found in graph.items()
        if module.startswith("emulator.esc")
        for name in found
        if name.startswith("emulator.slave")
    }
    assert esc_imports == {"emulator.slave.sii", "emulator.slave.state_machine"}


def test_importing_the_firmware_loads_the_pdi_not_the_esc() -> None:
    """The same, in a fresh interpreter: the firmware modules (all of ``emulator.slave`` but
    the ESI slave, which builds an ESC) load none of the ESC's other modules. ``emulator``
    itself loads the engine and with it the ESC, so the probe puts an empty package in its
    place (the ESC's modules import none of its names)."""
    names = sorted(
        module
        for module, _ in modules_of("emulator")
        if module.startswith("emulator.slave.")
        and (module, "emulator.esc.device") not in SLAVE_BUILDS_AN_ESC
    )
    empty = (
        "import sys, types\n"
        "empty = types.ModuleType('emulator')\n"
        f"empty.__path__ = [{str(ROOT / 'emulator')!r}]\n"
        "sys.modules['emulator'] = empty\n"
    )
    loaded = {m for m in loaded_after(names, empty) if m.startswith("emulator.esc")}
    assert "emulator.esc.pdi" in loaded
    assert loaded <= SLAVE_SEES_OF_THE_ESC | {"emulator.esc.compiled"}


def test_the_loop_finder_finds_loops() -> None:
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_registers_with_side_effects_are_written_in_one_module() -> None:
    """Issue "One ESC": the end addresses of the error counters (0x0314), the watchdog counters
    (0x0442, their start) and the EEPROM interface (0x0510), and the DC speed counter start
    0x0930, each appear as a number in at most one module of emulator/esc and emulator/slave."""
    import io
    import tokenize

    where: dict[int, set[str]] = {0x0314: set(), 0x0442: set(), 0x0510: set(), 0x0930: set()}
    for path in sorted(
        [*(ROOT / "emulator" / "esc").glob("*.py"), *(ROOT / "emulator" / "slave").glob("*.py")]
    ):
        tokens = tokenize.generate_tokens(io.StringIO(path.read_text()).readline)
        for token in tokens:
            if token.type != tokenize.NUMBER:
                continue
            try:
                value = int(token.string.replace("_", ""), 0)
            except ValueError:  # a float or complex literal
                continue
            if value in where:
                where[value].add(path.name)
    assert all(len(files) == 1 for files in where.values()), where
