"""A progress bar on stderr for long runs, only when stderr is a terminal; each step also stops
the run for a signal that something swallowed (:mod:`skinframes_cli.signals`)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from skinframes_cli.signals import raise_if_signalled

__all__ = ["progress_bar"]


@contextmanager
def progress_bar(total: int | None, unit: str) -> Iterator[Callable[[int], None]]:
    """A callback that advances a bar by n; the bar shows itself after a second, and only on
    a terminal (tqdm's ``delay``), so short runs and pipes stay quiet. ``total`` None: a
    counter with its rate (the end is not known, as in a log's first pass)."""
    if not sys.stderr.isatty():  # no bar: tqdm is not even imported (start-up time)
        yield _ignore
        return
    from tqdm import tqdm

    with tqdm(
        total=total,
        unit=f" {unit}",
        unit_scale=True,
        delay=1.0,
        file=sys.stderr,
        leave=False,
    ) as bar:

        def advance(n: int) -> None:
            raise_if_signalled()
            bar.update(n)

        yield advance


def _ignore(n: int) -> None:
    """Progress nobody sees (a signal a step swallowed still stops the run)."""
    raise_if_signalled()
