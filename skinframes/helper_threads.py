"""Helper threads leave SIGINT and SIGTERM to the main thread.

CPython runs signal handlers in the main thread only, when it next runs Python code. The kernel
delivers a signal sent to the process to any thread that does not block it: taken by a helper
that waits in a system call (a write to a pipe whose reader does not read), it reaches a main
thread that waits without a timeout (a lock, a write of its own) only when that wait ends, which
may be never. A helper that blocks both leaves them to the main thread, whose wait the signal
then interrupts (``EINTR``; PEP 475 runs the handler before the call is retried).
"""

from __future__ import annotations

import signal
from typing import Final

__all__ = ["HANDLED_IN_MAIN", "MAIN_WAIT_S", "leave_signals_to_main"]

HANDLED_IN_MAIN: Final = (signal.SIGINT, signal.SIGTERM)  # the signals that end a command
# a main thread's wait for a helper ends this often and begins again: CPython runs a handler
# between bytecodes, and a signal that arrives as a blocking wait (a lock, a write) begins is
# seen only when that wait ends (a Ctrl-C while a command waits for a reader that does not read)
MAIN_WAIT_S: Final = 0.1


def leave_signals_to_main() -> None:
    """Block SIGINT and SIGTERM in the calling thread (a helper's first call; no-op where
    threads have no signal masks)."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, set(HANDLED_IN_MAIN))
