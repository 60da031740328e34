"""A pseudo-terminal to run ``skinframes`` in (``watch``'s view), read as a user sees it."""

from __future__ import annotations

import contextlib
import fcntl
import os
import pty
import re
import select
import signal
import struct
import sys
import termios
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
HEAD = "skinframes watch "  # the first words of every view watch draws
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


class Terminal:
    """``skinframes ARGV`` on a pseudo-terminal of 140 x 50, its screen output read as it comes;
    ``prefix``: what runs it (``ip netns exec NS``)."""

    def __init__(self, *argv: str, prefix: tuple[str, ...] = ()) -> None:
        command = [*prefix, sys.executable, "-m", "skinframes", *argv]
        self.pid, self.fd = pty.fork()
        if self.pid == 0:  # the child: the command, its stdin, stdout and stderr the terminal
            fcntl.ioctl(0, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 140, 0, 0))  # before exec
            os.chdir(ROOT)
            os.execvp(command[0], command)
        self.out = ""

    def read_until(self, needle: str | re.Pattern[str], timeout_s: float = 60) -> str:
        """Read until a whole view (one redraw to the next) shows ``needle`` (a text, or a
        pattern it matches); that view."""

        def shown(screen: str) -> bool:
            return needle in screen if isinstance(needle, str) else bool(needle.search(screen))

        deadline = time.monotonic() + timeout_s
        while not shown(self.screen()) and time.monotonic() < deadline:
            if select.select([self.fd], [], [], 0.1)[0]:
                try:
                    self.out += os.read(self.fd, 65536).decode(errors="replace")
                except OSError:
                    break
        screen = self.screen()
        assert shown(screen), f"{needle!r} not shown: {ANSI.sub('', self.out)[-2000:]}"
        return screen

    def screen(self) -> str:
        """The last whole view drawn: from one head line to the next (rich redraws it all)."""
        frames = ANSI.sub("", self.out).split(HEAD)
        return HEAD + frames[-2] if len(frames) >= 3 else ""

    def press(self, key: str) -> None:
        os.write(self.fd, key.encode())

    def wait(self, timeout_s: float = 60) -> int:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid:
                with_rest = select.select([self.fd], [], [], 0)[0]
                if with_rest:
                    with contextlib.suppress(OSError):
                        self.out += os.read(self.fd, 65536).decode(errors="replace")
                os.close(self.fd)
                return os.waitstatus_to_exitcode(status)
            if select.select([self.fd], [], [], 0.1)[0]:
                with contextlib.suppress(OSError):
                    self.out += os.read(self.fd, 65536).decode(errors="replace")
        os.kill(self.pid, signal.SIGKILL)
        os.waitpid(self.pid, 0)
        pytest.fail("watch did not end")
