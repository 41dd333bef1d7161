"""Steps seen, and what held at each step, in memory that grows with the changes, not the steps.

The recorder notes the step of every step message it records (hundreds of topics, one
message per step each) and the alive flags of every team state; the monitor the robots
alive at each step. Kept as a Python ``set`` of ints and a dict of arrays, that is ~60
bytes per topic and step: ~75 MB per sim-hour for the recorder of a 20-robot run at 2 Hz
(the soak, docs/benchmarks.md). A run's steps come in order and without gaps, and who is
alive changes a few times a run, so both are kept by their changes instead:

- :class:`StepSet`: a set of steps as sorted disjoint runs ``lo..hi``; a step next to the
  last run extends it in O(1), any other step in O(log runs); memory O(gaps).
- :class:`Timeline`: a mapping step -> value (alive flags, a frozenset of robots) for the
  steps that have one, holding a value only where it differs from the value of the step
  before it; memory O(steps seen as runs + changes).

Both behave as the ``set`` and ``dict`` they replace (``in``, ``len``, iteration in
ascending order, ``get``); rclpy-free, so evaluate and replay may use them too.
"""

from __future__ import annotations

import operator
from bisect import bisect_right
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

import numpy as np


class StepSet:
    """A set of integer steps kept as sorted disjoint runs ``lo..hi`` (inclusive)."""

    __slots__ = ("_lo", "_hi", "_n")

    def __init__(self, steps: Iterable[int] = ()) -> None:
        self._lo: list[int] = []
        self._hi: list[int] = []
        self._n = 0
        for k in steps:
            self.add(k)

    def add(self, k: int) -> None:
        """Add step ``k``; O(1) when it extends the last run, else O(runs) at worst."""
        k = int(k)
        lo, hi = self._lo, self._hi
        if hi and k == hi[-1] + 1:
            hi[-1] = k
            self._n += 1
            return
        i = bisect_right(lo, k) - 1  # the run starting at or before k
        if i >= 0 and k <= hi[i]:
            return
        left = i >= 0 and hi[i] == k - 1
        right = i + 1 < len(lo) and lo[i + 1] == k + 1
        if left and right:  # k closes the gap between two runs
            hi[i] = hi[i + 1]
            del lo[i + 1], hi[i + 1]
        elif left:
            hi[i] = k
        elif right:
            lo[i + 1] = k
        else:
            lo.insert(i + 1, k)
            hi.insert(i + 1, k)
        self._n += 1

    def __contains__(self, k: object) -> bool:
        if not isinstance(k, (int, np.integer)):
            return False
        i = bisect_right(self._lo, int(k)) - 1
        return i >= 0 and k <= self._hi[i]

    def __len__(self) -> int:
        return self._n

    def __iter__(self) -> Iterator[int]:
        for lo, hi in zip(self._lo, self._hi, strict=True):
            yield from range(lo, hi + 1)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, StepSet):
            return self._lo == other._lo and self._hi == other._hi
        if isinstance(other, (set, frozenset)):
            return len(other) == self._n and all(k in self for k in other)
        return NotImplemented

    def __repr__(self) -> str:
        return f"StepSet({self.runs()})"

    @property
    def last(self) -> int | None:
        """The largest step, None when empty."""
        return self._hi[-1] if self._hi else None

    def runs(self) -> list[tuple[int, int]]:
        """The runs ``(lo, hi)``, inclusive, ascending."""
        return list(zip(self._lo, self._hi, strict=True))

    def after(self, k: int) -> int | None:
        """The smallest step greater than ``k``, None if there is none."""
        i = bisect_right(self._lo, k) - 1
        if i >= 0 and k < self._hi[i]:
            return k + 1
        return self._lo[i + 1] if i + 1 < len(self._lo) else None

    def array(self) -> np.ndarray:
        """The steps as a sorted int64 array."""
        if not self._lo:
            return np.zeros(0, dtype=np.int64)
        return np.concatenate([np.arange(lo, hi + 1, dtype=np.int64)
                               for lo, hi in zip(self._lo, self._hi, strict=True)])


def _same_flags(a: Any, b: Any) -> bool:
    return bool(np.array_equal(a, b))


class Timeline(Mapping):
    """A mapping step -> value that stores a value only where it changes (see the module).

    ``same(a, b)`` says whether two values are equal: ``==`` by default (frozensets);
    :meth:`flags` makes one for arrays of alive flags (stored read-only copies).
    """

    def __init__(self, same: Callable[[Any, Any], bool] = operator.eq) -> None:
        self._same = same
        self._steps = StepSet()
        #: Steps where a value is stored (ascending), and their values.
        self._at: list[int] = []
        self._values: list[Any] = []

    @classmethod
    def flags(cls) -> Timeline:
        """A timeline of boolean arrays (the recorder's alive flags per team state)."""
        return cls(_same_flags)

    def _stored(self, k: int) -> Any:
        """The value in effect at step ``k`` (the last stored at or before it)."""
        i = bisect_right(self._at, k) - 1
        return self._values[i] if i >= 0 else None

    def __setitem__(self, k: int, value: Any) -> None:
        k = int(k)
        if isinstance(value, np.ndarray):
            value = value.copy()
            value.flags.writeable = False
        i = bisect_right(self._at, k) - 1
        stored_here = i >= 0 and self._at[i] == k
        if not stored_here and i >= 0 and self._same(self._values[i], value):
            self._steps.add(k)  # the value in effect already: nothing to store
            return
        following = self._steps.after(k)
        if following is not None:
            j = bisect_right(self._at, following) - 1
            if self._at[j] != following:
                # The next step took its value from k or before: pin it there, so that
                # k's value does not become the next step's.
                self._at.insert(j + 1, following)
                self._values.insert(j + 1, self._values[j])
        if stored_here:
            self._values[i] = value
        else:
            self._at.insert(i + 1, k)
            self._values.insert(i + 1, value)
        self._steps.add(k)

    def __getitem__(self, k: int) -> Any:
        if k not in self._steps:
            raise KeyError(k)
        return self._stored(int(k))

    def __contains__(self, k: object) -> bool:
        return k in self._steps

    def __iter__(self) -> Iterator[int]:
        return iter(self._steps)

    def __len__(self) -> int:
        return len(self._steps)

    @property
    def last(self) -> int | None:
        """The largest step with a value, None when empty."""
        return self._steps.last

    def changes(self) -> int:
        """Values stored (the memory this timeline holds)."""
        return len(self._values)
