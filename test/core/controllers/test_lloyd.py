"""Lloyd controllers on Voronoi cells (Dames eq. 8): ``phd`` and ``uniform``."""

from __future__ import annotations

import numpy as np

from phd_swarm.core.controllers.base import CellDensity, Knowledge
from phd_swarm.core.controllers.lloyd import LloydController
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.registry import lookup

GRID = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
CELL = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
BINS = np.array([iy * 10 + ix for iy in range(4) for ix in range(4)])
RNG = np.random.default_rng(0)
NONE = np.empty((0, 2))


def knowledge(phd, z=NONE, cell=CELL, bins=BINS):
    return Knowledge(0, 3, np.zeros(2), z, CellDensity(GRID, cell, bins, phd))


def test_uniform_goes_to_the_centroid_and_phd_to_the_mass():
    phd = np.zeros(16)
    phd[15] = 1.0  # bin (3, 3): centre (3.5, 3.5)
    u = LloydController(uniform=True).decide(knowledge(phd), RNG)
    assert np.allclose(u.goal, [2.0, 2.0]) and u.power_weight == 0.0
    d = LloydController().decide(knowledge(phd), RNG)
    assert np.allclose(d.goal, [3.5, 3.5]) and d.power_weight == 0.0


def test_zero_weights_fall_back_to_the_cell_centroid_computed_only_then():
    calls = []

    def cell():
        calls.append(1)
        return CELL

    d = LloydController().decide(knowledge(np.zeros(16), cell=cell), RNG)
    assert np.allclose(d.goal, [2.0, 2.0]) and calls == [1]
    phd = np.ones(16)
    LloydController().decide(knowledge(phd, cell=cell), RNG)
    assert calls == [1], "the polygon is not needed when some weight is positive"


def test_registered_names_make_these_controllers():
    for name, uniform in (("phd", False), ("uniform", True)):
        part = lookup("controller", name)
        c = part.make(None, 0)
        assert isinstance(c, LloydController) and c.uniform is uniform
        assert part.requires == {"grid_density", "cell"}
