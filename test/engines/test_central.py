"""The central engine runs the same team as the distributed one, up to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core import phd_grid
from phd_swarm.core.partition import cells
from phd_swarm.core.polygons import points_in_polygon
from phd_swarm.engines.central import CentralEngine
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim import scenario as sc

STEPS = 120


def _chen_o(mode: str) -> sc.Scenario:
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
                assert np.array_equal(robot.alpha, cent.alpha[robot.bins]), (k, rid)
                assert np.array_equal(robot.count, cent.count[robot.bins]), (k, rid)
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
