"""Simulated radios: who can hear whom, from the robots' positions at a step.

An exchange asks its radio which of the live robots a robot reaches at step k
(:meth:`Radio.contacts`), from the world's team state of that step (ids, positions, alive
flags), and sends only to those: messages per robot per step grow with the robots in reach,
not with the team.

- :class:`SameNodeRadio` (Shirsat & Berman Sec. II, IV): robots hear each other when they
  occupy the same node of the grid (positions equal within ``tolerance`` metres: the
  world moves a walking robot exactly onto its node, so the tolerance only absorbs the
  last bit of a floating-point move).
- :class:`RangeRadio` (Papaioannou et al., range C_R): robots hear each other within
  ``range`` metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RangeRadio:
    """Robots within ``range`` metres hear each other (the disk of radius C_R)."""

    range: float

    def __post_init__(self) -> None:
        if not np.isfinite(self.range) or self.range < 0.0:
            raise ValueError(f"radio range must be finite and >= 0 m, got {self.range!r}")

    def contacts(self, me: int, ids: np.ndarray, positions: np.ndarray,
                 alive: np.ndarray) -> np.ndarray:
        """Ids of the live robots other than ``me`` that ``me`` reaches, ascending.

        Parameters
        ----------
        me : int
            The robot asking.
        ids : np.ndarray of int, shape (R,)
        positions : np.ndarray, shape (R, 2) [m]
        alive : np.ndarray of bool, shape (R,)
        """
        ids = np.asarray(ids, dtype=np.int64)
        mine = np.flatnonzero(ids == me)
        if not mine.size:
            raise ValueError(f"robot {me} is not in the team {ids.tolist()}")
        d = np.hypot(*(np.asarray(positions, dtype=float) - positions[mine[0]]).T)
        hear = (d <= self.range) & np.asarray(alive, dtype=bool) & (ids != me)
        return np.sort(ids[hear])


class SameNodeRadio(RangeRadio):
    """Robots on the same grid node hear each other (Shirsat & Berman's renewal epochs)."""

    def __init__(self, tolerance: float = 1e-6) -> None:
        super().__init__(tolerance)
