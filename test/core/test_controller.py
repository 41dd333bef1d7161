"""Controllers: Lloyd weights per kind and the next power weight (Chen eq. 13-14)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.controller import ControllerConfig, decide
from phd_swarm.core.grid import Environment, Grid

GRID = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
CELL = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
BINS = np.array([iy * 10 + ix for iy in range(4) for ix in range(4)])


def test_uniform_goes_to_the_centroid_and_phd_to_the_mass():
    phd = np.zeros(16)
    phd[15] = 1.0  # bin (3, 3): centre (3.5, 3.5)
    u = decide(ControllerConfig("uniform"), GRID, np.zeros(2), CELL, BINS, phd, False)
    assert np.allclose(u.goal, [2.0, 2.0]) and u.power_weight == 0.0
    d = decide(ControllerConfig("phd"), GRID, np.zeros(2), CELL, BINS, phd, False)
    assert np.allclose(d.goal, [3.5, 3.5]) and d.power_weight == 0.0


def test_chen_p_power_weight_is_the_phd_mass_to_the_minus_half():
    phd = np.full(16, 0.25)  # 4 expected targets in the cell
    d = decide(ControllerConfig("chen_p", rho_max=5.0), GRID, np.zeros(2), CELL, BINS, phd,
               True)
    assert d.power_weight == pytest.approx(0.5)


def test_chen_o_idle_robot_follows_wc_busy_robot_follows_phd():
    phd = np.zeros(16)
    phd[0] = 1.0  # bin (0, 0)
    alpha = np.zeros(16)
    count = np.full(16, 4.0)
    alpha[15] = 3.0  # rate (3 - 1) / 4 = 0.5 in bin (3, 3)
    cfg = ControllerConfig("chen_o", rho_max=5.0)
    idle = decide(cfg, GRID, np.zeros(2), CELL, BINS, phd, False, alpha, count)
    busy = decide(cfg, GRID, np.zeros(2), CELL, BINS, phd, True, alpha, count)
    assert np.allclose(idle.goal, [3.5, 3.5])
    assert np.allclose(busy.goal, [0.5, 0.5])
    assert idle.power_weight == pytest.approx(0.5 ** -0.5)  # cell mass 0.5 x 1 m^2


def test_zero_cumulative_mass_caps_rho_and_bad_kinds_fail():
    cfg = ControllerConfig("chen_o", rho_max=5.0)
    d = decide(cfg, GRID, np.zeros(2), CELL, BINS, np.zeros(16), False, np.zeros(16),
               np.zeros(16))
    assert d.power_weight == 5.0
    with pytest.raises(ValueError, match="cumulative"):
        decide(cfg, GRID, np.zeros(2), CELL, BINS, np.zeros(16), False)
    with pytest.raises(ValueError, match="kind"):
        ControllerConfig("voronoi")
