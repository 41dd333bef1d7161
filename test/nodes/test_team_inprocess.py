"""World, monitor and a team of robot nodes in one process, lockstep, against the engine.

The ROS stack in lockstep mode must compute the same team PHD as the in-memory engine of
the distributed filter for the same scenario and seed (DESIGN.md), step by step.
"""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.config import RunConfig
from phd_swarm.core.grid import Environment
from phd_swarm.sim.engine import InMemoryEngine
from phd_swarm.sim.scenario import dames_static


def small_static(robots: int = 5, steps: int = 64):
    """A 40 x 40 m Dames static scenario where 5 robots find most targets in 32 s."""
    s = dames_static(robots=robots, targets=12)
    return s.with_overrides(
        env=Environment(0.0, 0.0, 40.0, 40.0), robot_start_box=(15.0, 0.0, 25.0, 5.0),
        duration=steps * s.dt, seed=7,
        targets=s.targets.__class__(kind="static", count=12,
                                    draw_box=(0.0, 0.0, 40.0, 40.0)))


def start_team(ros, tmp_path, scenario, controller="phd", observers=1, **world):
    """World, monitor and one robot node per robot on ``ros``'s executor."""
    from rclpy.parameter import Parameter

    from phd_swarm.nodes.monitor import MonitorNode
    from phd_swarm.nodes.robot import RobotNode
    from phd_swarm.nodes.world import WorldNode

    rc = RunConfig(scenario).with_overrides(
        world={"observers": observers, **world},
        robot={"controller": controller, "observers": observers},
        monitor={"progress_every": 0})
    params = rc.write_params(tmp_path / "params.yaml")
    args = ["--ros-args", "--params-file", str(params)]
    robots = [ros.add(RobotNode(context=ros.context, namespace=f"/robot_{i}", cli_args=args,
                                parameter_overrides=[Parameter("robot_id", value=i)]))
              for i in range(scenario.robots)]
    monitor = ros.add(MonitorNode(keep_images=True, context=ros.context, cli_args=args))
    world_node = ros.add(WorldNode(context=ros.context, cli_args=args))
    return world_node, monitor, robots


@pytest.mark.ros
def test_lockstep_team_equals_in_memory_engine_and_ospa_falls(tmp_path):
    from phd_swarm.testing import InProcessRos

    scenario = small_static()
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_team(ros, tmp_path, scenario)
        assert ros.spin_until(lambda: monitor.done, timeout=240.0), (
            f"monitor stopped at step {monitor.next_step} of {scenario.steps}")
        assert world.dead == set() and world.rejected == 0
        assert sum(sum(r.rejections.values()) for r in robots) == 0
        images = monitor.images
        series = monitor.series

    engine = InMemoryEngine(scenario, "phd")
    worst = 0.0
    for k in range(scenario.steps):
        engine.step()
        expected = engine.team_weights()
        scale = max(float(expected.sum()), 1e-300)
        worst = max(worst, float(np.max(np.abs(images[k] - expected))) / scale)
    assert worst <= 1e-12, f"team PHD differs from the engine by {worst:.3g} of its mass"
    assert len(series) == scenario.steps == 64
    ospa = np.array([r["ospa"] for r in series])
    assert ospa[:8].mean() > ospa[-8:].mean() + 2.0, ospa
