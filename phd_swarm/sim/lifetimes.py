"""Targets' in-area lifetimes: the steps each target is in the truth during a run.

Papaioannou et al. normalise the tracking time by "the actual lifetime of the targets (i.e.,
the ground-truth length of time for which a target evolves inside the surveillance area)"
(Sec. VI-B, Fig. 5a). This is that length, counted in the run: the steps at which a target
is in the world's truth set (it leaves the set when it dies, leaves the area or the run
ends). Two sources:

- :func:`alive_steps`, from a trial's ``target_ids`` series (the per-target figures of
  :mod:`phd_swarm.core.estimators.papaioannou.figures`), so each trial reports its own;
- :func:`in_area_lifetimes`, from the simulator alone (:class:`~phd_swarm.sim.world.World`
  over the scenario's steps, no robots moving), to measure a lifetime model over many
  seeds.
"""

from __future__ import annotations

import numpy as np

from phd_swarm.sim.scenario import Scenario
from phd_swarm.sim.world import World

__all__ = ["alive_steps", "in_area_lifetimes"]


def alive_steps(target_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ids seen in a per-step id table and the steps each was seen.

    Parameters
    ----------
    target_ids : np.ndarray of int, shape (steps, W)
        Row k: the ids of the targets in the truth at step k, padded with -1.

    Returns
    -------
    ids : np.ndarray of int64, shape (T,)
        The distinct ids, ascending.
    steps : np.ndarray of int64, shape (T,)
        How many rows hold each.
    """
    table = np.asarray(target_ids)
    if table.ndim != 2 or not np.issubdtype(table.dtype, np.integer):
        raise ValueError(f"target_ids must be an integer array (steps, W), got "
                         f"{table.dtype} {table.shape}")
    ids, steps = np.unique(table[table >= 0], return_counts=True)
    return ids.astype(np.int64), steps.astype(np.int64)


def in_area_lifetimes(scenario: Scenario) -> np.ndarray:
    """Steps each target of ``scenario``'s world is in the truth during its run, (T,).

    The world of the scenario's seed (targets from its own stream, as in a trial), stepped
    ``scenario.steps`` times; a target never in the truth during the run is not counted.
    Multiply by ``scenario.dt`` for seconds.
    """
    world = World(scenario)
    seen: dict[int, int] = {}
    for _ in range(scenario.steps):
        for i in world.truth()[0].tolist():
            seen[i] = seen.get(i, 0) + 1
        world.advance()
    return np.array([seen[i] for i in sorted(seen)], dtype=np.int64)
