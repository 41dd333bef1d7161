"""Checks of the target models' arguments, and read-only arrays of their state.

Shared by the target kinds' modules (:mod:`phd_swarm.sim.dames_targets`,
:mod:`phd_swarm.sim.walkers`) and the scenario: a bad box, count or rate is a
``ValueError`` naming the argument, and a model's positions, headings and ids are handed out
frozen so no caller can move a target behind the model's back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from phd_swarm.core.geometry.grid import Environment


def frozen(a: np.ndarray) -> np.ndarray:
    """``a``, made read-only."""
    a.setflags(write=False)
    return a


def check_box(name: str, box: Sequence[float]) -> np.ndarray:
    """A box (xmin, ymin, xmax, ymax) with xmax > xmin and ymax > ymin, as an array."""
    b = np.asarray(box, dtype=float).reshape(-1)
    if b.shape != (4,) or not np.all(np.isfinite(b)) or not (b[2] > b[0] and b[3] > b[1]):
        raise ValueError(f"{name} must be (xmin, ymin, xmax, ymax) with xmax > xmin and "
                         f"ymax > ymin, got {box!r}")
    return b


def check_count(name: str, count: int) -> int:
    """An integer count >= 0."""
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
        raise ValueError(f"{name} must be an integer >= 0, got {count!r}")
    return int(count)


def check_nonneg(name: str, value: float, positive: bool = False) -> float:
    """A finite number >= 0 (> 0 with ``positive``)."""
    ok = np.isfinite(value) and (value > 0 if positive else value >= 0)
    if not ok:
        raise ValueError(f"{name} must be a finite number {'> 0' if positive else '>= 0'}, "
                         f"got {value!r}")
    return float(value)


def check_inside(name: str, box: Sequence[float], env: Environment) -> None:
    """Raise unless the box (xmin, ymin, xmax, ymax) [m] lies inside the map ``env``."""
    if not (box[0] >= env.xmin and box[1] >= env.ymin and box[2] <= env.xmax
            and box[3] <= env.ymax):
        raise ValueError(f"{name} {box} must lie inside the environment "
                         f"({env.xmin}, {env.ymin}, {env.xmax}, {env.ymax})")
