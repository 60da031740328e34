"""Run tshark on a capture and read its verdicts (stderr ignored: it warns when run as root)."""

from __future__ import annotations

import subprocess
from pathlib import Path


def run(tshark: str, path: Path | str, *args: str) -> str:
    result = subprocess.run(
        [tshark, "-n", "-r", str(path), *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, f"tshark {args} failed: {result.stderr}"
    return result.stdout


def problems(tshark: str, path: Path | str, *options: str) -> list[str]:
    """Frames tshark calls malformed or flags with an expert item of warning or worse
    (``options``: more tshark arguments, e.g. ``-o ip.check_checksum:TRUE``)."""
    out = run(
        tshark,
        path,
        *options,
        "-Y",
        "_ws.malformed || _ws.expert.severity >= warning",
        "-T",
        "fields",
        "-e",
        "frame.number",
        "-e",
        "_ws.expert.message",
    )
    return [line for line in out.splitlines() if line.strip()]


def fields(
    tshark: str, path: Path | str, names: list[str], display_filter: str = "", *options: str
) -> list[dict[str, list[str]]]:
    """One dict per frame: field -> all its occurrences (tshark -E occurrence=a)."""
    args = [
        *options,
        "-T",
        "fields",
        "-E",
        "occurrence=a",
        "-E",
        "separator=\t",
        "-E",
        "aggregator=,",
    ]
    if display_filter:
        args += ["-Y", display_filter]
    for n in names:
        args += ["-e", n]
    rows = []
    for line in run(tshark, path, *args).splitlines():
        cols = line.split("\t")
        cols += [""] * (len(names) - len(cols))
        rows.append({n: (c.split(",") if c else []) for n, c in zip(names, cols, strict=True)})
    return rows


def values(tshark: str, field: str) -> dict[int, str]:
    """``tshark -G values`` for one field: value -> name."""
    out = subprocess.run(
        [tshark, "-G", "values"], capture_output=True, text=True, timeout=120, check=True
    ).stdout
    table = {}
    for line in out.splitlines():
        parts = line.split("\t")
        if len(parts) >= 4 and parts[0] == "V" and parts[1] == field:
            table[int(parts[2], 0)] = parts[3]
    return table
