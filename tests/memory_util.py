"""What the memory tests measure: the peak of what Python (and numpy) allocate while some work
runs, counted by tracemalloc, so the machine's load does not matter."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable


def traced_peak(work: Callable[[], object]) -> int:
    """The peak bytes allocated while ``work()`` runs (what it allocated before is not counted)."""
    tracemalloc.start()
    try:
        work()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
