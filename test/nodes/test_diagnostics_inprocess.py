"""A healthy lockstep team reports OK on /diagnostics and shows its PHD as occupancy grids.

World, monitor, recorder and robots on one executor (:func:`phd_swarm.testing.start_swarm`
plus a recorder), while a probe listens to ``/diagnostics``, the monitor's grid and robot
0's window in both forms. Then the log: complete, holding the others' reports (not the
recorder's own), and drawn as the views' snapshot (:mod:`phd_swarm.tools.views_snapshot`).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest

from phd_swarm.testing import small_static_scenario


def _key(msg) -> tuple[int, int]:
    return msg.header.stamp.sec, msg.header.stamp.nanosec


@pytest.mark.ros
@pytest.mark.slow
def test_a_healthy_team_reports_ok_and_shows_its_phd_as_occupancy_grids(tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray
    from nav_msgs.msg import OccupancyGrid
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, QoSProfile

    from phd_swarm.logs.mcap_log import read_messages
    from phd_swarm.nodes import diagnostics as D
    from phd_swarm.nodes import topics as T
    from phd_swarm.nodes.occupancy import from_density
    from phd_swarm.nodes.qos import subscription_qos
    from phd_swarm.nodes.recorder import Recorder
    from phd_swarm.testing import InProcessRos, start_swarm
    from phd_swarm.tools.plots import save_snapshot
    from phd_swarm.tools.views_snapshot import views_frame
    from phd_swarm_msgs.msg import DensityGrid

    scenario = small_static_scenario(robots=3, steps=10)
    log = tmp_path / "run.mcap"
    reports: dict[str, list] = defaultdict(list)
    team_grids: dict[int, OccupancyGrid] = {}
    robot_grids: dict[int, OccupancyGrid] = {}
    windows: dict[int, DensityGrid] = {}
    # deeper than the writers' LATCHED depth 1, so that the probe keeps every grid
    deep = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    with InProcessRos(executor="events") as ros:
        probe = ros.node("probe")
        probe.create_subscription(
            DiagnosticArray, T.DIAGNOSTICS,
            lambda m: [reports[s.hardware_id].append(s) for s in m.status],
            subscription_qos("OBSERVATION"))
        probe.create_subscription(OccupancyGrid, T.MONITOR_DENSITY_GRID,
                                  lambda m: team_grids.setdefault(_key(m), m), deep)
        probe.create_subscription(OccupancyGrid, T.robot_topic(0, "density_grid"),
                                  lambda m: robot_grids.setdefault(_key(m), m), deep)
        probe.create_subscription(DensityGrid, T.robot_topic(0, "density"),
                                  lambda m: windows.setdefault(m.step, m),
                                  subscription_qos("STEP"))
        world, monitor, robots = start_swarm(ros, tmp_path, scenario, observers=2)
        params = str(tmp_path / "params.yaml")
        recorder = ros.add(Recorder(context=ros.context,
                                    cli_args=["--ros-args", "--params-file", params],
                                    parameter_overrides=[
                                        Parameter("output", value=str(log)),
                                        Parameter("params_file", value=params),
                                        Parameter("discover", value=False)]))
        assert ros.spin_until(lambda: monitor.done, timeout=120.0), monitor.next_step
        everyone = {"world", "recorder", *(f"robot_{r}" for r in range(scenario.robots))}

        def settled() -> bool:
            rec = reports.get("recorder", [])
            return everyone <= set(reports) and bool(rec) and all(
                int(v.value) > 0 for v in rec[-1].values if v.key == "step_messages_expected")
        # the recorder counts gaps on steps that ended GAP_SETTLE_S ago
        assert ros.spin_until(settled, timeout=D.GAP_SETTLE_S + 10.0), sorted(reports)
        world_done = reports["world"][-1]
        robot_done = reports["robot_0"][-1]
        recorder.close()
        assert world.dead == set() and world.rejected == 0
        assert recorder.report is not None and recorder.report.complete, \
            recorder.report.describe()

    # /diagnostics: every report of a healthy lockstep run is OK, and says what it should
    bad = {who: [(s.level, s.message) for s in got if D.level_of(s) != D.OK]
           for who, got in reports.items()}
    assert not any(bad.values()), bad
    values = {kv.key: kv.value for kv in robot_done.values}
    assert values["state"] == "done" and int(values["step_lag"]) <= 1
    assert values["contacts"] != "n/a" and values["timeouts"] == "0"
    assert values["last_finished_step"] == str(scenario.steps - 1)
    values = {kv.key: kv.value for kv in world_done.values}
    assert values["steps_done"] == str(scenario.steps) and values["robots_dead"] == "none"
    values = {kv.key: kv.value for kv in reports["recorder"][-1].values}
    assert values["step_messages_missing"] == "0" and int(values["messages_written"]) > 0

    # the grids: the team's covers the map from its corner, robot 0's is its window
    ny, nx = scenario.grid.shape
    assert team_grids, "no team grid"
    for msg in team_grids.values():
        assert (msg.info.width, msg.info.height) == (nx, ny)
        assert msg.info.resolution == pytest.approx(scenario.grid.resolution)
        assert (msg.info.origin.position.x, msg.info.origin.position.y) == (
            scenario.env.xmin, scenario.env.ymin)
        assert msg.header.frame_id == "map" and len(msg.data) == nx * ny
    assert any(np.frombuffer(bytes(m.data), np.int8).max() > 0 for m in team_grids.values())
    assert robot_grids, "no grid of robot 0"
    last = windows[max(windows)]
    got = robot_grids[_key(last)]
    assert got == from_density(last)
    assert (got.info.width, got.info.height) == (last.width, last.height)

    # the log holds the world's and the robots' reports, not the recorder's own
    recorded = {s.hardware_id for rec in read_messages(log, [T.DIAGNOSTICS])
                for s in rec.msg.status}
    assert recorded == everyone - {"recorder"}
    frame = views_frame(log)
    assert frame.step == scenario.steps - 1 and frame.phd.shape == (ny, nx)
    assert set(frame.robots) == set(range(scenario.robots)) == frame.alive
    assert len(frame.cells) == scenario.robots and len(frame.goals) == scenario.robots
    assert save_snapshot(frame, tmp_path / "views.png").stat().st_size > 0
