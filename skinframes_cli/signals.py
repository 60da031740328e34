"""SIGINT and SIGTERM while a command runs: raised in the main thread, and remembered.

Raised, so that ``with`` blocks (atomic files) clean up on the way out: SIGINT as
:class:`KeyboardInterrupt`, SIGTERM as :class:`Terminated`. Remembered, because code the command
calls may swallow the exception: an extension module that is first imported while the signal
arrives (numpy.random's Cython modules, imported when a run first draws taxels, turn it into
nothing or into an ImportError), and the run would go on and replace the previous file (issue
42: 2 of 16 SIGINTs 2-3 ms after the temporary file appeared). Every progress step of a long
run asks :func:`raise_if_signalled`, which raises it again, so the run stops before its final
rename whatever swallowed it once.

Forgotten, once the command is over: CPython marks a KeyboardInterrupt that leaves code exec()
or eval() ran from a string as unhandled, for the rest of the process, even when something
catches it, and ``python -m`` then ends itself by SIGINT (-2) whatever the exit code was
(pythonrun.c's ``run_eval_code_obj``, read by ``Py_RunMain``). namedtuple() and dataclasses
build their methods that way, and numpy.random.bit_generator (Cython) calls namedtuple() while
it is imported, in a run's first milliseconds (issue 42 again: -2 after the error line, 3 of
400 SIGINTs under load).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Final

from skinframes.helper_threads import HANDLED_IN_MAIN

__all__ = ["Terminated", "first_stops", "handled", "handling", "raise_if_signalled"]


class Terminated(BaseException):
    """SIGTERM arrived: raised in the main thread so ``with`` blocks (atomic files) clean up.

    A BaseException, like KeyboardInterrupt, so that no ``except Exception`` swallows it.
    """


BOTH: Final = HANDLED_IN_MAIN  # SIGINT and SIGTERM, the signals that end a command
_received: list[int] = []  # the signals that arrived while a command ran (main thread's)


def _raise(signum: int) -> None:
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Terminated


def raise_if_signalled() -> None:
    """Raise what a signal raised before (:class:`KeyboardInterrupt`, :class:`Terminated`),
    in case something swallowed it; nothing when no signal came."""
    if _received:
        _raise(_received[0])


@contextlib.contextmanager
def handled() -> Iterator[None]:
    """While a command runs (main thread only): SIGINT and SIGTERM remembered and raised."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    _received.clear()
    try:
        with handling(_raised):
            yield
    finally:
        _received.clear()  # (the command is over: its signal is reported, not carried on)
        _forget_interrupt_in_exec()


def _raised(signum: int, frame: FrameType | None) -> None:
    """A signal remembered and raised (:func:`handled`)."""
    _received.append(signum)
    _raise(signum)


@contextlib.contextmanager
def first_stops(
    stop: Callable[[], None], which: tuple[signal.Signals, ...] = BOTH
) -> Iterator[None]:
    """Inside, the first of the signals ``which`` calls ``stop`` (a loop ends at its own pace,
    then the command finishes its files), and any after it is remembered and raised as
    :func:`handled` raises it: nothing on the way out, such as a pipe whose reader does not
    read, can then keep the command from ending (what it had not written is dropped, and a
    file keeps its previous content). The handlers before are back afterwards
    (:func:`handling`)."""
    stopping = False

    def on_signal(signum: int, frame: FrameType | None) -> None:
        nonlocal stopping
        if stopping:
            _raised(signum, frame)
        stopping = True
        stop()

    with handling(on_signal, which):
        yield


def _forget_interrupt_in_exec() -> None:
    """Clear CPython's "KeyboardInterrupt unhandled" mark that an interrupt raised inside
    exec()'d code leaves behind: exec() of a string clears it before it runs (and sets it only
    if a KeyboardInterrupt leaves that code). One that escapes main() is marked again by
    ``python -m`` itself, as it should be."""
    exec("")


@contextlib.contextmanager
def handling(
    handler: Callable[[int, FrameType | None], None], which: tuple[signal.Signals, ...] = BOTH
) -> Iterator[None]:
    """Inside, the signals ``which`` go to ``handler``; the handlers before are back afterwards,
    all of them whenever a signal comes. One that comes while they are put back is held and
    raised again once they are (:func:`signal.raise_signal`): the handler before takes it."""
    held: list[int] = []  # signals that came while the handlers before were put back
    restoring = False

    def on_signal(signum: int, frame: FrameType | None) -> None:
        if restoring:
            held.append(signum)
        else:
            handler(signum, frame)

    previous: dict[signal.Signals, Callable[[int, FrameType | None], object] | int] = {}
    try:
        for sig in which:  # each one's before known before it changes
            previous[sig] = signal.getsignal(sig) or signal.SIG_DFL
            signal.signal(sig, on_signal)
        yield
    finally:
        restoring = True
        for sig, before in previous.items():
            signal.signal(sig, before)
        for signum in held:
            signal.raise_signal(signum)
