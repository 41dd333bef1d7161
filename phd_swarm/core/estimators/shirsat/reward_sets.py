"""The union of estimated target sets: Shirsat & Berman's rewards (eq. 6, Alg. 1-3).

A robot's *reward* M_k is the set of target positions it has estimated so far. Each step
it adds the targets it extracted (Alg. 1 line d, ``M_k = M_{k-1} U X_hat_k``), and when
robots meet at a node they exchange their rewards and each keeps the union (eq. 6, Alg. 2;
Alg. 3 adds a pair's estimates to their common set only if they are not in it yet).

The sets here are real-valued: positions [m] extracted from a Gaussian mixture. The same
target is estimated at a slightly different position at every step and by every robot, so
the test of Alg. 3, ``x_temp not in X``, never holds for a real-valued estimate: an
exact-equality union would add every target again at every step (M grows by the targets in
view, step after step) and the reward's cardinality, the paper's estimated number of targets
(Fig. 5b, t_reward), would count estimates, not targets. :func:`union` therefore reads
"``x`` is in the set" as "``x`` lies within ``distance`` of a point of the set", which is the
exact union when ``distance`` is 0 and the points are distinct.

The rule, precisely: the points of all the sets are taken in order (the first set's rows in
order, then the second's, ...), and a point is kept unless it lies within ``distance``
(Euclidean, boundary included) of a point kept before it. So

- the result depends only on the order of the inputs (no tie-breaking, no randomness), and
  ``union(sets) == union([concatenate(sets)])``;
- within one set the same rule applies: a set's later row within ``distance`` of one of its
  own earlier kept rows is dropped (an extraction that gives ``round(w) = 2`` copies of a
  component's mean is one point of the reward);
- a kept point is never replaced by a later one, so ``union([M, X])`` contains ``M`` as it
  was (up to its own duplicates) and a reward never loses a target it once had;
- the first set survives whole if its points are farther than ``distance`` apart;
- a later point within ``distance`` of a dropped point but farther than ``distance`` from
  every kept point is kept (the dropped point does not shadow anything).

The greedy rule is not symmetric in the inputs (two points of two sets within ``distance``:
the earlier one is kept), so the rewards of two robots that meet are made equal by taking
the sets in an order both robots agree on: increasing robot id
(:meth:`phd_swarm.core.estimators.shirsat.estimator.ShirsatEstimator.merge_rewards`).

**The labelled reading.** Eq. 19 makes a member a tuple <l, v>, l "a label for the tracked
target, such as one of its properties, e.g. its color, shape, size or its position in the
environment". :func:`union` reads the label as the position (the default); with a sensor
that identifies the targets it detects, :func:`union_by_label` reads it as that identity:
``x`` is in the set when its label is, and an estimate without a label is not added.

Reference: A. Shirsat and S. Berman, "Decentralized multi-target tracking with multiple
quadrotors using a PHD filter", AIAA SciTech 2021, eq. 6, Alg. 1-3.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...geometry.points import as_points

__all__ = ["as_labels", "as_points", "extend", "extend_by_label", "union", "union_by_label"]


def _first_of_each_cluster(points: np.ndarray, d2: float) -> np.ndarray:
    """Rows of ``points`` kept by the greedy rule within one set, in order.

    ``close[i, j]`` (j > i) marks pairs within the distance; row i, if still kept, drops
    the later rows close to it. O(K^2) numpy for the pairs; the Python loop runs only over
    the rows that have a close later row, none in the usual case.
    """
    diff = points[:, None, :] - points[None, :, :]
    close = np.triu(np.einsum("ijd,ijd->ij", diff, diff) <= d2, k=1)
    alive = np.ones(len(points), dtype=bool)
    for i in np.flatnonzero(close.any(axis=1)):
        if alive[i]:
            alive &= ~close[i]
    return points[alive]


def union(sets: Sequence[np.ndarray], distance: float) -> np.ndarray:
    """The union of point sets, a point within ``distance`` of a kept one being the same.

    Eq. 6 / Alg. 1 line d / Alg. 3 for real-valued estimates; the rule and why it is a
    distance rule are in the module docstring. Each set is compared with the points kept
    from the earlier sets at once (vectorised), then the greedy rule runs within the set.

    Parameters
    ----------
    sets : sequence of np.ndarray, each shape (K_i, 2)
        Point sets [m], taken in the order given; an empty set may be ``[]`` or shape
        (0, 2).
    distance : float
        Points at most this far apart [m] are one target, finite and >= 0 (0: only equal
        points are).

    Returns
    -------
    np.ndarray, shape (K, 2)
        The kept points in the order they were met (a new array).

    Raises
    ------
    ValueError
        If ``distance`` is negative or not finite, or a set is malformed (naming it).
    """
    kept = _grow([], sets, _squared(distance))
    return np.concatenate(kept) if kept else np.empty((0, 2))


def extend(reduced: np.ndarray, sets: Sequence[np.ndarray], distance: float) -> np.ndarray:
    """``union([reduced, *sets], distance)`` for a ``reduced`` that is already a union.

    A robot's reward grows by the targets of each step (Alg. 1 line d); its points are
    farther than ``distance`` apart already, so the greedy rule keeps all of them and only
    the new sets need comparing. The result equals :func:`union`'s, and is ``reduced``
    itself (not a copy) when nothing is added, which is most steps.

    Parameters
    ----------
    reduced : np.ndarray, shape (K, 2)
        A :func:`union` result [m] (trusted: not checked again).
    sets : sequence of np.ndarray, each shape (K_i, 2)
        The sets to add, in order.
    distance : float
        As for :func:`union`.
    """
    d2 = _squared(distance)
    if not any(len(s) for s in sets):
        return reduced
    kept = _grow([reduced] if len(reduced) else [], sets, d2)
    return np.concatenate(kept) if kept else np.empty((0, 2))


def _squared(distance: float) -> float:
    """``distance`` squared, after checking it is a finite number >= 0."""
    try:
        d = float(distance)
    except (TypeError, ValueError):
        raise ValueError(f"distance must be a number >= 0, got {distance!r}") from None
    if not np.isfinite(d) or d < 0.0:
        raise ValueError(f"distance must be finite and >= 0, got {distance!r}")
    return d * d


def _grow(kept: list[np.ndarray], sets: Sequence[np.ndarray], d2: float) -> list[np.ndarray]:
    """Add each set's points to ``kept`` (points pairwise farther than sqrt(d2)) by the rule."""
    n_kept = sum(len(k) for k in kept)
    for i, s in enumerate(sets):
        pts = as_points(s, f"sets[{i}]")
        if n_kept and len(pts):
            previous = kept[0] if len(kept) == 1 else np.concatenate(kept)
            diff = pts[:, None, :] - previous[None, :, :]
            far = np.einsum("ijd,ijd->ij", diff, diff) > d2
            pts = pts[far.all(axis=1)]
        if len(pts) > 1:
            pts = _first_of_each_cluster(pts, d2)
        if len(pts):
            kept.append(pts)
            n_kept += len(pts)
    return kept


