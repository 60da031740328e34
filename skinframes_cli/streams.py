"""``-`` on the command line: standard output for an output a pipe can carry, standard input
for an input (docs/interface.md, Conventions).

A stream is not a file: nothing is written atomically there. Binary data is not written to a
terminal (one error line, as tshark refuses ``-w -`` on one). An input that is read twice
(``decode --taxels``) is first copied from standard input into a temporary file that is removed
afterwards, so memory does not grow with it.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from typing import IO, Final, Literal, overload

from skinframes.atomic_file import atomic_output
from skinframes.errors import SkinframesError

__all__ = ["STDIO", "input_bytes", "input_path", "output"]

STDIO: Final = "-"
MAX_STDIN_BYTES: Final = 64 << 20  # an input read whole (sii: an ESI file or an image)


@overload
def output(
    path: str, mode: Literal["wb"], *, what: str
) -> contextlib.AbstractContextManager[IO[bytes]]: ...
@overload
def output(
    path: str, mode: Literal["w"], *, what: str
) -> contextlib.AbstractContextManager[IO[str]]: ...
def output(
    path: str, mode: str, *, what: str
) -> contextlib.AbstractContextManager[IO[bytes]] | contextlib.AbstractContextManager[IO[str]]:
    """The file ``path`` written atomically, or standard output for ``-`` (``what``: the option,
    for the error line when binary data would go to a terminal)."""
    if path != STDIO:
        return atomic_output(path, mode)  # type: ignore[call-overload, no-any-return]
    return _stdout(mode, what)  # type: ignore[return-value]


@contextlib.contextmanager
def _stdout(mode: str, what: str) -> Iterator[IO[bytes] | IO[str]]:
    if mode == "wb" and sys.stdout.isatty():
        raise SkinframesError(f"{what} -: standard output is a terminal; pipe it or redirect it")
    stream: IO[bytes] | IO[str] = sys.stdout.buffer if mode == "wb" else sys.stdout
    yield stream
    stream.flush()


def input_bytes(path: str, *, limit: int = MAX_STDIN_BYTES) -> bytes:
    """The whole of ``path``, or of standard input for ``-`` (at most ``limit`` bytes)."""
    if path != STDIO:
        with open(path, "rb") as f:
            return f.read()
    data = sys.stdin.buffer.read(limit + 1)
    if len(data) > limit:
        raise SkinframesError(f"standard input: more than {limit} bytes")
    return data


@contextlib.contextmanager
def input_path(path: str, suffix: str = "") -> Iterator[str]:
    """A file name for ``path``; for ``-``, a temporary copy of standard input (for readers
    that read their input twice), removed when the block ends."""
    if path != STDIO:
        yield path
        return
    fd, name = tempfile.mkstemp(prefix="skinframes-stdin-", suffix=suffix)
    try:
        with os.fdopen(fd, "wb") as f:
            shutil.copyfileobj(sys.stdin.buffer, f, 1 << 20)
        try:
            yield name
        except SkinframesError as exc:  # name the input as the user did, not the copy
            exc.args = tuple(a.replace(name, STDIO) if isinstance(a, str) else a for a in exc.args)
            raise
    finally:
        with contextlib.suppress(OSError):
            os.unlink(name)
