"""Per-step figures of Papaioannou et al.'s system: searched area, agents and targets tracking.

The estimator part's ``figures`` hook (:mod:`phd_swarm.core.registry`): the sweep runner and
the monitor call it once per step with the live agents' estimators (or views of them) and
the true target positions.

- ``searched_area``: the fraction of the area the team has searched, the integral over A of
  the team's search density, i.e. the mean over the nodes of the largest search value any
  agent holds (eq. 10; Figs. 1, 2, 4 plot it in percent; it never reaches 1 because of the
  decay, as Sec. VI-B says);
- ``agents_tracking``: agents with at least one estimate (in tracking mode at the next step);
- ``targets_alive``, ``targets_tracked``: true targets, and those with an agent's estimate
  within :data:`TRACK_GATE` of them. Fig. 5's "ratio of tracking time to target lifetime"
  of a run is ``sum(targets_tracked) / sum(targets_alive)`` over its steps (the
  lifetime-weighted mean of each target's ratio; docs/decisions.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.distance import cdist

#: Names of the per-step figures, in order.
FIGURES = ("searched_area", "agents_tracking", "targets_alive", "targets_tracked")

#: A true target counts as tracked when an estimate lies within this distance [m]: three
#: range sds of the paper's sensor (zeta0 = 1 m) at the ranges a square of 10 m allows.
TRACK_GATE = 3.0


def step_figures(estimators: list[Any], truth: np.ndarray, c: float,
                 p: float) -> dict[str, float]:
    """The figures of one step (see the module docstring).

    Parameters
    ----------
    estimators : list
        The live agents' estimators, or views of them: each has ``search`` ((S,), the
        search values, or None if not known) and ``estimates()`` ((K, 2) [m]).
    truth : np.ndarray, shape (N, 2)
        True target positions [m].
    c, p : float
        OSPA cut-off and order (unused: the OSPA is the runner's).
    """
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    maps = [np.asarray(e.search, dtype=float) for e in estimators
            if getattr(e, "search", None) is not None]
    searched = float(np.max(maps, axis=0).mean()) if maps else float("nan")
    points = [np.asarray(e.estimates(), dtype=float).reshape(-1, 2) for e in estimators]
    tracking = sum(len(x) > 0 for x in points)
    found = np.concatenate(points) if points else np.empty((0, 2))
    tracked = (int((cdist(truth, found) <= TRACK_GATE).any(axis=1).sum())
               if len(truth) and len(found) else 0)
    return {"searched_area": searched, "agents_tracking": float(tracking),
            "targets_alive": float(len(truth)), "targets_tracked": float(tracked)}
