"""Sung & Tokekar's planners: ``lawnmower``, ``nearest_gaussian``, ``largest_gaussian``."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial import cKDTree

from phd_swarm.core import registry
from phd_swarm.core.controllers.base import Controller, Decision, Knowledge
from phd_swarm.core.controllers.sung_planners import (
    LargestGaussian,
    LawnMower,
    NearestGaussian,
    covariance_size,
    setup,
)
from phd_swarm.core.estimators.gm_phd.filter import GaussianMixture
from phd_swarm.core.geometry.centroids import next_position
from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.system import SystemConfig

RNG = np.random.default_rng(0)
SIDE = 150.0  # [m], Sung Fig. 6
D_STEP = 0.5  # 0.5 m/s x 1 s
FOV = 25.0  # [m]
PAPER_STEPS = 7278  # three sweeps, Sung Fig. 6 caption
# Derived: 17.68 m to the first lane, 7 lanes of 125 m, 6 turns of 20.83 m, 194.45 m back.
SWEEP_STEPS = 2427
START = np.zeros(2)  # the map's corner, as in the sung_tokekar preset
CORNER = np.array([12.5, 12.5])  # first lane start: the default inset


def scenario_stub():
    return SimpleNamespace(
        env=Environment(0.0, 0.0, SIDE, SIDE), dt=1.0, robot_max_speed=D_STEP,
        robot_start_box=(0.0, 0.0, 1e-6, 1e-6),
        models=SimpleNamespace(detection=SimpleNamespace(radius=FOV)))


def config(**options):
    return setup(scenario_stub(), SimpleNamespace(options=tuple(options.items())))


def knowledge(position, mixture=None):
    return Knowledge(0, 0, np.asarray(position, dtype=float), np.empty((0, 2)),
                     estimator=SimpleNamespace(mixture=mixture))


def simulate(controller, start, steps):
    """Positions q^0..q^steps under the world's rule (Chen eq. 3, clipped into the map)."""
    q = np.asarray(start, dtype=float)
    out = [q]
    for _ in range(steps):
        goal = controller.decide(knowledge(q), RNG).goal
        q = np.clip(next_position(q, goal, D_STEP), 0.0, SIDE)
        out.append(q)
    return np.array(out)


def returns_home(positions):
    home = positions[0]
    return [k for k in range(1, len(positions))
            if np.hypot(*(positions[k] - home)) <= 1e-9]


def mixture(weights, means, covs=None):
    j = len(weights)
    covs = np.tile(np.eye(2), (j, 1, 1)) if covs is None else covs
    return GaussianMixture(np.asarray(weights, float), np.asarray(means, float).reshape(j, 2),
                           np.asarray(covs, float).reshape(j, 2, 2))


def test_default_lawnmower_takes_the_derived_steps_and_returns_home_each_sweep():
    cfg = config()
    assert cfg.lanes.shape == (14, 2)  # 7 lanes
    assert np.allclose(cfg.lanes[0], CORNER) and np.allclose(cfg.lanes[-1], SIDE - CORNER)
    positions = simulate(LawnMower(cfg), START, 3 * SWEEP_STEPS + 20)
    assert returns_home(positions)[:3] == [SWEEP_STEPS, 2 * SWEEP_STEPS, 3 * SWEEP_STEPS]
    assert 3 * SWEEP_STEPS == 7281
    assert abs(3 * SWEEP_STEPS - PAPER_STEPS) / PAPER_STEPS < 1e-3  # 3 steps, 1.5 m
    # Repeats for ever by default: a fourth sweep has begun.
    assert np.hypot(*positions[-1]) == pytest.approx(20 * D_STEP)


def test_every_point_of_the_map_is_within_the_fov_of_one_sweep():
    positions = simulate(LawnMower(config()), START, SWEEP_STEPS)
    g = np.arange(0.0, SIDE + 0.5, 1.0)
    grid = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    # Samples 0.5 m apart: a point within 25 m of a sample is within 25 m of the path.
    gap, _ = cKDTree(positions).query(grid)
    assert gap.max() <= FOV
    assert gap.max() == pytest.approx(np.hypot(*CORNER), abs=1.0)  # the other corners


