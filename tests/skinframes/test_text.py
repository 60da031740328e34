"""skinframes.text.escape: untrusted text keeps to one printable line."""

from __future__ import annotations

import pytest

from skinframes.text import escape


@pytest.mark.parametrize(
    ("raw", "shown"),
    [
        ("capture.pcapng", "capture.pcapng"),
        ("Übersicht µs 测量.pcap", "Übersicht µs 测量.pcap"),  # printable letters stay
        ("a\nb", "a\\nb"),
        ("a\r\tb", "a\\r\\tb"),
        ("\x1b[31mred\x1b[0m", "\\x1b[31mred\\x1b[0m"),  # ANSI colour: shown, not obeyed
        ("\x00\x7f\x9b", "\\x00\\x7f\\x9b"),  # NUL, DEL and the C1 CSI
        ("line\u2028sep", "line\\u2028sep"),  # Unicode line separator
        ("\udcff", "\\udcff"),  # an undecodable byte of a file name (surrogateescape)
        ("\U000e0001", "\\U000e0001"),  # an invisible tag character
    ],
)
def test_escape(raw: str, shown: str) -> None:
    assert escape(raw) == shown
    assert "\n" not in escape(raw) and "\x1b" not in escape(raw)
    assert escape(raw).isprintable()


def test_escape_takes_any_object() -> None:
    assert escape(ValueError("bad\nname")) == "bad\\nname"
