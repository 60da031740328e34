"""The ESC's busiest modules compiled with mypyc (part of mypy), the same sources as C extensions.

``python -m emulator.esc.build`` (``make`` runs it) compiles :data:`MODULES` into
``emulator/esc/_compiled/<digest>/``, the digest being that of their sources and everything they
import (:func:`source_digest`). Importing :mod:`emulator.esc` puts that folder first on the
package's path when it exists for the sources as they are (:func:`folder`), so an edited source runs
as Python until it is compiled again, and never when ``SKINFRAMES_PURE=1``. The test suite runs the
Python sources, whose paths it checks one by one (some tests stand in for functions and methods,
which compiled modules do not allow); tests prove the compiled modules answer hostile frames byte
for byte as the sources do, and give the timing engine the same frames. Without a C compiler
everything runs as Python.

Compiled, hostile frames at 160 ESCs take about 0.8 times their CPU, the first logical read after
a change of the FMMUs about 0.6 times (benchmarks/README).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import io
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Final

# the modules of the frame's path through the chain (emulator/esc/<name>.py), and the commands
# they test every datagram against: compiled, their Final values are C statics to the others
# (from a Python module, each use is a lookup in its namespace: 1.6% of a hostile frame's
# instructions)
MODULES: Final = (
    "al",
    "chain",
    "commands",
    "device",
    "dl",
    "eeprom",
    "mapping",
    "syncmanagers",
    "together",
    "write_plans",
)
HERE: Final = Path(__file__).resolve().parent
COMPILED: Final = HERE / "_compiled"  # one folder per digest of the sources
# what the compiled modules were compiled against (mypyc takes constants and types of the modules
# they import): every source of both packages
PACKAGES: Final = (HERE.parent, HERE.parent.parent / "skinframes")
PURE_ENV: Final = "SKINFRAMES_PURE"  # "1": run the Python sources whatever is compiled
GROUP: Final = "emulator.esc.native"  # mypyc's shared library: emulator.esc.native__mypyc


def source_digest() -> str:
    """SHA-256 of the Python version and of every source of :data:`PACKAGES` (paths and bytes),
    which the compiled modules import: the name of the folder compiled from them (5 ms)."""
    digest = hashlib.sha256(sys.version.encode())
    for package in PACKAGES:
        for source in sorted(package.rglob("*.py")):
            name = source.relative_to(package.parent).as_posix()
            digest.update(name.encode() + b"\0" + source.read_bytes() + b"\0")
    return digest.hexdigest()[:32]


def folder() -> Path | None:
    """The folder compiled from the sources as they are, unless ``SKINFRAMES_PURE=1``; else
    None (nothing compiled, or an edited source)."""
    if os.environ.get(PURE_ENV) == "1" or not COMPILED.is_dir():
        return None
    try:
        found = COMPILED / source_digest()
    except OSError:
        return None
    return found if found.is_dir() else None


def in_use() -> bool:
    """Whether the chain runs compiled (:mod:`emulator.esc.chain` is a C extension)."""
    from emulator.esc import chain

    return not str(chain.__file__).endswith(".py")


def build() -> Path:
    """Compile :data:`MODULES` (mypyc, a C compiler) into a folder of their own, made beside
    the others under a temporary name and renamed into place when complete, unless a source
    changed meanwhile (OSError); older folders go. The folder."""
    from mypyc.build import mypycify  # the build's own dependencies (mypy, setuptools)

    distribution = importlib.import_module("setuptools").Distribution  # (stubs or not)

    digest = source_digest()
    target = COMPILED / digest
    if target.is_dir():
        return target
    COMPILED.mkdir(exist_ok=True)
    root = HERE.parent.parent  # mypyc names the modules by their paths from here
    with tempfile.TemporaryDirectory(dir=COMPILED, prefix=".build-") as tmp:
        before = os.getcwd()
        os.chdir(root)
        try:
            extensions = mypycify(
                [f"emulator/esc/{name}.py" for name in MODULES],
                group_name=GROUP,
                target_dir=os.path.join(tmp, "c"),
            )
            dist = distribution(
                {
                    "ext_modules": extensions,
                    "script_name": "emulator.esc.compiled",
                    "script_args": [
                        "--quiet",
                        "build_ext",
                        "--build-lib",
                        os.path.join(tmp, "lib"),
                        "--build-temp",
                        os.path.join(tmp, "o"),
                    ],
                }
            )
            dist.parse_command_line()
            dist.run_commands()
        finally:
            os.chdir(before)
        if source_digest() != digest:
            raise OSError("a source changed while it compiled")
        built = Path(tmp, "lib", "emulator", "esc")
        made = Path(tmp, "made")
        made.mkdir()
        for lib in built.iterdir():
            if lib.suffix in (".so", ".pyd"):
                shutil.move(lib, made / lib.name)
        os.rename(made, target)
    for old in COMPILED.iterdir():
        if old != target and not old.name.startswith("."):
            shutil.rmtree(old, ignore_errors=True)
    return target


def main() -> int:
    """Build, and say where (or why not: then everything runs as Python); mypyc's own remarks
    only where it fails."""
    if (COMPILED / source_digest()).is_dir():
        return 0
    print(f"compiling {', '.join(MODULES)} of emulator/esc with mypyc (a minute or two)")
    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said):
            made = build()
    except KeyboardInterrupt:
        print("emulator.esc.compiled: interrupted; the ESCs run as Python")
        return 130
    except (Exception, SystemExit) as exc:  # no compiler, no mypy: Python it is
        sys.stdout.write(said.getvalue()[-4000:])
        reason = f"{type(exc).__name__}: {exc}".strip()
        print(f"emulator.esc.compiled: not compiled ({reason}); the ESCs run as Python")
        return 1
    print(f"compiled into {made.relative_to(HERE.parent.parent)}")
    return 0
