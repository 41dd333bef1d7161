"""Lloyd's algorithm on the bin grid: weighted-centroid goals and the bounded step.

Each robot r moves towards the weighted centroid of its cell (Dames 2020 eq. 8, Chen et al.
eq. 2), the integral being replaced by the sum over the bins it owns (see
:func:`phd_swarm.core.geometry.ownership.assign_bins`), and advances at most ``d_step`` per
time step
along the straight line to it (Chen eq. 3).

The weighting function phi is one of (Dames Sec. II-C and IV, Chen Alg. 1):

- ``phd``: the PHD bin masses (Dames: phi = v; Chen: w_i for busy robots);
- ``uniform``: 1 per bin, the coverage controller of Dames Sec. IV (Cortes et al.);
- ``cumulative``: Chen's cumulative estimate wc (eq. 11), for idle robots.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .grid import Grid
from .polygons import polygon_area, polygon_centroid


def _as_point(name: str, value: np.ndarray) -> np.ndarray:
    p = np.asarray(value, dtype=float).reshape(-1)
    if p.shape != (2,) or not np.isfinite(p).all():
        raise ValueError(f"{name} must be two finite numbers, got {value!r}")
    return p


def weighted_centroid(centres: np.ndarray, weights: np.ndarray,
                      fallback: np.ndarray | Callable[[], np.ndarray]) -> np.ndarray:
    """Weighted centroid sum_k w_k x_k / sum_k w_k over bins (Dames eq. 8, Chen eq. 2).

    The bin-centre rule turns the integrals of eq. 8 into sums: with masses w_k (e.g. the
    expected target count of bin k) the bin area cancels.

    Parameters
    ----------
    centres : np.ndarray, shape (K, 2)
        Bin centres x_k [m]; K may be 0.
    weights : np.ndarray, shape (K,)
        Non-negative weights w_k (any unit; only ratios matter).
    fallback : np.ndarray, shape (2,), or a callable returning one
        Returned when K = 0 or all w_k = 0, where eq. 8 is undefined. Callers pass the
        geometric centroid of the cell (:func:`centroid_goal` does), which is what a
        uniform weighting would give. A callable is called only then.

    Returns
    -------
    np.ndarray, shape (2,)
        The centroid [m].

    Raises
    ------
    ValueError
        On mismatched shapes, non-finite weights or negative weights (phi must be
        non-negative, Dames Sec. II-C).
    """
    x = np.asarray(centres, dtype=float).reshape(-1, 2)
    w = np.asarray(weights, dtype=float).reshape(-1)
    fb = None if callable(fallback) else _as_point("fallback", fallback)
    if w.shape[0] != x.shape[0]:
        raise ValueError(f"got {w.shape[0]} weights for {x.shape[0]} bin centres")
    if not np.all(np.isfinite(w)):
        raise ValueError("centroid weights must be finite")
    if np.any(w < 0):
        raise ValueError(f"centroid weights must be non-negative; the smallest is {w.min()}")
    if x.shape[0] == 0 or not w.max() > 0:
        return _as_point("fallback", fallback()) if fb is None else fb.copy()
    # PHD masses of long-observed empty bins decay geometrically into the subnormal range,
    # where w @ x underflows; scaling by the largest weight keeps the ratio exact enough.
    w = w / w.max()
    return (w @ x) / w.sum()


def centroid_goal(grid: Grid, owned_flat_idx: np.ndarray, weights_of_owned: np.ndarray,
                  cell_polygon: np.ndarray | Callable[[], np.ndarray],
                  position: np.ndarray) -> np.ndarray:
    """Lloyd goal of one robot: the weighted centroid of the bins it owns (Dames eq. 8).

    Falls back, in order, to the area centroid of ``cell_polygon`` when the weights sum to
    zero (or no bin is owned), then to ``position`` when the cell is empty (a power cell
    can be, Chen eq. 12), so the robot stays put rather than chasing an undefined goal.

    Parameters
    ----------
    grid : Grid
        The bin grid.
    owned_flat_idx : np.ndarray of int, shape (K,)
        Flat indices of the bins the robot owns.
    weights_of_owned : np.ndarray, shape (K,)
        phi at those bins, >= 0 (the controllers' weights, :mod:`phd_swarm.core.controllers`).
    cell_polygon : np.ndarray, shape (V, 2), or a callable returning it
        The robot's cell [m]; (0, 2) if empty. A callable is called only when the
        fallback is needed (a caller that has no polygon at hand computes it then).
    position : np.ndarray, shape (2,)
        The robot's position q [m].

    Returns
    -------
    np.ndarray, shape (2,)
        Goal g [m].
    """
    q = _as_point("position", position)

    def fallback() -> np.ndarray:
        poly = cell_polygon() if callable(cell_polygon) else cell_polygon
        poly = np.asarray(poly, dtype=float).reshape(-1, 2)
        return polygon_centroid(poly) if polygon_area(poly) > 0 else q

    idx = np.asarray(owned_flat_idx, dtype=np.int64).reshape(-1)
    return weighted_centroid(grid.centres_of(idx), weights_of_owned, fallback)


def step_length(max_speed: float, dt: float) -> float:
    """d_step = v_max * dt [m], the distance a robot can move in one step (Chen eq. 3).

    ``max_speed`` [m/s] and ``dt`` [s] must be finite and > 0 (Dames Sec. IV: 2 m/s;
    Chen Sec. 4: 5 m/s).
    """
    for name, value in (("max_speed", max_speed), ("dt", dt)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(max_speed) * float(dt)


def control_step(position: np.ndarray, goal: np.ndarray, d_step: float) -> np.ndarray:
    """Control input u = min(d_step, |g - q|) (g - q) / |g - q| (Chen eq. 3), u = 0 at g.

    Parameters
    ----------
    position : np.ndarray, shape (2,)
        q [m].
    goal : np.ndarray, shape (2,)
        g [m].
    d_step : float
        Largest step [m], > 0 (:func:`step_length`).

    Returns
    -------
    np.ndarray, shape (2,)
        Displacement u [m]; |u| <= d_step, and u = g - q when the goal is within reach.
        Use :func:`next_position` for q + u landing exactly on g.
    """
    q = _as_point("position", position)
    g = _as_point("goal", goal)
    if not (np.isfinite(d_step) and d_step > 0):
        raise ValueError(f"d_step must be a finite number > 0, got {d_step!r}")
    delta = g - q
    dist = float(np.hypot(delta[0], delta[1]))
    if dist <= d_step:
        return delta
    return delta * (d_step / dist)


def next_position(position: np.ndarray, goal: np.ndarray, d_step: float) -> np.ndarray:
    """Position after one step of Chen eq. 3, q + u [m], shape (2,).

    When the goal is within ``d_step`` the result is ``goal`` itself, not q + (g - q),
    which can differ from g in the last bit and would keep a converged robot jittering.
    """
    q = _as_point("position", position)
    g = _as_point("goal", goal)
    u = control_step(q, g, d_step)
    delta = g - q
    if np.hypot(delta[0], delta[1]) <= d_step:
        return g.copy()
    return q + u
