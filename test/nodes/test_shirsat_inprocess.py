"""Shirsat & Berman's system as ROS nodes in one process, lockstep, against the engine.

Three robot nodes random-walk on the grid with a GM-PHD each and merge their reward sets
when they meet (``meet_merge``, inbox kind ``rewards``): every robot's components and reward
set, the robots met, and the monitor's figures equal the in-memory engine's bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config import load_run_config
from phd_swarm.engines.distributed import DistributedEngine

ROOT = Path(__file__).resolve().parents[2]
STEPS = 60


@pytest.mark.ros
def test_lockstep_team_equals_in_memory_engine_with_meetings(tmp_path):
    from phd_swarm.nodes import topics as T
    from phd_swarm.nodes.faces import gaussian_mixture
    from phd_swarm.nodes.faces.meet_merge import reward_points
    from phd_swarm.testing import InProcessRos, start_swarm
    from phd_swarm_msgs.msg import GaussianMixture, RewardSet

    # Seed 4: the robots meet at steps 2, 30, 32 and 33.
    scenario = load_run_config(ROOT / "config" / "shirsat_small.yaml").scenario.with_overrides(
        seed=4, duration=float(STEPS))
    robots = range(scenario.robots)
    components = {r: {} for r in robots}
    rewards = {r: {} for r in robots}
    with InProcessRos(executor="events") as ros:
        probe = ros.node("probe")
        for r in robots:
            probe.create_subscription(GaussianMixture, T.robot_topic(r, "components"),
                                      lambda m, r=r: components[r].setdefault(m.step, m), 100)
            probe.create_subscription(RewardSet, T.robot_topic(r, "reward_set"),
                                      lambda m, r=r: rewards[r].setdefault(m.step, m), 100)
        world, monitor, nodes = start_swarm(ros, tmp_path, scenario)
        assert ros.spin_until(lambda: monitor.done, timeout=240.0), (
            f"monitor stopped at step {monitor.next_step} of {scenario.steps}")
        assert ros.spin_until(lambda: all(len(rewards[r]) == STEPS for r in robots),
                              timeout=30.0)
        assert world.dead == set() and world.rejected == 0 and monitor.rejected == 0
        assert sum(sum(n.rejections.values()) for n in nodes) == 0
        sent = sum(n.filter.stats["sent"] for n in nodes)
        series = monitor.series

    engine = DistributedEngine(scenario)
    meetings = []
    for k in range(STEPS):
        _, truth = engine.world.truth()
        engine.step()
        for r in robots:
            est = engine.agents[r].estimator
            mix = gaussian_mixture.mixture_from_ros(components[r][k], 1000)
            assert np.array_equal(mix.weights, est.mixture.weights), (k, r)
            assert np.array_equal(mix.means, est.mixture.means), (k, r)
            assert np.array_equal(reward_points(rewards[r][k]), est.reward_set()), (k, r)
            assert list(rewards[r][k].met_ids) == est.met.tolist(), (k, r)
            if est.met.size:
                meetings.append((k, r))
        figures = engine.figures(truth)
        for name, value in figures.items():
            assert value == series[k][name] or (np.isnan(value) and np.isnan(series[k][name]))
    assert {k for k, _ in meetings} == {2, 30, 32, 33}
    # One message per robot met, none otherwise: O(meetings), not O(team).
    assert sent == len(meetings)
    assert engine.agents[0].exchange.stats["sent"] + engine.agents[1].exchange.stats[
        "sent"] + engine.agents[2].exchange.stats["sent"] == sent


@pytest.mark.ros
def test_the_ros_stack_refuses_the_labelled_sensor_naming_the_reading(tmp_path):
    """MeasurementSet and RewardSet carry no labels: the nodes refuse to run without them."""
    from phd_swarm.nodes.ros_params import ParameterError
    from phd_swarm.testing import InProcessRos, start_swarm

    scenario = load_run_config(ROOT / "config" / "shirsat_small.yaml").scenario.with_system(
        sensor="disk_labelled", options={"reward_union": "label"})
    with InProcessRos(executor="events") as ros:
        with pytest.raises(ParameterError, match=r"scenario\.system: sensor disk_labelled "
                                                 r"labels its measurements.*reward_union: "
                                                 r"label\) runs on the in-memory engines only"):
            start_swarm(ros, tmp_path, scenario)


def test_run_swarm_refuses_the_labelled_sensor_before_anything_starts(tmp_path):
    import subprocess
    import sys

    text = (ROOT / "config" / "shirsat_small.yaml").read_text()
    config = tmp_path / "labelled.yaml"
    config.write_text(text.replace("sensor: disk\n", "sensor: disk_labelled\n").replace(
        "grid_spacing: 0.5 ", "reward_union: label\n          grid_spacing: 0.5 "))
    assert "disk_labelled" in config.read_text() and "reward_union: label" in config.read_text()
    out = tmp_path / "runs"
    res = subprocess.run([sys.executable, "-m", "phd_swarm.tools.run_swarm", str(config),
                          "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "sensor disk_labelled labels its measurements" in res.stderr
    assert "in-memory engines only" in res.stderr and not out.exists()
