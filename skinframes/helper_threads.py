"""Helper threads leave SIGINT and SIGTERM to the main thread.

CPython runs signal handlers in the main thread only, when it next runs Python code. The kernel
delivers a signal sent to the process to any thread that does not block it: taken by a helper
that waits in a system call (a write to a pipe whose reader does not read), it reaches a main
thread that waits without a timeout (a lock, a write of its own) only when that wait ends, which
may be never. A helper that blocks both leaves them to the main thread, whose wait the signal
then interrupts (``EINTR``; PEP 475 runs the handler before the call is retried).

Threads and processes inherit the mask of the thread that starts them: those started inside
:func:`signals_held` begin with both blocked (a worker process then takes them as it chooses).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType
from typing import Final

__all__ = ["HANDLED_IN_MAIN", "MAIN_WAIT_S", "leave_signals_to_main", "signals_held"]

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


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Inside, SIGINT and SIGTERM wait until the block ends, where the handlers take them:
    blocked in the calling thread, so that the threads and processes it starts begin with them
    blocked, and in the main thread held by a handler of its own (another thread, one of a
    library's, may take them from the kernel, and CPython runs the handler in the main thread
    all the same). For starting helpers that must not be left half-started."""
    held: list[int] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        held.append(signum)

    before = {}
    if threading.current_thread() is threading.main_thread():
        before = {sig: signal.getsignal(sig) or signal.SIG_DFL for sig in HANDLED_IN_MAIN}
        for sig in HANDLED_IN_MAIN:
            signal.signal(sig, hold)
    masks = hasattr(signal, "pthread_sigmask")
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, HANDLED_IN_MAIN) if masks else set()
    try:
        yield
    finally:
        if masks:  # (first: one that was blocked is held now, and the mask is never left)
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for sig, handler in before.items():
            signal.signal(sig, handler)
        for signum in held:
            signal.raise_signal(signum)
