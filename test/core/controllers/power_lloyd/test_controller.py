"""Power-diagram Lloyd controllers of Chen et al. (2021): ``chen_p`` and ``chen_o``."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.controllers.base import CellDensity, Knowledge
from phd_swarm.core.controllers.power_lloyd.controller import (
    PowerLloydConfig,
    PowerLloydO,
    PowerLloydP,
    power_weight_guard,
    setup,
    switching_figures,
)
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim import presets as sc

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
    assert cfg == PowerLloydConfig(2.5, "laplace", "fixed", 1.0, 5.0)
    with pytest.raises(ValueError, match="cumulative_mode"):
        SystemConfig(controller="chen_o", options=(("cumulative_mode", "bogus"),))
    with pytest.raises(ValueError, match="rho_max"):
        SystemConfig(controller="chen_p", options=(("rho_max", -1.0),))


def test_rho_cap_nearest_robot_leaves_the_weight_uncapped_for_the_partition_to_guard():
    s = sc.chen_clustered(robots=5, resolution=1.0)
    guarded = setup(s, SystemConfig(controller="chen_p",
                                    options=(("rho_cap", "nearest_robot"),)))
    # No fixed cap: the map's diagonal, farther than any two robots in E can be apart.
    assert guarded == PowerLloydConfig(float(np.hypot(100.0, 100.0)), "rate",
                                       "nearest_robot", 1.0, 5.0)
    # 1e-4 expected targets: rho = 100 m, uncapped (the fixed cap would give 5 m).
    d = PowerLloydP(guarded).decide(knowledge(np.full(16, 1e-4 / 16), ONE), RNG)
    assert d.power_weight == pytest.approx(100.0)
    d = PowerLloydP(guarded).decide(knowledge(np.zeros(16), ONE), RNG)
    assert d.power_weight == guarded.rho_max
    both = setup(s, SystemConfig(controller="chen_o", options=(
        ("rho_cap", "nearest_robot"), ("rho_max", 10.0))))
    assert both.rho_max == 10.0
    guard = power_weight_guard(guarded)
    assert guard.option == "rho_cap: nearest_robot"
    q = np.array([[40.0, 50.0], [50.0, 50.0], [60.0, 50.0]])
    np.testing.assert_allclose(guard.bound(q, np.array([30.0, 0.5, 30.0])),
                               [np.sqrt(80.0), 0.5, np.sqrt(80.0)])  # margin: the 1 m bin
    assert power_weight_guard(setup(s, SystemConfig(controller="chen_p"))) is None
    with pytest.raises(ValueError, match="rho_cap"):
        SystemConfig(controller="chen_p", options=(("rho_cap", "none"),))


def test_the_default_cap_is_the_old_one():
    s = sc.chen_clustered(robots=5, resolution=1.0)
    cfg = setup(s, SystemConfig(controller="chen_o"))
    assert (cfg.rho_max, cfg.rho_cap, cfg.cumulative_mode) == (5.0, "fixed", "rate")
    explicit = setup(s, SystemConfig(controller="chen_o", options=(("rho_cap", "fixed"),)))
    assert explicit == cfg


def test_chen_o_counts_a_busy_robot_that_turns_idle_with_a_target_in_view():
    cfg = PowerLloydConfig(rho_max=5.0, sensing_radius=5.0)
    alpha, count = np.zeros(16), np.zeros(16)
    robots = [PowerLloydO(cfg) for _ in range(3)]
    seen = [ONE, ONE, NONE]
    for c, z in zip(robots, seen, strict=True):
        c.decide(knowledge(np.zeros(16), z, alpha, count), RNG)
    f = switching_figures(robots, np.array([[3.0, 4.0]]))
    assert f == {"busy_robots": 2.0, "turned_idle": 0.0, "turned_idle_in_view": 0.0}

    def step(k, z, position):
        return Knowledge(0, k, np.asarray(position, float), z,
                         CellDensity(GRID, CELL, BINS, np.zeros(16), alpha, count))

    # Step 4: robots 0 and 1 see nothing; robot 2 (idle before) sees something.
    robots[0].decide(step(4, NONE, [0.0, 0.0]), RNG)
    robots[1].decide(step(4, NONE, [20.0, 0.0]), RNG)
    robots[2].decide(step(4, ONE, [0.0, 0.0]), RNG)
    truth = np.array([[3.0, 4.0]])  # 5 m from robot 0: on the disk's edge, in view
    f = switching_figures(robots, truth)
    assert f == {"busy_robots": 1.0, "turned_idle": 2.0, "turned_idle_in_view": 1.0}
    assert robots[0].turned_idle and robots[1].turned_idle and not robots[2].turned_idle
    # A robot that did not decide at the latest step (dead) is not counted.
    robots[2].decide(step(5, NONE, [0.0, 0.0]), RNG)
    assert switching_figures(robots, truth) == {"busy_robots": 0.0, "turned_idle": 1.0,
                                                "turned_idle_in_view": 1.0}
    assert switching_figures(robots, np.empty((0, 2)))["turned_idle_in_view"] == 0.0
