"""The figures of Shirsat & Berman's evaluation, per step, from the robots' reward sets.

Sec. VI reports the cardinality of each robot's reward over time (Fig. 5b), the time
t_reward at which every robot's reward cardinality equals the true number of targets, and
the estimated positions (Figs. 6-8). Per step, over the robots given:

- ``reward_min``, ``reward_mean``, ``reward_max``: the cardinality |M_k| of the robots'
  reward sets (Fig. 5b);
- ``reward_ospa_mean``: the mean over the robots of OSPA(truth, M_k) (order p, cut-off c),
  how well the sets place the targets, which the cardinality alone does not say;
- ``all_found``: 1.0 if every robot's reward cardinality equals the true number of targets,
  else 0.0 (the paper's criterion: cardinality, not positions); t_reward is the first step
  at which it is 1;
- ``components_mean``: the mean number of GM-PHD components per robot;
- ``robots_meeting``: how many robots merged another robot's set at the step (are at a
  renewal epoch, eq. 5-6). Over a run of T steps and N robots, N T / sum_k
  robots_meeting is the mean inter-arrival time of a robot's renewals (Table 1).

With no robot (all dead) every figure is NaN but ``all_found``, 0.0.

The hook reads only ``reward_set()``, ``met`` and ``mixture.weights`` of each estimator,
which the robots' messages carry (:class:`phd_swarm.nodes.gm_convert.EstimatorView`), so the
monitor computes the same numbers from a run's messages as the in-memory engine from the
estimators.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..ospa import ospa

#: Names of the per-step figures, in order.
FIGURES = ("reward_min", "reward_mean", "reward_max", "reward_ospa_mean", "all_found",
           "components_mean", "robots_meeting")


def step_figures(estimators: list[Any], truth: np.ndarray, c: float,
                 p: float) -> dict[str, float]:
    """The figures of one step (see the module docstring), for any number of robots.

    Parameters
    ----------
    estimators : list
        The live robots' estimators, or views of them: each has ``reward_set()`` ((K, 2)
        [m]), ``met`` (the robots merged at the step) and ``mixture.weights`` ((J,)).
    truth : np.ndarray, shape (N, 2)
        True target positions at the step [m].
    c, p : float
        OSPA cut-off [m] and order.
    """
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    if not estimators:
        nan = float("nan")
        return {"reward_min": nan, "reward_mean": nan, "reward_max": nan,
                "reward_ospa_mean": nan, "all_found": 0.0, "components_mean": nan,
                "robots_meeting": 0.0}
    sets = [np.asarray(e.reward_set(), dtype=float).reshape(-1, 2) for e in estimators]
    counts = np.array([len(s) for s in sets], dtype=float)
    components = np.array([np.size(e.mixture.weights) for e in estimators], dtype=float)
    distances = np.array([ospa(truth, s, c, p) for s in sets])
    return {"reward_min": float(counts.min()), "reward_mean": float(counts.mean()),
            "reward_max": float(counts.max()),
            "reward_ospa_mean": float(distances.mean()),
            "all_found": float(np.all(counts == len(truth))),
            "components_mean": float(components.mean()),
            "robots_meeting": float(sum(np.size(e.met) > 0 for e in estimators))}
