"""skinframes knows bytes, emulator knows time: imports go one way only (STYLE 2.1)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

PROBE = """
import sys
import skinframes, skinframes.cli, skinframes.canbus, skinframes.cantrace, skinframes.check
bad = sorted(m for m in sys.modules if m == "emulator" or m.startswith("emulator."))
print(",".join(bad))
"""


def test_importing_skinframes_does_not_load_the_emulator() -> None:
    out = subprocess.run(
        [sys.executable, "-c", PROBE],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=60,
        check=True,
    )
    assert out.stdout.strip() == ""


def test_skinframes_sources_import_emulator_only_inside_functions() -> None:
    for path in (ROOT / "skinframes").rglob("*.py"):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if line.startswith(("import emulator", "from emulator")):
                raise AssertionError(f"{path}:{number}: module-level import of emulator")
