"""Arrays of 2-D points, checked where they enter: one rule for every module that takes them.

:func:`as_points` turns positions (a set of targets or estimates, K x 2 [m]) into a float
array, refusing anything else with an error that names where it came from; ``[]`` is the
empty set. Used by OSPA (:mod:`.ospa`) and the reward sets (:mod:`.shirsat.reward_sets`).
"""

from __future__ import annotations

import numpy as np


def as_points(points: np.ndarray, where: str = "points") -> np.ndarray:
    """``points`` as a float array (K, 2) [m], checked; ``[]`` is the empty set.

    Raises
    ------
    ValueError
        Naming ``where``, if the shape is not (K, 2) or a coordinate is not finite.
    """
    try:
        a = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: expected an array of 2-D points (K, 2)") from None
    if a.size == 0:
        return a.reshape(0, 2)
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"{where}: expected shape (K, 2), got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{where}: coordinates must be finite (no NaN or inf)")
    return a
