"""A run's per-step rows (the monitor's figures of each step) kept as typed numpy columns.

The monitor appends one row a step (``step``, ``t``, the OSPA and its parts, the
cardinalities, robots alive and reported, messages per robot, the estimator's figures) and
writes the run's summary from all of them at the end. As a list of dicts that is ~1.5 kB a
step, ~10 MB per sim-hour at 2 Hz, the most of the monitor's growth in the hour's soak
after the DDS histories (docs/benchmarks.md); as columns it is 8 bytes per figure and step.

:class:`StepSeries` is a sequence of row dicts as before (``len``, indexing, iteration give
dicts equal to those appended, ints as ints, floats as floats) and gives a column at once
(:meth:`StepSeries.column`). A figure that a row lacks (an estimator's figure that some
steps do not have) is NaN in its column and left out of that row again; a None is NaN too.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any, overload

import numpy as np


class StepSeries(Sequence):
    """Rows of numbers (dicts) as typed columns, amortised O(1) to append."""

    def __init__(self) -> None:
        self._columns: dict[str, np.ndarray] = {}
        #: Columns that some row lacks: their NaN means "not in the row".
        self._sparse: set[str] = set()
        self._n = 0

    def append(self, row: Mapping[str, Any]) -> None:
        """Add a row (name -> int, float or None)."""
        n = self._n
        if self._columns and n == len(next(iter(self._columns.values()))):
            for name, col in self._columns.items():
                grown = np.empty(max(16, 2 * n), dtype=col.dtype)
                grown[:n] = col[:n]
                self._columns[name] = grown
        for name, value in row.items():
            col = self._columns.get(name)
            whole = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
            if col is None:
                col = np.empty(max(16, len(next(iter(self._columns.values()), ())), n + 1),
                               dtype=np.int64 if whole else np.float64)
                if n:
                    col = col.astype(np.float64)
                    col[:n] = np.nan
                    self._sparse.add(name)
                self._columns[name] = col
            elif col.dtype == np.int64 and not whole:
                col = self._columns[name] = col.astype(np.float64)
            col[n] = np.nan if value is None else value
        for name, col in self._columns.items():
            if name not in row:
                if col.dtype == np.int64:
                    col = self._columns[name] = col.astype(np.float64)
                col[n] = np.nan
                self._sparse.add(name)
        self._n = n + 1

    def __len__(self) -> int:
        return self._n

    def _row(self, i: int) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name, col in self._columns.items():
            value = col[i]
            if col.dtype == np.int64:
                out[name] = int(value)
            elif not (name in self._sparse and np.isnan(value)):
                out[name] = float(value)
        return out

    @overload
    def __getitem__(self, i: int) -> dict[str, Any]: ...

    @overload
    def __getitem__(self, i: slice) -> list[dict[str, Any]]: ...

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._row(j) for j in range(*i.indices(self._n))]
        if not -self._n <= i < self._n:
            raise IndexError(i)
        return self._row(i % self._n)

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return (self._row(i) for i in range(self._n))

    def column(self, name: str) -> np.ndarray:
        """The values of ``name`` in every row (a view; NaN where a row lacks it)."""
        col = self._columns.get(name)
        return np.full(self._n, np.nan) if col is None else col[:self._n]

    def nbytes(self) -> int:
        """Bytes the columns hold (with the room to grow)."""
        return sum(col.nbytes for col in self._columns.values())
