"""Sung & Tokekar's system as ROS nodes in one process, lockstep, against the engine.

One robot node (GM-PHD with the limited-FoV rule, tracks, a lawn-mower; no exchange), the
world with the false-positive sensor, and the monitor: the robot's components, targets and
tracks, and the monitor's scores and figures, equal the in-memory engine's bit for bit,
with the GP fed by the tracks' estimates and by their detections (issue 34).
"""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.scoring import score_estimates
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim.presets import sung_tokekar

STEPS = 80


def _scenario(controller: str = "lawnmower", gp_input: str = "estimates"):
    return sung_tokekar().with_system(controller=controller, options={
        "false_positive_prob": 0.2, "gp_prediction": True,
        "gp_input": gp_input}).with_overrides(seed=3, duration=float(STEPS))


@pytest.mark.ros
@pytest.mark.parametrize("controller, gp_input", [("lawnmower", "estimates"),
                                                  ("largest_gaussian", "estimates"),
                                                  ("lawnmower", "detections")])
def test_lockstep_robot_equals_in_memory_engine(tmp_path, controller, gp_input):
    from phd_swarm.nodes import topics as T
    from phd_swarm.nodes.faces import gaussian_mixture
    from phd_swarm.testing import InProcessRos, start_swarm
    from phd_swarm_msgs.msg import GaussianMixture, TrackSet

    scenario = _scenario(controller, gp_input)
    components: dict[int, GaussianMixture] = {}
    tracks: dict[int, TrackSet] = {}
    with InProcessRos(executor="events") as ros:
        probe = ros.node("probe")
        probe.create_subscription(GaussianMixture, T.robot_topic(0, "components"),
                                  lambda m: components.setdefault(m.step, m), 100)
        probe.create_subscription(TrackSet, T.robot_topic(0, "tracks"),
                                  lambda m: tracks.setdefault(m.step, m), 100)
        world, monitor, robots = start_swarm(ros, tmp_path, scenario)
        assert ros.spin_until(lambda: monitor.done, timeout=240.0), (
            f"monitor stopped at step {monitor.next_step} of {scenario.steps}")
        assert ros.spin_until(lambda: len(components) == len(tracks) == STEPS, timeout=30.0)
        graph = dict(probe.get_topic_names_and_types())
        assert world.dead == set() and world.rejected == 0 and monitor.rejected == 0
        assert sum(robots[0].rejections.values()) == 0
        series = monitor.series
        summary = monitor.summary()

    assert graph[T.robot_topic(0, "components")] == ["phd_swarm_msgs/msg/GaussianMixture"]
    assert graph[T.robot_topic(0, "markers")] == ["visualization_msgs/msg/MarkerArray"]
    assert not any(t.endswith(("/inbox", "/density", "/cell")) for t in graph)
    engine = DistributedEngine(scenario)
    est = engine.agents[0].estimator
    ever_confirmed = set()
    for k in range(STEPS):
        _, truth = engine.world.truth()
        engine.step()
        mix = gaussian_mixture.mixture_from_ros(components[k], 1000)
        assert np.array_equal(mix.weights, est.mixture.weights), k
        assert np.array_equal(mix.means, est.mixture.means), k
        assert np.array_equal(mix.covs, est.mixture.covs), k
        got = gaussian_mixture.tracks_from_ros(tracks[k], 1000)
        positions, covs, weights, ids = est.targets()
        assert np.array_equal(got.track_ids, ids) and np.array_equal(got.positions, positions)
        assert np.array_equal(got.covs, covs) and np.array_equal(got.weights, weights)
        assert np.array_equal(got.confirmed, est.confirmed_mask())
        ever_confirmed |= set(got.track_ids[got.confirmed].tolist())
        score = score_estimates(*engine.team_estimates(), truth, scenario.ospa_c,
                                scenario.ospa_p)
        row = series[k]
        assert row["step"] == k and row["ospa"] == score.ospa
        assert row["cardinality_est"] == score.cardinality_est
        figures = engine.figures(truth)
        assert set(figures) <= set(row)
        for name, value in figures.items():
            assert value == row[name] or (np.isnan(value) and np.isnan(row[name])), name
    assert ever_confirmed, "tracks were confirmed"
    assert summary["steps"] == STEPS and summary["figures"]["tracks"] > 0