def union_by_label(sets: Sequence[tuple[np.ndarray, np.ndarray]]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The union of labelled sets <l, v> (eq. 19): one member per label, the first met.

    The labelled reading of eq. 6 / Alg. 1 line d / Alg. 3, for a sensor that identifies
    targets (:mod:`phd_swarm.core.sensors.disk_labelled`): ``x`` is in the set when its
    label is, whatever its position. The members of all the sets are taken in order (as
    :func:`union`), a member is kept unless its label was kept before, and a member without
    a label (0: an estimate that no identified measurement formed,
    :mod:`phd_swarm.core.estimators.shirsat.labels`) is not a member at all. So a kept
    member is never replaced (its position stays the one first estimated) and the result
    depends only on the order of the inputs.

    Parameters
    ----------
    sets : sequence of (np.ndarray (K_i,) of int, np.ndarray (K_i, 2))
        Labels (>= 0) and positions [m] of each set, taken in the order given.

    Returns
    -------
    labels : np.ndarray of int64, shape (K,)
        The kept labels, all > 0 and distinct, in the order they were met.
    points : np.ndarray, shape (K, 2)
        Their positions [m] (a new array).

    Raises
    ------
    ValueError
        If a set is malformed (naming it): labels not integers >= 0, or not one per point.
    """
    labels, points = [], []
    for i, (lab, pts) in enumerate(sets):
        pts = as_points(pts, f"sets[{i}]")
        labels.append(as_labels(lab, len(pts), f"sets[{i}]"))
        points.append(pts)
    if not labels:
        return np.empty(0, dtype=np.int64), np.empty((0, 2))
    lab, pts = np.concatenate(labels), np.concatenate(points)
    _, first = np.unique(lab, return_index=True)
    keep = np.sort(first[lab[first] > 0])
    return lab[keep], pts[keep]


def extend_by_label(labels: np.ndarray, points: np.ndarray, new_labels: np.ndarray,
                    new_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``union_by_label([(labels, points), (new_labels, new_points)])`` for a reduced set.

    ``labels, points`` is a :func:`union_by_label` result (trusted); they are returned
    themselves (not copies) when nothing is added, which is most steps.
    """
    new_labels = as_labels(new_labels, len(new_points), "new set")
    if not np.any(new_labels[~np.isin(new_labels, labels)] > 0):
        return labels, points
    return union_by_label([(labels, points), (new_labels, new_points)])


def as_labels(labels: np.ndarray, n: int, where: str) -> np.ndarray:
    """``labels`` as int64 (n,), after checking they are integers >= 0, one per point.

    Raises
    ------
    ValueError
        Naming ``where``, if they are not.
    """
    lab = np.asarray(labels).reshape(-1)
    if lab.size == 0 and n == 0:
        return np.empty(0, dtype=np.int64)
    if lab.shape[0] != n or not np.issubdtype(lab.dtype, np.integer) or lab.min() < 0:
        raise ValueError(f"{where}: labels must be {n} integers >= 0 (one per point), got "
                         f"{lab!r}")
    return lab.astype(np.int64)
