"""The figures of Shirsat & Berman's evaluation, per step, from the robots' reward sets.

Sec. VI reports the cardinality of each robot's reward over time (Fig. 5b), the time
t_reward at which every robot's reward cardinality equals the true number of targets, and
the estimated positions (Figs. 6-8). Per step, over the robots given:

- ``reward_min``, ``reward_mean``, ``reward_max``: the cardinality |M_k| of the robots'
  reward sets (Fig. 5b);
- ``reward_ospa_mean``: the mean over the robots of OSPA(truth, M_k) (order p, cut-off c),
  how well the sets place the targets, which the cardinality alone does not say;
- ``reward_true_mean``: the mean over the robots of the number of members of M_k that
  match a true target (:func:`true_members`: by label for a labelled member, else by
  position within c), the numerator of Table 1's reward % counting found targets only;
- ``all_found``: 1.0 if every robot's reward cardinality equals the true number of targets,
  else 0.0 (the paper's criterion: cardinality, not positions); t_reward is the first step
  at which it is 1;
- ``components_mean``: the mean number of GM-PHD components per robot;
- ``robots_meeting``: how many robots merged another robot's set at the step (are at a
  renewal epoch, eq. 5-6). Over a run of T steps and N robots, N T / sum_k
  robots_meeting is the mean inter-arrival time of a robot's renewals (Table 1).

With no robot (all dead) every figure is NaN but ``all_found``, 0.0.

The hook reads only ``reward_set()``, ``reward_labels()`` (if it has one), ``met`` and
``mixture.weights`` of each estimator, which the robots' messages carry
(:class:`phd_swarm.nodes.faces.gaussian_mixture.EstimatorView`), so the monitor
computes the same numbers from a run's messages as the in-memory engine from the
estimators.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from ...ospa import ospa
from ...sensors.disk_labelled import tags

#: Names of the per-step figures, in order.
FIGURES = ("reward_min", "reward_mean", "reward_max", "reward_ospa_mean", "reward_true_mean",
           "all_found", "components_mean", "robots_meeting")


def true_members(points: np.ndarray, labels: np.ndarray, truth: np.ndarray,
                 truth_ids: np.ndarray | None, gate: float) -> float:
    """How many members of a reward set match a true target, each target matched once.

    A member with a label (> 0, the labelled reading) matches the target whose tag it is
    (:func:`phd_swarm.core.sensors.disk_labelled.tags` of ``truth_ids``), if that target
    is there at the step; the labels in a set are distinct, so no target is counted twice.
    A member without one (the union by position) matches a target within ``gate`` [m] of
    it (Euclidean, boundary included), one member per target and one target per member,
    as many pairs as can be made (a maximum matching, :func:`linear_sum_assignment` on
    0/1 costs): two members near one target count once, the second being the duplicate
    the union by position was meant to avoid.

    Parameters
    ----------
    points : np.ndarray, shape (K, 2)
        The members' positions [m].
    labels : np.ndarray of int, shape (K,)
        Their labels, 0 for none.
    truth : np.ndarray, shape (N, 2)
        True target positions [m].
    truth_ids : np.ndarray of int, shape (N,), or None
        The targets' ids; None if not known, when labelled members give NaN.
    gate : float
        The matching distance for members without a label [m].
    """
    labelled = labels > 0
    count = 0.0
    if labelled.any():
        if truth_ids is None:
            return float("nan")
        count += float(np.isin(labels[labelled], tags(truth_ids)).sum())
    rest = points[~labelled]
    if len(rest) and len(truth):
        d = np.hypot(rest[:, None, 0] - truth[None, :, 0], rest[:, None, 1] - truth[None, :, 1])
        cost = (d > gate).astype(float)
        rows, cols = linear_sum_assignment(cost)
        count += float(np.count_nonzero(cost[rows, cols] == 0.0))
    return count


def step_figures(estimators: list[Any], truth: np.ndarray, c: float,
                 p: float, ids: np.ndarray | None = None) -> dict[str, float]:
    """The figures of one step (see the module docstring), for any number of robots.

    Parameters
    ----------
    estimators : list
        The live robots' estimators, or views of them: each has ``reward_set()`` ((K, 2)
        [m]), ``met`` (the robots merged at the step) and ``mixture.weights`` ((J,)), and
        may have ``reward_labels()`` ((K,), 0 for none).
    truth : np.ndarray, shape (N, 2)
        True target positions at the step [m].
    c, p : float
        OSPA cut-off [m] and order; c is also the matching gate of ``reward_true_mean``
        (Shirsat & Berman's preset: 1.5 m, the reward sets' duplicate distance).
    ids : np.ndarray of int, shape (N,), optional
        The true targets' ids, which matching a labelled member needs (NaN without); the
        in-memory engine passes them.
    """
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    if not estimators:
        nan = float("nan")
        return {"reward_min": nan, "reward_mean": nan, "reward_max": nan,
                "reward_ospa_mean": nan, "reward_true_mean": nan, "all_found": 0.0,
                "components_mean": nan, "robots_meeting": 0.0}
    sets = [np.asarray(e.reward_set(), dtype=float).reshape(-1, 2) for e in estimators]
    labels = [np.asarray(e.reward_labels(), dtype=np.int64).reshape(-1)
              if hasattr(e, "reward_labels") else np.zeros(len(s), dtype=np.int64)
              for e, s in zip(estimators, sets, strict=True)]
    true = [true_members(s, lab, truth, ids, c)
            for s, lab in zip(sets, labels, strict=True)]
    counts = np.array([len(s) for s in sets], dtype=float)
    components = np.array([np.size(e.mixture.weights) for e in estimators], dtype=float)
    distances = np.array([ospa(truth, s, c, p) for s in sets])
    return {"reward_min": float(counts.min()), "reward_mean": float(counts.mean()),
            "reward_max": float(counts.max()),
            "reward_ospa_mean": float(distances.mean()),
            "reward_true_mean": float(np.mean(true)),
            "all_found": float(np.all(counts == len(truth))),
            "components_mean": float(components.mean()),
            "robots_meeting": float(sum(np.size(e.met) > 0 for e in estimators))}
