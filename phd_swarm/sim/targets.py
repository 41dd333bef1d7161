"""The ground truth of a run: every built-in target kind, and the initial population.

A scenario's ``targets.kind`` names a kind registered in :mod:`phd_swarm.sim.target_kinds`
by the module that implements it; this module imports those modules, so that every
built-in kind is registered once it is imported, and draws a scenario's targets by looking
the kind up (:func:`make_targets`):

- ``static`` (Dames 2020 Sec. IV-A) and ``dames_walk`` (Sec. IV-B):
  :mod:`phd_swarm.sim.dames_targets`;
- ``clustered_walk`` (Chen, Dames & Park 2021 Sec. 4) and ``turning_walk`` (Sung & Tokekar
  2022 Sec. VI-A.4): :mod:`phd_swarm.sim.walkers`;
- ``ncv`` (Papaioannou et al. Sec. VI): :mod:`phd_swarm.sim.ncv_paths` (with
  :mod:`phd_swarm.sim.ncv_targets`).

Every population exposes ``positions`` ((N, 2) [m]), ``ids`` ((N,) int64; an id is never
reused, not even after its target has left) and ``step(rng, dt)``
(:class:`~phd_swarm.sim.target_kinds.TargetPopulation`). All randomness comes from the
Generator passed in, consumed in the order each model documents, so a run is reproducible
bit for bit from its seed.
"""

from __future__ import annotations

import numpy as np

# The kinds' modules register their kinds when imported.
from phd_swarm.sim import dames_targets, ncv_paths, walkers  # noqa: F401
from phd_swarm.sim.target_kinds import TargetPopulation, TargetSetting, lookup, names

__all__ = ["TARGET_KINDS", "Targets", "make_targets"]

#: A true target population, whatever its kind.
Targets = TargetPopulation

#: The built-in target kinds' names, sorted (:func:`phd_swarm.sim.target_kinds.names`).
TARGET_KINDS = names()


def make_targets(rng: np.random.Generator, scenario: TargetSetting) -> Targets:
    """Initial target population of ``scenario`` (its ``targets`` config), drawn from ``rng``.

    The kind ``scenario.targets.kind`` draws it from the config fields it reads
    (:meth:`~phd_swarm.sim.target_kinds.TargetKind.populate`); the world passes its target
    stream (:class:`~phd_swarm.sim.world.World`).
    """
    return lookup(scenario.targets.kind).populate(rng, scenario)
