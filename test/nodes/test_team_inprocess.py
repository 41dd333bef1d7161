"""World, monitor and a team of robot nodes in one process, lockstep, against the engine.

The ROS stack in lockstep mode must compute the same team PHD as the in-memory engine of
the distributed filter for the same scenario and seed (DESIGN.md), step by step.
"""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.testing import small_static_scenario, start_swarm


@pytest.mark.ros
def test_lockstep_team_equals_in_memory_engine_and_ospa_falls(tmp_path):
    from phd_swarm.testing import InProcessRos

    scenario = small_static_scenario()
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_swarm(ros, tmp_path, scenario)
        probe = ros.node("graph_probe")
        assert ros.spin_until(lambda: monitor.next_step >= 2, timeout=60.0)
        graph = dict(probe.get_topic_names_and_types())
        assert ros.spin_until(lambda: monitor.done, timeout=240.0), (
            f"monitor stopped at step {monitor.next_step} of {scenario.steps}")
        assert world.dead == set() and world.rejected == 0
        assert sum(sum(r.rejections.values()) for r in robots) == 0
        images = monitor.images
        series = monitor.series

    expected = {"/clock": "rosgraph_msgs/msg/Clock",
                "/world/truth": "phd_swarm_msgs/msg/TargetSet",
                "/world/robots": "phd_swarm_msgs/msg/TeamState",
                "/world/markers": "visualization_msgs/msg/MarkerArray",
                "/monitor/metrics": "phd_swarm_msgs/msg/TeamMetrics",
                "/monitor/estimates": "phd_swarm_msgs/msg/TargetSet",
                "/monitor/markers": "visualization_msgs/msg/MarkerArray",
                **{f"/robot_{i}/{rel}": typ for i in range(scenario.robots)
                   for rel, typ in (("measurements", "phd_swarm_msgs/msg/MeasurementSet"),
                                    ("pose", "geometry_msgs/msg/PoseStamped"),
                                    ("status", "phd_swarm_msgs/msg/RobotStatus"),
                                    ("goal", "geometry_msgs/msg/PoseStamped"),
                                    ("cell", "phd_swarm_msgs/msg/CellPolygon"),
                                    ("density", "phd_swarm_msgs/msg/DensityGrid"),
                                    ("estimates", "phd_swarm_msgs/msg/TargetSet"),
                                    ("inbox", "phd_swarm_msgs/msg/InboxMessage"))}}
    missing = {t: typ for t, typ in expected.items() if typ not in graph.get(t, [])}
    assert not missing, f"topics missing from the graph while the swarm runs: {missing}"

    engine = DistributedEngine(scenario, "phd")
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


@pytest.mark.ros
def test_realtime_mode_steps_on_the_clock_and_the_team_keeps_up(tmp_path):
    import time

    from phd_swarm.testing import InProcessRos

    scenario = small_static_scenario(robots=3, steps=24)
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_swarm(ros, tmp_path, scenario, mode="realtime",
                                             realtime_factor=5.0)
        assert ros.spin_until(lambda: world._phase == "stepping", timeout=60.0)
        started = time.monotonic()
        assert ros.spin_until(lambda: world._phase in ("lingering", "finished"),
                              timeout=60.0)
        elapsed = time.monotonic() - started
        assert ros.spin_until(lambda: monitor.done, timeout=60.0)
    # 24 steps of 0.5 s at 5 x real time take 2.4 s of wall time, whatever the robots do.
    assert 2.0 < elapsed < 6.0, elapsed
    assert len(monitor.series) == scenario.steps
    assert world.dead == set()
