"""Untrusted text made safe to print: file names, strings read from captures and CAN logs.

One rule, used for every message and output line that can carry such text: control characters
(C0, DEL, C1), line and paragraph separators, and other unprintable code points are written as
Python escapes (``\\n``, ``\\x1b``, ``\\u2028``), so one line of output stays one line and an
ANSI escape sequence cannot recolour, move or erase what the terminal shows. Printable text,
non-ASCII letters included, is kept as it is.
"""

from __future__ import annotations

from typing import Final

__all__ = ["escape"]

_NAMED: Final = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def _escaped(ch: str) -> str:
    if ch in _NAMED:
        return _NAMED[ch]
    code = ord(ch)
    if code <= 0xFF:
        return f"\\x{code:02x}"
    if code <= 0xFFFF:
        return f"\\u{code:04x}"
    return f"\\U{code:08x}"


def escape(text: object) -> str:
    """``str(text)`` with every unprintable character written as its Python escape.

    A space is printable; a surrogate left by ``surrogateescape`` (an undecodable byte of a
    file name) is shown as ``\\udcXX``.
    """
    s = str(text)
    if s.isprintable():
        return s
    return "".join(ch if ch.isprintable() else _escaped(ch) for ch in s)