def test_a_wide_spacing_leaves_gaps():
    cfg = config(lawnmower_spacing=75.0)
    positions = simulate(LawnMower(cfg), cfg.lanes[0], 1200)
    g = np.arange(0.0, SIDE + 0.5, 1.0)
    gap, _ = cKDTree(positions).query(np.stack(np.meshgrid(g, g), -1).reshape(-1, 2))
    assert gap.max() > FOV


def test_finite_sweeps_end_at_the_start_and_the_path_begins_at_the_nearest_corner():
    start = np.array([140.0, 146.0])
    c = LawnMower(config(lawnmower_sweeps=2))
    first = c.decide(knowledge(start), RNG).goal
    assert np.allclose(first, SIDE - CORNER)
    positions = simulate(LawnMower(config(lawnmower_sweeps=2)), start, 6000)
    back = returns_home(positions)
    # Each sweep ends at the robot's own start, not the path's corner: 18 steps to
    # (137.5, 137.5), 7 x 250 on the lanes, 6 x 42 between them, 370 back from (12.5, 12.5).
    assert back[:2] == [2390, 4780]
    assert np.allclose(positions[back[1]:], start)  # stays after the second sweep


def test_lanes_along_x_spread_evenly_within_the_inset():
    cfg = config(lawnmower_axis="x", lawnmower_spacing=40.0, lawnmower_inset=15.0)
    assert cfg.lanes.shape == (8, 2)  # 120 m / 40 m: 4 lanes
    assert np.allclose(cfg.lanes[:2], [[15.0, 15.0], [135.0, 15.0]])
    assert np.allclose(np.unique(cfg.lanes[:, 1]), [15.0, 55.0, 95.0, 135.0])
    cfg = config(lawnmower_spacing=50.0)  # 125 m / 50 m: 3 gaps of 41.67 m
    assert np.allclose(np.unique(cfg.lanes[:, 0]), [12.5, 54.1667, 95.8333, 137.5])
    assert np.allclose(config(lawnmower_inset=100.0).lanes, [[75.0, 75.0], [75.0, 75.0]])


def test_nearest_gaussian_picks_the_nearest_mean():
    c = NearestGaussian(config())
    mix = mixture([1.0, 0.1, 1.0], [[10.0, 0.0], [3.0, 4.0], [-6.0, 0.0]])
    d = c.decide(knowledge([0.0, 0.0], mix), RNG)
    assert np.allclose(d.goal, [3.0, 4.0]) and d.power_weight == 0.0


def test_nearest_gaussian_min_weight_filters_light_components():
    c = NearestGaussian(config(min_weight=0.5))
    mix = mixture([1.0, 0.1, 1.0], [[10.0, 0.0], [3.0, 4.0], [-6.0, 0.0]])
    assert np.allclose(c.decide(knowledge([0.0, 0.0], mix), RNG).goal, [-6.0, 0.0])


def test_nearest_gaussian_stays_on_a_component_at_its_position():
    mix = mixture([0.01, 1.0], [[5.0, 5.0], [50.0, 5.0]])
    literal = NearestGaussian(config()).decide(knowledge([5.0, 5.0], mix), RNG)
    assert np.allclose(literal.goal, [5.0, 5.0])
    moves_on = NearestGaussian(config(min_weight=0.1)).decide(knowledge([5.0, 5.0], mix), RNG)
    assert np.allclose(moves_on.goal, [50.0, 5.0])


