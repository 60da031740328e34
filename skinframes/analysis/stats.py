"""Bounded-memory series and their summary statistics (all times in integer nanoseconds).

A :class:`Series` keeps its values in an int64 ``array.array`` (8 bytes per value, no Python
object per value), :class:`Window` only the last N of them (a live view's sliding window),
:class:`Rows` in a numpy array that grows in chunks; :class:`Summary` is what the report prints: count, min,
quartiles, median, mean, max and the population standard deviation. Quartiles are numpy's
default ("linear", Hyndman and Fan type 7), the same as Python's
``statistics.quantiles(method="inclusive")``.
"""

from __future__ import annotations

import array
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import numpy.typing as npt

__all__ = ["Rows", "Series", "Summary", "Window"]

_FIRST_CHUNK: Final = 64  # rows; the array doubles when full
_EMPTY: Final = np.empty(0, dtype=np.int64)


class _Growing:
    """Values appended one by one into a numpy array that doubles when full."""

    __slots__ = ("_n", "_values")

    def __init__(self, shape: tuple[int, ...], dtype: type[np.generic]) -> None:
        self._values: npt.NDArray[Any] = np.empty((_FIRST_CHUNK, *shape), dtype=dtype)
        self._n = 0

    def _append(self, value: Any) -> None:
        if self._n == len(self._values):
            self._values = np.concatenate([self._values, np.empty_like(self._values)])
        self._values[self._n] = value
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def _array(self) -> npt.NDArray[Any]:
        view = self._values[: self._n]
        view.flags.writeable = False
        return view


class Series:
    """A growing column of int64 values (appended one by one, read back as one array).

    Held in an ``array.array`` of C ``long long`` (8 bytes a value, as numpy's int64): ``append``
    is the array's own, with no Python frame per value (analyze calls it once per frame).
    """

    __slots__ = ("_values", "append")

    def __init__(self) -> None:
        self._values = array.array("q")
        self.append: Callable[[int], None] = self._values.append  # add one value

    def __len__(self) -> int:
        return len(self._values)

    @property
    def total(self) -> int:
        """Values ever appended (all of them are kept)."""
        return len(self._values)

    def array(self) -> npt.NDArray[np.int64]:
        """The values so far (a read-only copy: appending goes on)."""
        out = np.frombuffer(self._values, dtype=np.int64).copy() if self._values else _EMPTY
        out.flags.writeable = False
        return out


class Window:
    """A :class:`Series` that keeps only its last ``size`` values (memory independent of how
    many come), and counts every value appended (:attr:`total`)."""

    __slots__ = ("_values", "total")

    def __init__(self, size: int) -> None:
        self._values: deque[int] = deque(maxlen=size)
        self.total = 0

    def append(self, value: int) -> None:
        """Add one value (the oldest goes when the window is full)."""
        self._values.append(value)
        self.total += 1

    def __len__(self) -> int:
        return len(self._values)

    def array(self) -> npt.NDArray[np.int64]:
        """The values in the window, oldest first (a read-only copy)."""
        out = np.fromiter(self._values, dtype=np.int64, count=len(self._values))
        out.flags.writeable = False
        return out


class Rows(_Growing):
    """A growing 2-D uint16 table of fixed width (one row per frame: its working counters)."""

    __slots__ = ()

    def __init__(self, width: int) -> None:
        super().__init__((width,), np.uint16)

    def append(self, row: Sequence[int]) -> None:
        """Add one row of ``width`` values."""
        self._append(row)

    def array(self) -> npt.NDArray[np.uint16]:
        """The rows so far, shape (n, width) (a read-only view)."""
        return self._array()


@dataclass(frozen=True, slots=True)
class Summary:
    """Summary statistics of a series of nanosecond values (floats where they interpolate)."""

    count: int
    min_ns: int | None
    q1_ns: float | None
    median_ns: float | None
    q3_ns: float | None
    mean_ns: float | None
    max_ns: int | None
    std_ns: float | None

    @classmethod
    def of(cls, values: npt.NDArray[np.int64]) -> Summary:
        """Statistics of ``values`` (count 0 and None elsewhere for an empty array)."""
        if len(values) == 0:
            return cls(0, None, None, None, None, None, None, None)
        q1, median, q3 = (float(q) for q in np.percentile(values, [25, 50, 75]))
        return cls(
            count=len(values),
            min_ns=int(values.min()),
            q1_ns=q1,
            median_ns=median,
            q3_ns=q3,
            mean_ns=float(values.mean()),
            max_ns=int(values.max()),
            std_ns=float(values.std()),
        )

    def to_json(self) -> dict[str, Any]:
        """``{"count", "min_ns", "q1_ns", "median_ns", "q3_ns", "mean_ns", "max_ns", "std_ns"}``."""
        return {
            "count": self.count,
            "min_ns": self.min_ns,
            "q1_ns": self.q1_ns,
            "median_ns": self.median_ns,
            "q3_ns": self.q3_ns,
            "mean_ns": self.mean_ns,
            "max_ns": self.max_ns,
            "std_ns": self.std_ns,
        }
