"""The central engine runs the same team as the distributed one, up to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.controllers.power_lloyd.cumulative import nearest_robot_cap
from phd_swarm.core.estimators.grid_phd import filter as phd_grid
from phd_swarm.core.geometry.ownership import bin_owners
from phd_swarm.core.geometry.partition import cells
from phd_swarm.core.geometry.polygons import points_in_polygon
from phd_swarm.engines.central import CentralEngine
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim import presets as sc
from phd_swarm.sim.scenario import Scenario

STEPS = 120


def _chen_o(mode: str) -> Scenario:
    return sc.chen_clustered(robots=20, resolution=1.0).with_system(
        controller="chen_o", options={"rho_max": 5.0, "cumulative_mode": mode})


CASES = {
    "dames_static_phd": sc.dames_static(robots=20, targets=30),
    "dames_static_uniform": sc.dames_static(robots=20, targets=30).with_system(
        controller="uniform"),
    "dames_moving_phd": sc.dames_moving(robots=15, targets=20),
    "chen_p": sc.chen_clustered(robots=20, resolution=1.0).with_system(controller="chen_p"),
    "chen_o": _chen_o("rate"),
    "chen_o_laplace": _chen_o("laplace"),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CASES))
def test_central_engine_follows_the_distributed_one(name):
    scenario = CASES[name].with_overrides(seed=4)
    controller = scenario.system.controller
    dist = DistributedEngine(scenario)
    cent = CentralEngine(scenario)
    moved = 0.0
    for k in range(STEPS):
        before = cent.world.robot_positions.copy()
        dist.step()
        cent.step()
        team, ref = dist.team_weights(), cent.team_weights()
        err = float(np.abs(team - ref).max() / ref.sum())
        assert err <= 1e-9, f"step {k}: team PHD differs by {err:.3e} x total mass"
        gap = float(np.abs(dist.world.robot_positions - cent.world.robot_positions).max())
        assert gap <= 1e-9, f"step {k}: robot positions differ by {gap:.3e} m"
        # Every robot owns in the distributed engine what the central partition gives it.
        for r, rid in enumerate(cent.world.robot_ids.tolist()):
            robot = dist.robots[rid]
            assert np.array_equal(robot.bins, np.flatnonzero(cent.owners == r)), (k, rid)
            if robot.alpha is not None:
                # Chen eq. 9-10: whole numbers, so exactly equal.
                assert np.array_equal(robot.alpha, cent.layer.alpha[robot.bins]), (k, rid)
                assert np.array_equal(robot.count, cent.layer.count[robot.bins]), (k, rid)
            assert dist.power_weights[rid] == pytest.approx(cent.power_weights[r],
                                                            rel=1e-9, abs=1e-12)
        moved += float(np.abs(cent.world.robot_positions - before).max())
    assert moved > 10.0, "the team moved: the comparison covers the controllers"
    if controller in ("chen_p", "chen_o"):
        assert np.any(cent.power_weights > 0), "power cells were exercised"


@pytest.mark.slow
def test_at_an_fft_kernel_both_engines_keep_the_same_paths():
    # Chen at 0.1 m: a 29 x 29 kernel, convolved by FFT. The central engine spreads each
    # cell's bins in their own box as the robots do, and FFT round-off is cut at the same
    # floor, so searched-out cells (every mass tiny) steer the same way in both engines.
    scenario = sc.chen_clustered(robots=20, resolution=0.1).with_overrides(seed=2)
    assert scenario.models.motion.kernel(0.1).size > phd_grid.DIRECT_MAX_TAPS
    dist = DistributedEngine(scenario, "chen_p")
    cent = CentralEngine(scenario, "chen_p")
    for k in range(10):
        dist.step()
        cent.step()
        ref = cent.team_weights()
        err = float(np.abs(dist.team_weights() - ref).max() / ref.sum())
        assert err <= 1e-9, f"step {k}: team PHD differs by {err:.3e} x total mass"
        gap = float(np.abs(dist.world.robot_positions - cent.world.robot_positions).max())
        assert gap <= 1e-6, f"step {k}: robot positions differ by {gap:.3e} m"


def test_central_engine_runs_a_scenario_to_its_end():
    scenario = sc.dames_static(robots=5, targets=8).with_overrides(duration=5.0, seed=1)
    engine = CentralEngine(scenario, "phd")
    engine.run()
    assert engine.step_index == scenario.steps
    assert engine.team_weights().shape == scenario.grid.shape
    assert engine.goals.shape == (5, 2)
    assert engine.owners.shape == (scenario.grid.size,)
    assert set(np.unique(engine.owners).tolist()) <= set(range(5))
    # The cells, computed on demand, are those of the whole diagram at the last step, and
    # hold the bins the partition gives their robots.
    positions, rho = engine._generators
    polys = cells(scenario.grid.env, positions, rho)
    for r in range(5):
        np.testing.assert_array_equal(engine.cell(r), polys[r])
        owned = scenario.grid.centres_of(np.flatnonzero(engine.owners == r))
        assert points_in_polygon(owned, polys[r], 1e-9).all()


def test_the_nearest_robot_guard_bounds_the_weights_of_each_partition():
    # chen_p with the paper's uncapped rho: the engine caps each weight at the partition
    # (nearest_robot_cap with a one-bin margin), so every robot whose nearest other robot is
    # more than sqrt(2) bins away owns the bin it stands in.
    scenario = sc.chen_clustered(robots=20, resolution=1.0).with_overrides(seed=3).with_system(
        controller="chen_p", options={"rho_cap": "nearest_robot"})
    engine = CentralEngine(scenario)
    grid = scenario.grid
    uncapped = 0
    for _ in range(40):
        q = engine.world.robot_positions.copy()
        rho = nearest_robot_cap(q, engine.power_weights, margin=1.0)
        uncapped += int(np.sum(engine.power_weights > 5.0))
        engine.step()
        np.testing.assert_array_equal(engine.owners, bin_owners(grid, q, rho))
        np.testing.assert_array_equal(engine._generators[1], rho)
        d2 = np.sum((q[:, None] - q[None]) ** 2, axis=-1) + np.diag(np.full(len(q), np.inf))
        far = np.sqrt(d2.min(axis=1)) > np.sqrt(2.0)
        own = grid.flat_index(*np.floor(q[:, ::-1]).astype(int).T)
        assert np.array_equal(engine.owners[own[far]], np.flatnonzero(far))
    assert uncapped > 0, "weights above the fixed cap were exercised"


def test_the_defaults_are_the_fixed_cap_and_the_3_m_window():
    base = sc.chen_clustered(robots=10, resolution=1.0).with_overrides(seed=5, duration=10.0)
    runs = []
    for options in ({}, {"rho_cap": "fixed", "rho_max": 0.0, "extraction_window": 3.0,
                         "extraction_radius": 0.0}):
        engine = CentralEngine(base.with_system(controller="chen_o", options=options))
        assert engine._guard is None
        engine.run()
        runs.append((engine.world.robot_positions, engine.team_weights(),
                     engine.power_weights))
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


def test_chen_o_reports_its_switching_counts_and_the_protocol_refuses_the_guard():
    scenario = sc.chen_clustered(robots=10, resolution=1.0).with_overrides(seed=2)
    engine = CentralEngine(scenario.with_system(controller="chen_o"))
    zero = {"busy_robots": 0.0, "turned_idle": 0.0, "turned_idle_in_view": 0.0}
    assert engine.figures(np.empty((0, 2))) == zero, "nobody decided before the first step"
    ids, truth = engine.world.truth()
    engine.step()
    f = engine.figures(truth, ids)
    assert set(f) == set(zero)
    assert f["turned_idle"] == 0.0  # nobody was busy before the first step
    assert CentralEngine(scenario.with_system(controller="chen_p")).figures(truth) == {}
    # The distributed engine reports the same counts of the same robots.
    dist = DistributedEngine(scenario.with_system(controller="chen_o"))
    dist.step()
    assert dist.figures(truth, ids) == f
    for controller in ("chen_p", "chen_o"):
        with pytest.raises(ValueError, match="option rho_cap: nearest_robot bounds the "
                                             "power weights .* central engine"):
            DistributedEngine(scenario.with_system(controller=controller,
                                                   options={"rho_cap": "nearest_robot"}))