@pytest.mark.parametrize("cls", [NearestGaussian, LargestGaussian])
def test_empty_or_filtered_mixture_falls_back_to_the_lawnmower(cls):
    start = np.array([12.0, 9.0])
    expected = LawnMower(config()).decide(knowledge(start), RNG).goal
    assert np.allclose(expected, CORNER)
    empty = GaussianMixture(np.empty(0), np.empty((0, 2)), np.empty((0, 2, 2)))
    assert np.allclose(cls(config()).decide(knowledge(start, empty), RNG).goal, expected)
    light = mixture([0.2], [[100.0, 100.0]])
    got = cls(config(min_weight=0.5)).decide(knowledge(start, light), RNG).goal
    assert np.allclose(got, expected)


def test_gaussian_planner_without_a_mixture_names_the_capability():
    with pytest.raises(ValueError, match="gaussian_mixture"):
        NearestGaussian(config()).decide(knowledge([0.0, 0.0], None), RNG)


def rotated(cov, deg):
    t = np.radians(deg)
    r = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    return r @ cov @ r.T


# Widest by eigenvalue (10, its diagonal only 7.5 and 2.6), by trace (12), by det (30.25).
COVS = np.array([rotated(np.diag([10.0, 0.1]), 30.0), np.diag([9.5, 2.5]),
                 np.diag([5.5, 5.5])])
MEANS = np.array([[10.0, 0.0], [20.0, 0.0], [30.0, 0.0]])


@pytest.mark.parametrize("measure, expected", [
    ("max_eigenvalue", 0), ("trace", 1), ("determinant", 2)])
def test_largest_gaussian_by_each_size_measure(measure, expected):
    c = LargestGaussian(config(size_measure=measure))
    d = c.decide(knowledge([0.0, 0.0], mixture([1.0, 1.0, 1.0], MEANS, COVS)), RNG)
    assert np.allclose(d.goal, MEANS[expected]) and d.power_weight == 0.0


def test_size_measures_and_min_weight_of_largest_gaussian():
    assert np.allclose(covariance_size(COVS, "max_eigenvalue"), [10.0, 9.5, 5.5])
    assert np.allclose(covariance_size(COVS, "trace"), [10.1, 12.0, 11.0])
    assert np.allclose(covariance_size(COVS, "determinant"), [1.0, 23.75, 30.25])
    c = LargestGaussian(config(min_weight=0.5))
    d = c.decide(knowledge([0.0, 0.0], mixture([0.4, 1.0, 1.0], MEANS, COVS)), RNG)
    assert np.allclose(d.goal, MEANS[1])  # the widest is too light
    with pytest.raises(ValueError, match="size_measure"):
        covariance_size(COVS, "area")


@pytest.mark.parametrize("name, value", [
    ("lawnmower_spacing", 0.0), ("lawnmower_spacing", "wide"), ("lawnmower_axis", "z"),
    ("lawnmower_inset", -1.0),
    ("lawnmower_sweeps", -1), ("lawnmower_sweeps", 1.5), ("min_weight", -0.1),
    ("size_measure", "area")])
def test_option_errors_name_the_option(name, value):
    with pytest.raises(ValueError, match=name):
        config(**{name: value})


def test_system_config_checks_lawnmower_options():
    assert SystemConfig(controller="lawnmower").option("lawnmower_spacing") == 20.84
    with pytest.raises(ValueError, match="lawnmower_spacing"):
        SystemConfig(controller="lawnmower", options=(("lawnmower_spacing", -2.0),))


@pytest.mark.parametrize("name, cls, requires", [
    ("lawnmower", LawnMower, frozenset()),
    ("nearest_gaussian", NearestGaussian, frozenset({"gaussian_mixture"})),
    ("largest_gaussian", LargestGaussian, frozenset({"gaussian_mixture"}))])
def test_registry_entries_make_the_planners(name, cls, requires):
    part = registry.lookup("controller", name)
    assert part.requires == requires
    assert {"lawnmower_spacing", "lawnmower_inset", "lawnmower_axis", "lawnmower_sweeps"} \
        <= {s.name for s in part.options}
    c = part.make(part.setup(scenario_stub(), SimpleNamespace(options=())), 0)
    assert type(c) is cls
    d = c.decide(knowledge([11.0, 10.0], mixture([], [])), RNG)
    assert np.allclose(d.goal, CORNER)


