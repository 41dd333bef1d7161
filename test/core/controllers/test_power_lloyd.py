"""Power-diagram Lloyd controllers of Chen et al. (2021): ``chen_p`` and ``chen_o``."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.controllers.base import CellDensity, Knowledge
from phd_swarm.core.controllers.power_lloyd import (
    PowerLloydConfig,
    PowerLloydO,
    PowerLloydP,
    setup,
)
from phd_swarm.core.grid import Environment, Grid
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim import scenario as sc

GRID = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
CELL = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
BINS = np.array([iy * 10 + ix for iy in range(4) for ix in range(4)])
RNG = np.random.default_rng(0)
ONE = np.array([[1.0, 1.0]])
NONE = np.empty((0, 2))


def knowledge(phd, z=NONE, alpha=None, count=None):
    return Knowledge(0, 3, np.zeros(2), z, CellDensity(GRID, CELL, BINS, phd, alpha, count))


def test_chen_p_power_weight_is_the_phd_mass_to_the_minus_half():
    phd = np.full(16, 0.25)  # 4 expected targets in the cell
    d = PowerLloydP(PowerLloydConfig(rho_max=5.0)).decide(knowledge(phd, ONE), RNG)
    assert d.power_weight == pytest.approx(0.5)


def test_chen_o_idle_robot_follows_wc_busy_robot_follows_phd():
    phd = np.zeros(16)
    phd[0] = 1.0  # bin (0, 0)
    alpha = np.zeros(16)
    count = np.full(16, 4.0)
    alpha[15] = 3.0  # rate (3 - 1) / 4 = 0.5 in bin (3, 3)
    c = PowerLloydO(PowerLloydConfig(rho_max=5.0))
    idle = c.decide(knowledge(phd, NONE, alpha, count), RNG)
    busy = c.decide(knowledge(phd, ONE, alpha, count), RNG)
    assert np.allclose(idle.goal, [3.5, 3.5])
    assert np.allclose(busy.goal, [0.5, 0.5])
    assert idle.power_weight == pytest.approx(0.5 ** -0.5)  # cell mass 0.5 x 1 m^2


def test_zero_cumulative_mass_caps_rho_and_a_missing_layer_fails():
    c = PowerLloydO(PowerLloydConfig(rho_max=5.0))
    d = c.decide(knowledge(np.zeros(16), NONE, np.zeros(16), np.zeros(16)), RNG)
    assert d.power_weight == 5.0
    with pytest.raises(ValueError, match="cumulative"):
        c.decide(knowledge(np.zeros(16)), RNG)


def test_rho_max_zero_is_the_sensing_radius_and_options_are_checked():
    s = sc.chen_clustered(robots=5, resolution=1.0)
    assert setup(s, SystemConfig(controller="chen_o")).rho_max == s.models.detection.radius
    cfg = setup(s, SystemConfig(controller="chen_o",
                                options=(("rho_max", 2.5), ("cumulative_mode", "laplace"))))
    assert cfg == PowerLloydConfig(2.5, "laplace")
    with pytest.raises(ValueError, match="cumulative_mode"):
        SystemConfig(controller="chen_o", options=(("cumulative_mode", "bogus"),))
    with pytest.raises(ValueError, match="rho_max"):
        SystemConfig(controller="chen_p", options=(("rho_max", -1.0),))
