"""Per-step figures of Papaioannou et al.'s system: searched area, agents and targets tracking.

The estimator part's ``figures`` hook (:mod:`phd_swarm.core.registry`): the sweep runner and
the monitor call it once per step with the live agents' estimators (or views of them) and
the true target positions; the in-memory engine also passes the true targets' ids and the
agents' controllers.

Scalars, one value per step:

- ``searched_area``: the fraction of the area the team has searched, the integral over A of
  the team's search density, i.e. the mean over the nodes of the largest search value any
  agent holds (eq. 10; Figs. 1, 2, 4 plot it in percent; it never reaches 1 because of the
  decay, as Sec. VI-B says);
- ``agents_tracking``: agents with at least one estimate (in tracking mode at the next step);
- ``targets_alive``, ``targets_tracked``: true targets, and those with an agent's estimate
  within :data:`TRACK_GATE` of them. Fig. 5's pooled "ratio of tracking time to target
  lifetime" of a run is ``sum(targets_tracked) / sum(targets_alive)`` over its steps (the
  lifetime-weighted mean of each target's ratio; docs/decisions.md);
- with the controllers: ``agents_looking``, agents whose move tracked tentative detections
  only (the look rule, ``look_tentative``); ``overlap_tests``, the tracking-overlap windows
  compared with Q_th (full, every step overlapping, both sets non-empty), summed over the
  agents, so a pair's window counts twice, once for each agent; ``overlaps_fired``, those
  within Q_th (again once per agent); ``overlap_best``, the smallest window sum of eq. 19's
  scores [m] (NaN if none; under ``overlap_threshold_form: mean`` the test compares this
  over the window's length with Q_th).

Per target, with the ids (:data:`ID_FIGURES`; one row per step, the live targets in id
order; the sweep runner pads the rows to one width with -1, :func:`phd_swarm.tools.
series_arrays.pad_rows`):

- ``target_ids``: the true targets' ids (int64);
- ``target_trackers``: for each, the bit mask of the agents with an estimate within
  :data:`TRACK_GATE` of it (bit r: agent r; 0: not tracked);
- ``target_in_view``: for each, the bit mask of the agents whose sensing square held it at
  the step's scan (the targets that could be detected, with p_D = 0.99).

So the alive ids at step k are ``target_ids[k][target_ids[k] >= 0]``, the tracked ones
those with ``target_trackers > 0``, and agent r tracked target i if
``target_trackers >> r & 1``. Agent ids must be < :data:`MAX_AGENTS`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.spatial.distance import cdist

#: Names of the per-step scalar figures, in order (the last four need the controllers).
FIGURES = ("searched_area", "agents_tracking", "targets_alive", "targets_tracked",
           "agents_looking", "overlap_tests", "overlaps_fired", "overlap_best")

#: Names of the per-target figures (one int64 per live target; they need the ids).
ID_FIGURES = ("target_ids", "target_trackers", "target_in_view")

#: A true target counts as tracked when an estimate lies within this distance [m]: three
#: range sds of the paper's sensor (zeta0 = 1 m) at the ranges a square of 10 m allows.
TRACK_GATE = 3.0

#: Agents a bit mask of int64 can name (ids 0 .. 62).
MAX_AGENTS = 63


def _agent_bits(estimators: Sequence[Any]) -> np.ndarray:
    ids = np.array([int(getattr(e, "robot_id", i)) for i, e in enumerate(estimators)],
                   dtype=np.int64)
    if np.any((ids < 0) | (ids >= MAX_AGENTS)):
        raise ValueError(f"target_trackers: agent ids must lie in [0, {MAX_AGENTS}), got "
                         f"{ids.tolist()}")
    return np.left_shift(np.int64(1), ids)


def _masks(hits: np.ndarray, bits: np.ndarray) -> np.ndarray:
    """Bit masks (N,) of the agents (columns of ``hits``, (N, R) bool) that hit each target."""
    return (hits * bits[None, :]).sum(axis=1, dtype=np.int64) if hits.size else \
        np.zeros(hits.shape[0], dtype=np.int64)


def step_figures(estimators: list[Any], truth: np.ndarray, c: float, p: float,
                 ids: np.ndarray | None = None,
                 controllers: Sequence[Any] | None = None) -> dict[str, Any]:
    """The figures of one step (see the module docstring).

    Parameters
    ----------
    estimators : list
        The live agents' estimators, or views of them: each has ``search`` ((S,), the
        search values, or None if not known) and ``estimates()`` ((K, 2) [m]); for the
        per-target figures also ``robot_id`` (else its index), and for ``target_in_view``
        ``sensor_position`` and ``setup.sensor``.
    truth : np.ndarray, shape (N, 2)
        True target positions [m].
    c, p : float
        OSPA cut-off and order (unused: the OSPA is the runner's).
    ids : np.ndarray of int, shape (N,), optional
        The true targets' ids; None: no per-target figures.
    controllers : sequence, optional
        The agents' controllers in the order of ``estimators`` (``mode`` and
        ``overlap_step`` of :class:`~phd_swarm.core.controllers.sat_search_track.
        SatSearchTrack`); None: no look or overlap figures.

    Returns
    -------
    dict
        Scalars (float) by name, and with ``ids`` the arrays of :data:`ID_FIGURES`, (N,).
    """
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    maps = [np.asarray(e.search, dtype=float) for e in estimators
            if getattr(e, "search", None) is not None]
    searched = float(np.max(maps, axis=0).mean()) if maps else float("nan")
    points = [np.asarray(e.estimates(), dtype=float).reshape(-1, 2) for e in estimators]
    tracking = sum(len(x) > 0 for x in points)
    # near[i, r]: agent r has an estimate within the gate of target i.
    near = np.array([(cdist(truth, x) <= TRACK_GATE).any(axis=1) if len(x) and len(truth)
                     else np.zeros(len(truth), dtype=bool) for x in points],
                    dtype=bool).reshape(len(points), len(truth)).T
    out: dict[str, Any] = {"searched_area": searched, "agents_tracking": float(tracking),
                           "targets_alive": float(len(truth)),
                           "targets_tracked": float(near.any(axis=1).sum())}
    if controllers is not None:
        steps = [getattr(ctl, "overlap_step", None) for ctl in controllers]
        steps = [s for s in steps if s is not None]
        best = min((s.best for s in steps), default=float("inf"))
        out.update({
            "agents_looking": float(sum(getattr(ctl, "mode", "") == "look"
                                        for ctl in controllers)),
            "overlap_tests": float(sum(s.tested for s in steps)),
            "overlaps_fired": float(sum(s.fired for s in steps)),
            "overlap_best": best if np.isfinite(best) else float("nan")})
    if ids is not None:
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        if ids.shape != (len(truth),):
            raise ValueError(f"ids must have shape ({len(truth)},) like truth, got {ids.shape}")
        bits = _agent_bits(estimators)
        seen = np.zeros((len(truth), len(estimators)), dtype=bool)
        for r, e in enumerate(estimators):
            where = getattr(e, "sensor_position", None)
            if where is not None and len(truth):
                seen[:, r] = e.setup.sensor.inside(truth, where)
        out.update({"target_ids": ids.copy(), "target_trackers": _masks(near, bits),
                    "target_in_view": _masks(seen, bits)})
    return out