# --- planned_path: what the robot's markers draw; read-only, decisions unchanged ---------


def test_controller_default_planned_path_is_empty():
    class Still(Controller):
        def decide(self, knowledge, rng):
            return Decision(goal=knowledge.position)

    assert Still().planned_path().shape == (0, 2)


def test_lawnmower_planned_path_runs_from_the_goal_to_the_start():
    c = LawnMower(config())
    assert c.planned_path().shape == (0, 2)  # nothing laid before the first decision
    start = np.array([3.0, 4.0])
    q = start
    for k in range(3000):  # past the first sweep's end (2427 steps from the corner)
        goal = c.decide(knowledge(q), RNG).goal
        path = c.planned_path()
        assert np.array_equal(path[0], goal)
        assert np.array_equal(path[-1], start)
        if k == 0:
            assert np.array_equal(path[:-1], c.path[:-1]) and len(path) == 15
        q = np.clip(next_position(q, goal, D_STEP), 0.0, SIDE)
    path[:] = -1.0  # a copy: the plan is unchanged
    assert np.array_equal(c.planned_path()[-1], start)


def test_lawnmower_planned_path_after_the_last_sweep_is_the_start():
    start = np.array([140.0, 146.0])
    c = LawnMower(config(lawnmower_sweeps=1))
    q = start
    for _ in range(2400):
        goal = c.decide(knowledge(q), RNG).goal
        q = np.clip(next_position(q, goal, D_STEP), 0.0, SIDE)
    assert c.finished
    assert np.array_equal(c.planned_path(), [start])


def test_planned_path_leaves_the_decisions_bit_identical():
    mixes = [mixture([1.0, 0.3], [[40.0, 60.0], [90.0, 20.0]]),
             mixture([], []), mixture([0.2], [[10.0, 140.0]])]
    for cls in (LawnMower, NearestGaussian, LargestGaussian):
        plain, asked = cls(config(min_weight=0.25)), cls(config(min_weight=0.25))
        q1 = q2 = np.array([7.0, 3.0])
        for k in range(600):
            mix = mixes[(k // 50) % 3]
            g1 = plain.decide(knowledge(q1, mix), RNG).goal
            asked.planned_path()
            g2 = asked.decide(knowledge(q2, mix), RNG).goal
            asked.planned_path()[:] = np.nan
            assert np.array_equal(g1, g2)
            q1 = np.clip(next_position(q1, g1, D_STEP), 0.0, SIDE)
            q2 = np.clip(next_position(q2, g2, D_STEP), 0.0, SIDE)


@pytest.mark.parametrize("cls", [NearestGaussian, LargestGaussian])
def test_gaussian_planner_path_is_its_goal_or_its_fallback_path(cls):
    c = cls(config(min_weight=0.5))
    assert c.planned_path().shape == (0, 2)
    start = np.array([12.0, 9.0])
    mix = mixture([1.0], [[100.0, 50.0]], [[[9.0, 2.0], [2.0, 1.0]]])
    goal = c.decide(knowledge(start, mix), RNG).goal
    assert np.array_equal(c.planned_path(), [goal]) and np.array_equal(goal, [100.0, 50.0])
    # Nothing heavy enough: the lawn mower's remaining waypoints, from its goal to the start.
    goal = c.decide(knowledge(start, mixture([0.2], [[100.0, 50.0]])), RNG).goal
    path = c.planned_path()
    assert np.array_equal(path[0], goal) and np.array_equal(goal, CORNER)
    assert np.array_equal(path, c.fallback.planned_path()) and np.array_equal(path[-1], start)
    goal = c.decide(knowledge(start, mix), RNG).goal  # back on a component
    assert np.array_equal(c.planned_path(), [goal])
