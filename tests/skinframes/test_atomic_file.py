"""atomic_output / atomic_path: the target appears whole or keeps its previous bytes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from skinframes.atomic_file import atomic_output, atomic_path
from skinframes.errors import CaptureError, SkinframesError


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_bytes_and_text_replace_the_target(tmp_path: Path) -> None:
    target = tmp_path / "a.bin"
    target.write_bytes(b"old")
    with atomic_output(target) as f:
        f.write(b"new bytes")
    assert target.read_bytes() == b"new bytes"
    with atomic_output(tmp_path / "b.csv", "w") as t:
        t.write("x,y\n1,2\n")
    assert (tmp_path / "b.csv").read_bytes() == b"x,y\n1,2\n"
    assert leftovers(tmp_path) == []


def test_an_interrupted_write_keeps_the_previous_file(tmp_path: Path) -> None:
    target = tmp_path / "a.pcap"
    target.write_bytes(b"previous")
    with pytest.raises(KeyboardInterrupt), atomic_output(target) as f:
        f.write(b"half")
        raise KeyboardInterrupt
    assert target.read_bytes() == b"previous"
    assert leftovers(tmp_path) == []


def test_a_signal_while_the_temporary_file_is_made_leaves_no_file(tmp_path: Path) -> None:
    """Issue 42: a SIGINT's KeyboardInterrupt raised wherever create_temp may run a signal
    handler leaves no file behind (one right after os.open left an empty .tmp while the command
    said that no file was left half-written: 1 run in 400 under load)."""
    import dis
    import itertools
    import sys
    from types import FrameType
    from typing import Any

    from skinframes import atomic_file

    code = atomic_file.create_temp.__code__
    # CPython runs a Python signal handler after a call or a backward jump (the eval breaker)
    checks = [
        b.offset
        for a, b in itertools.pairwise(dis.get_instructions(code))
        if a.opname.startswith(("CALL", "JUMP_BACKWARD"))
    ]

    def interrupting_at(at: int) -> Any:
        """A trace function that raises KeyboardInterrupt at the at-th check (from 1)."""
        seen = 0

        def trace(frame: FrameType, event: str, arg: Any) -> Any:
            nonlocal seen
            if frame.f_code is not code:
                return None
            frame.f_trace_opcodes = True
            if event == "opcode" and frame.f_lasti in checks:
                seen += 1
                if seen == at:
                    raise KeyboardInterrupt
            return trace

        return trace

    target = tmp_path / "a.pcap"
    for at in itertools.count(1):  # the KeyboardInterrupt at the 1st, 2nd, .. check
        before = sys.gettrace()
        sys.settrace(interrupting_at(at))
        try:
            tmp, fd = atomic_file.create_temp(target)
        except KeyboardInterrupt:
            assert leftovers(tmp_path) == [], (at, list(tmp_path.iterdir()))
            continue
        finally:
            sys.settrace(before)
        os.close(fd)
        tmp.unlink()
        break
    assert at > 3  # every check before the return was tried, the one after os.open too


def test_atomic_path_lets_a_library_write_by_name(tmp_path: Path) -> None:
    target = tmp_path / "pic.png"
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.exists() and not target.exists()
        tmp.write_bytes(b"\x89PNG")
    assert target.read_bytes() == b"\x89PNG"
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("kind", ["symlink", "directory", "missing-folder"])
def test_refused_targets_name_the_reason_and_write_nothing(tmp_path: Path, kind: str) -> None:
    outside = tmp_path / "outside.txt"
    outside.write_bytes(b"keep")
    if kind == "symlink":
        target = tmp_path / "link"
        os.symlink(outside, target)
        reason = "symbolic link"
    elif kind == "directory":
        target = tmp_path / "dir"
        target.mkdir()
        reason = "is a directory"
    else:
        target = tmp_path / "no" / "such" / "x.png"
        reason = "does not exist"
    with pytest.raises(CaptureError, match=reason) as err, atomic_output(target) as f:
        f.write(b"x")
    assert isinstance(err.value, SkinframesError)
    assert outside.read_bytes() == b"keep"
    assert not (tmp_path / "no").exists()
    assert leftovers(tmp_path) == []
