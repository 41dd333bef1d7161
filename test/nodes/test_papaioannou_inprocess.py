"""Papaioannou et al.'s system as ROS nodes in one process, lockstep, against the engine.

Four agents search and track with a particle PHD and a search map each and exchange their
state (inbox kind ``sat``) with the agents in range: every agent's estimates and goals, its
search maps, modes and joint-plan agents, the messages sent and the monitor's OSPA equal
the in-memory engine's bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config import load_run_config
from phd_swarm.core.scoring import score_estimates
from phd_swarm.engines.distributed import DistributedEngine

ROOT = Path(__file__).resolve().parents[2]
STEPS = 30


@pytest.mark.ros
def test_lockstep_team_equals_in_memory_engine(tmp_path):
    from geometry_msgs.msg import PoseStamped

    from phd_swarm.nodes import convert
    from phd_swarm.nodes import topics as T
    from phd_swarm.testing import InProcessRos, start_swarm
    from phd_swarm_msgs.msg import DensityGrid, SatState, TargetSet

    scenario = load_run_config(ROOT / "config" / "papaioannou_small.yaml").scenario
    scenario = scenario.with_overrides(duration=float(STEPS))
    robots = range(scenario.robots)
    estimates = {r: {} for r in robots}
    goals = {r: [] for r in robots}
    maps = {r: {} for r in robots}
    states = {r: {} for r in robots}
    with InProcessRos(executor="events") as ros:
        probe = ros.node("probe")
        for r in robots:
            probe.create_subscription(TargetSet, T.robot_topic(r, "estimates"),
                                      lambda m, r=r: estimates[r].setdefault(m.step, m), 100)
            probe.create_subscription(PoseStamped, T.robot_topic(r, "goal"),
                                      lambda m, r=r: goals[r].append(m), 100)
            probe.create_subscription(DensityGrid, T.robot_topic(r, "search_map"),
                                      lambda m, r=r: maps[r].setdefault(m.step, m), 100)
            probe.create_subscription(SatState, T.robot_topic(r, "sat_state"),
                                      lambda m, r=r: states[r].setdefault(m.step, m), 100)
        world, monitor, nodes = start_swarm(ros, tmp_path, scenario)
        assert ros.spin_until(lambda: monitor.done, timeout=240.0), (
            f"monitor stopped at step {monitor.next_step} of {scenario.steps}")
        assert ros.spin_until(lambda: all(len(estimates[r]) == STEPS for r in robots),
                              timeout=30.0)
        assert world.dead == set() and world.rejected == 0 and monitor.rejected == 0
        assert sum(sum(n.rejections.values()) for n in nodes) == 0
        sent = sum(n.filter.stats["sent"] for n in nodes)
        series = monitor.series

    engine = DistributedEngine(scenario)
    found = 0
    for k in range(STEPS):
        _, truth = engine.world.truth()
        engine.step()
        for r in robots:
            est = engine.agents[r].estimator.estimates()
            assert np.array_equal(convert.target_positions(estimates[r][k]), est), (k, r)
            found += len(est)
            g = goals[r][k].pose.position
            agent = engine.agents[r]
            assert [g.x, g.y] == agent.controller.goal.tolist(), (k, r)
            assert np.array_equal(np.array(maps[r][k].data), agent.estimator.search), (k, r)
            assert states[r][k].tracking == agent.controller.tracking, (k, r)
            assert list(states[r][k].plan_members) == list(agent.controller.plan_members)
        score = score_estimates(*engine.team_estimates(), truth, scenario.ospa_c,
                                scenario.ospa_p)
        assert series[k]["ospa"] == score.ospa, k
    assert found > 0
    assert sent == sum(engine.agents[r].exchange.stats["sent"] for r in robots) > 0
