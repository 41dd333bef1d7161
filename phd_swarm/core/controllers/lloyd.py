"""Lloyd controllers on Voronoi cells: ``phd`` (Dames 2020) and ``uniform`` (coverage).

Each robot heads for the weighted centroid of its cell (Dames eq. 8), the integral being the
sum over the bins it owns (:func:`phd_swarm.core.geometry.centroids.centroid_goal`):

- ``phd``: phi = the PHD bin masses (Dames eq. 8; the "D" method of Chen et al.);
- ``uniform``: phi = 1, the coverage baseline of Dames Sec. IV (Cortes et al.).

Cells are Voronoi cells, so the power weight is always 0.
"""

from __future__ import annotations

import numpy as np

from .. import registry
from ..geometry.centroids import centroid_goal
from .base import Controller, Decision, Knowledge

#: What the Lloyd controllers need: a grid density over the robot's own cell.
REQUIRES = ("grid_density", "cell")


class LloydController(Controller):
    """Weighted-centroid goal on a Voronoi cell (Dames eq. 8).

    Parameters
    ----------
    uniform : bool
        phi = 1 (coverage) instead of the PHD.
    """

    def __init__(self, uniform: bool = False) -> None:
        self.uniform = uniform

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Goal: the centroid of the own bins weighted by phi; power weight 0."""
        c = knowledge.local
        phi = np.ones(c.bins.size) if self.uniform else c.phd
        goal = centroid_goal(c.grid, c.bins, phi, c.cell, knowledge.position)
        return Decision(goal=np.asarray(goal, dtype=float), power_weight=0.0)


registry.register(
    "controller", "phd", lambda setup, rid: LloydController(uniform=False),
    description="Lloyd on Voronoi cells weighted by the PHD (Dames 2020 eq. 8).",
    requires=REQUIRES)
registry.register(
    "controller", "uniform", lambda setup, rid: LloydController(uniform=True),
    description="Lloyd on Voronoi cells with phi = 1, the coverage baseline (Dames Sec. IV).",
    requires=REQUIRES)
