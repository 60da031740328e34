"""Three layers, imports going down only: skinframes (bytes) <- emulator (time) <- skinframes_cli.

The rules, proved two ways (STYLE 2.1):

1. ``skinframes`` never imports ``emulator`` or ``skinframes_cli``;
2. ``emulator`` never imports ``skinframes_cli``;
3. ``skinframes_cli`` sits on top and may import both.

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
print(json.dumps(sorted({m.partition(".")[0] for m in sys.modules})))
"""


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_importing_every_module_loads_no_upper_layer(package: str) -> None:
    names = [module for module, _ in modules_of(package)]
    out = subprocess.run(
        [sys.executable, "-c", PROBE, json.dumps(names)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
        check=True,
    )
    loaded = set(json.loads(out.stdout))
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
