"""Files that appear whole or not at all: a temporary file beside the target, then a rename.

Every file skinframes writes (captures, pictures, CSV, JSON, CAN logs, DBC, Lua, .npy) goes
through :func:`atomic_output` or :func:`atomic_path`: the bytes go to ``.NAME.XXXXXXXX.tmp`` in the
target's folder, which replaces the target only when the ``with`` block ends without an
exception. An exception (KeyboardInterrupt too) removes the temporary file and leaves a previous
file at the target as it was. Atomic against exceptions and interruption, not against a power
cut (no fsync).

A target that is a symbolic link, a directory or not a regular file is refused, as is a missing
parent folder (it is named, never created).
"""

from __future__ import annotations

import contextlib
import os
import secrets
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Literal, overload

from skinframes.errors import CaptureError

__all__ = ["atomic_output", "atomic_path", "check_target", "create_temp", "output_folder"]

_TEMP_ATTEMPTS = 100


def check_target(target: Path) -> None:
    """Raise CaptureError for a path skinframes must not replace, or cannot create."""
    if target.is_symlink():
        raise CaptureError(f"{target}: is a symbolic link; refusing to replace it")
    if target.is_dir():
        raise CaptureError(f"{target}: is a directory")
    if target.exists() and not target.is_file():
        raise CaptureError(f"{target}: exists and is not a regular file")
    if not target.parent.is_dir():
        if target.parent.exists():
            raise CaptureError(f"{target}: {target.parent} is not a directory")
        raise CaptureError(f"{target}: directory {target.parent} does not exist")


def output_folder(path: str | os.PathLike[str]) -> Path:
    """The folder a command writes its files into, created when missing if its parent exists
    (one level, never ``mkdir -p``: a mistyped parent is named, not built).

    Raises:
        CaptureError: ``path`` exists and is not a folder, its parent does not exist, or it
            cannot be created.
    """
    out = Path(os.fspath(path))
    if out.is_dir():
        return out
    if out.exists() or out.is_symlink():
        raise CaptureError(f"{out}: exists and is not a directory")
    if not out.parent.is_dir():
        raise CaptureError(f"{out}: directory {out.parent} does not exist")
    try:
        out.mkdir()
    except OSError as exc:
        raise CaptureError(f"{out}: cannot create ({exc.strerror or exc})") from exc
    return out


def create_temp(target: Path) -> tuple[Path, int]:
    """A new, empty file beside ``target``: its path and an open descriptor.

    ``os.open`` with O_EXCL and mode 0o666 lets the umask decide the permissions, as a plain
    ``open()`` would (``tempfile.mkstemp`` forces 0o600).

    A signal's exception (KeyboardInterrupt) raised while the file is made leaves no file: the
    handler may run right after ``os.open`` returned, before the caller holds the path.
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    for _ in range(_TEMP_ATTEMPTS):
        tmp = target.parent / f".{target.name}.{secrets.token_hex(4)}.tmp"
        # list.extend(map(...)) keeps the descriptor with no bytecode after os.open, so no
        # Python signal handler runs between the file's creation and `opened` holding it
        opened: list[int] = []
        try:
            opened.extend(map(os.open, (tmp,), (flags,), (0o666,)))
            return tmp, opened[0]
        except FileExistsError:
            continue
        except OSError as exc:
            raise CaptureError(
                f"{target}: cannot create a file in {target.parent} ({exc.strerror or exc})"
            ) from exc
        except BaseException:  # a signal's exception: the file, if made, is ours to remove
            if opened:
                os.close(opened[0])
                tmp.unlink(missing_ok=True)
            raise
    raise CaptureError(f"{target}: no free temporary name in {target.parent}")


@overload
def atomic_output(
    path: str | os.PathLike[str], mode: Literal["wb"] = "wb", *, encoding: None = None
) -> contextlib.AbstractContextManager[IO[bytes]]: ...
@overload
def atomic_output(
    path: str | os.PathLike[str], mode: Literal["w"], *, encoding: str = "utf-8"
) -> contextlib.AbstractContextManager[IO[str]]: ...
def atomic_output(
    path: str | os.PathLike[str], mode: str = "wb", *, encoding: str | None = None
) -> contextlib.AbstractContextManager[IO[bytes]] | contextlib.AbstractContextManager[IO[str]]:
    """An open file whose contents replace ``path`` when the ``with`` block completes.

    Args:
        path: the file to create or replace.
        mode: ``"wb"`` (bytes) or ``"w"`` (text, ``encoding`` default UTF-8, ``\\n`` newlines).

    Raises:
        CaptureError: ``path`` is refused (see the module) or its folder is not writable.
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"atomic_output: mode {mode!r}, expected 'wb' or 'w'")
    return _atomic_output(Path(os.fspath(path)), mode, encoding)  # type: ignore[return-value]


@contextlib.contextmanager
def _atomic_output(target: Path, mode: str, encoding: str | None) -> Iterator[IO[bytes] | IO[str]]:
    with atomic_path(target) as tmp:
        if mode == "wb":
            with open(tmp, "wb") as fb:
                yield fb
        else:
            with open(tmp, "w", encoding=encoding or "utf-8", newline="\n") as ft:
                yield ft


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary path beside ``path`` for a library that writes by name (matplotlib, numpy).

    The temporary file exists (empty) when the block starts; whatever the block leaves in it
    replaces ``path`` when the block completes. On an exception it is removed.

    Raises:
        CaptureError: ``path`` is refused (see the module) or its folder is not writable.
    """
    target = Path(os.fspath(path))
    check_target(target)
    tmp, fd = create_temp(target)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
