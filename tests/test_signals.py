"""skinframes_cli.signals.handling: the handlers before are back whenever a signal comes;
first_stops: a first signal stops, a second is raised; skinframes.helper_threads.signals_held:
signals wait for the block's end, and what it starts begins with them blocked.

The signals are raised in this process with :func:`signal.raise_signal` at a chosen step of
putting the handlers in place or back (CPython runs a Python handler before raise_signal
returns), so each case happens every run.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType

import pytest

from skinframes.helper_threads import signals_held
from skinframes_cli.signals import (
    Terminated,
    first_stops,
    handled,
    handling,
    raise_if_signalled,
)

Handler = Callable[[int, FrameType | None], None]


class InsideError(Exception):
    """Raised by the handler given to handling()."""


def _inside(signum: int, frame: FrameType | None) -> None:
    raise InsideError(signum)


@pytest.fixture
def before() -> Iterator[tuple[list[int], Handler]]:
    """SIGINT and SIGTERM to a handler that records them, for the test; the real ones after."""
    got: list[int] = []

    def record(signum: int, frame: FrameType | None) -> None:
        got.append(signum)

    old = {s: signal.signal(s, record) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield got, record
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)


def _signal_after(
    monkeypatch: pytest.MonkeyPatch, when: Callable[[int, object], bool], raised: signal.Signals
) -> None:
    """signal.signal, and ``raised`` raised right after a call for which ``when`` holds."""
    real = signal.signal

    def setting(signum: int, handler: object) -> object:
        out = real(signum, handler)  # type: ignore[arg-type]
        if when(signum, handler):
            signal.raise_signal(raised)
        return out

    monkeypatch.setattr(signal, "signal", setting)


def test_a_signal_while_the_handlers_are_put_back_goes_to_the_handler_before(
    before: tuple[list[int], Handler], monkeypatch: pytest.MonkeyPatch
) -> None:
    got, record = before
    # SIGTERM comes when SIGINT's handler is back and SIGTERM's is not yet
    _signal_after(monkeypatch, lambda s, h: s == signal.SIGINT and h is record, signal.SIGTERM)
    with handling(_inside):
        pass
    monkeypatch.undo()
    assert got == [signal.SIGTERM]  # not InsideError, raised on the way out
    assert signal.getsignal(signal.SIGINT) is record
    assert signal.getsignal(signal.SIGTERM) is record


def test_a_signal_while_the_handlers_are_put_in_place_leaves_the_handlers_before(
    before: tuple[list[int], Handler], monkeypatch: pytest.MonkeyPatch
) -> None:
    got, record = before
    # SIGINT comes when its handler is in place and SIGTERM's is not yet
    _signal_after(monkeypatch, lambda s, h: s == signal.SIGINT and h is not record, signal.SIGINT)
    with pytest.raises(InsideError), handling(_inside):
        pytest.fail("the signal stops the block before it starts")
    monkeypatch.undo()
    assert got == []
    assert signal.getsignal(signal.SIGINT) is record
    assert signal.getsignal(signal.SIGTERM) is record


def test_a_signal_inside_goes_to_the_handler_given(
    before: tuple[list[int], Handler],
) -> None:
    got, record = before
    with pytest.raises(InsideError), handling(_inside):
        signal.raise_signal(signal.SIGTERM)
    assert got == []
    assert signal.getsignal(signal.SIGTERM) is record


def test_a_first_signal_stops_and_a_second_is_raised_and_remembered(
    before: tuple[list[int], Handler],
) -> None:
    """first_stops (serve): the first signal calls stop and nothing is raised, so that serving
    ends at its own pace; the second is raised as handled() raises it, and remembered."""
    got, record = before
    stops: list[str] = []
    with handled():
        with pytest.raises(Terminated), first_stops(lambda: stops.append("stop")):
            signal.raise_signal(signal.SIGINT)
            assert stops == ["stop"]
            signal.raise_signal(signal.SIGTERM)
        assert stops == ["stop"]
        with pytest.raises(Terminated):
            raise_if_signalled()
    assert got == []
    assert signal.getsignal(signal.SIGINT) is record


@pytest.mark.parametrize("where", ["this thread", "another thread"])
def test_signals_held_come_when_the_block_ends_and_what_it_starts_has_them_blocked(
    before: tuple[list[int], Handler], where: str
) -> None:
    """Inside, a signal waits, whether this thread (blocked) or another one (a library's, which
    the kernel may choose) takes it; a thread started inside begins with both blocked."""
    got, record = before
    masks: list[set[signal.Signals]] = []

    def started() -> None:
        masks.append(signal.pthread_sigmask(signal.SIG_BLOCK, set()))
        if where == "another thread":
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})
            signal.raise_signal(signal.SIGTERM)

    with signals_held():
        if where == "this thread":
            signal.raise_signal(signal.SIGTERM)
        thread = threading.Thread(target=started)
        thread.start()
        thread.join()
        assert got == []
    assert got == [signal.SIGTERM]
    assert {signal.SIGINT, signal.SIGTERM} <= masks[0]
    assert signal.getsignal(signal.SIGINT) is record and signal.getsignal(signal.SIGTERM) is record
    assert signal.SIGTERM not in signal.pthread_sigmask(signal.SIG_BLOCK, set())


def test_a_ctrl_c_while_the_command_s_module_loads_is_the_interrupt_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A command's module imports numpy or matplotlib: up to half a second in which a Ctrl-C
    once gave Python's KeyboardInterrupt traceback. The signal comes from inside that import."""
    import skinframes_cli

    load = skinframes_cli._command_module

    def interrupted_load(name: str) -> object:
        signal.raise_signal(signal.SIGINT)
        return load(name)

    monkeypatch.setattr(skinframes_cli, "_command_module", interrupted_load)
    try:
        code = skinframes_cli.main(["tables"])
    except KeyboardInterrupt:
        pytest.fail("the Ctrl-C escaped main")
    assert code == 130
    assert capsys.readouterr().err == (
        "skinframes: interrupted (SIGINT); no file was left half-written\n"
    )
