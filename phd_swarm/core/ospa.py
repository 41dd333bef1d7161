"""Optimal SubPattern Assignment (OSPA) distance between two finite sets of 2-D points.

Dames (2020) eq. 12 and Chen, Dames & Park (2021) eq. 15, both citing Schuhmacher, Vo & Vo,
"A consistent metric for performance evaluation of multi-object filters", IEEE TSP 56(8),
2008. For X = {x_1..x_m}, Y = {y_1..y_n} with m <= n (swap otherwise), cut-off c > 0 [m]
and order 1 <= p < inf::

    d_p^(c)(X, Y) = ( (1/n) * ( min_pi sum_{i=1..m} d_c(x_i, y_pi(i))^p
                                + c^p * (n - m) ) )^(1/p),
    d_c(x, y) = min(c, ||x - y||),

the minimum running over injections pi of {1..m} into {1..n}. Dames' eq. 12 as printed
closes the 1/n before the cardinality term; we follow Chen's eq. 15 and Schuhmacher et al.,
where 1/n multiplies both terms (otherwise the distance is not bounded by c and not a
metric). The papers use c = 10 m and p = 1.

The result is in metres and lies in [0, c]: 0 for two empty sets, c when exactly one set
is empty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from .geometry.points import as_points


@dataclass(frozen=True)
class OspaComponents:
    """OSPA distance and its split into localisation and cardinality parts.

    For finite p, ``distance**p == localisation**p + cardinality**p`` (Schuhmacher et al.
    2008, Sec. IV-C) with, for m <= n,

    - ``localisation = ((1/n) * min_pi sum_i d_c(x_i, y_pi(i))^p)^(1/p)``,
    - ``cardinality = (c^p * (n - m) / n)^(1/p)``.

    For p = inf both are the limits p -> inf of those expressions: ``localisation`` is the
    bottleneck cost ``min_pi max_i d_c(x_i, y_pi(i))`` of the best injection (0 if m = 0),
    ``cardinality`` is c if m != n else 0, and ``distance = max(localisation,
    cardinality)``.

    Attributes
    ----------
    distance : float
        OSPA distance d_p^(c)(X, Y) [m], in [0, c].
    localisation : float
        Part due to the distances between assigned points [m].
    cardinality : float
        Part due to the difference in the number of points [m].
    """

    distance: float
    localisation: float
    cardinality: float


def _as_points(name: str, points: np.ndarray) -> np.ndarray:
    return as_points(points, name)


def _check_params(c: float, p: float) -> None:
    if not (np.isfinite(c) and c > 0):
        raise ValueError(f"c (cut-off distance) must be a finite number > 0, got {c!r}")
    if np.isnan(p) or p < 1:
        raise ValueError(f"p (order) must be in [1, inf], got {p!r}")


def _bottleneck(dc: np.ndarray) -> float:
    """Return the bottleneck cost: min over injections pi of max_i dc[i, pi(i)].

    ``dc`` has shape (m, n) with 1 <= m <= n.

    Binary search over the distinct entries: a threshold t is feasible when every row can
    be assigned to a distinct column with an entry <= t, i.e. when the assignment on the
    0/1 cost ``dc > t`` costs nothing.
    """
    values = np.unique(dc)
    lo, hi = 0, values.size - 1
    while lo < hi:
        mid = (lo + hi) // 2
        over = (dc > values[mid]).astype(float)
        rows, cols = linear_sum_assignment(over)
        if over[rows, cols].sum() == 0.0:
            hi = mid
        else:
            lo = mid + 1
    return float(values[lo])


def ospa_components(X: np.ndarray, Y: np.ndarray, c: float = 10.0,
                    p: float = 1.0) -> OspaComponents:
    """OSPA distance with its localisation and cardinality parts (Dames eq. 12).

    Parameters
    ----------
    X : np.ndarray, shape (m, 2)
        First point set [m], e.g. the true target positions; m may be 0.
    Y : np.ndarray, shape (n, 2)
        Second point set [m], e.g. the estimated target positions; n may be 0.
    c : float
        Cut-off distance [m] (> 0); also the penalty per unassigned point.
    p : float
        Order, in [1, inf]. ``p = inf`` uses the max-based definition of Schuhmacher et
        al.: c if m != n, else the bottleneck assignment ``min_pi max_i d_c(x_i,
        y_pi(i))``.

    Returns
    -------
    OspaComponents
        Distance, localisation and cardinality parts [m]; see :class:`OspaComponents`.

    Raises
    ------
    ValueError
        If X or Y is not an (k, 2) array of finite values, c is not a finite positive
        number, or p is not in [1, inf].

    Notes
    -----
    The optimal assignment is found with ``scipy.optimize.linear_sum_assignment`` on the
    cut-off cost matrix ``d_c^p`` (rectangular, so all m points of the smaller set are
    assigned), O(n^3). The metric is symmetric in X and Y.
    """
    x = _as_points("X", X)
    y = _as_points("Y", Y)
    c = float(c)
    p = float(p)
    _check_params(c, p)
    if x.shape[0] > y.shape[0]:
        x, y = y, x
    m, n = x.shape[0], y.shape[0]
    if n == 0:
        return OspaComponents(0.0, 0.0, 0.0)

    dc = np.minimum(cdist(x, y), c)
    if np.isinf(p):
        loc = _bottleneck(dc) if m > 0 else 0.0
        card = c if m != n else 0.0
        return OspaComponents(max(loc, card), loc, card)

    # Costs in units of c keep every term in [0, 1]: c^p overflows for large p, and a
    # common scale factor does not change the optimal assignment.
    cost = (dc / c) ** p
    rows, cols = linear_sum_assignment(cost)
    loc_cost = float(cost[rows, cols].sum())
    total = (loc_cost + (n - m)) / n
    return OspaComponents(distance=c * total ** (1.0 / p),
                          localisation=c * (loc_cost / n) ** (1.0 / p),
                          cardinality=c * ((n - m) / n) ** (1.0 / p))


def ospa(X: np.ndarray, Y: np.ndarray, c: float = 10.0, p: float = 1.0) -> float:
    """OSPA distance d_p^(c)(X, Y) [m] between point sets X (m, 2) and Y (n, 2).

    Dames (2020) eq. 12 / Schuhmacher et al. (2008); the formula and the p = inf case are
    in the module docstring and :func:`ospa_components`. Returns a value in [0, c]: 0 when
    both sets are empty, c when exactly one is.
    """
    return ospa_components(X, Y, c=c, p=p).distance
