"""The live view's feeder (phd_swarm.nodes.viewer), in process, against a Recorded stream.

A lockstep team (world, monitor, robots) and the viewer on one executor; the viewer logs to
a stand-in for ``rerun.RecordingStream`` that keeps every call, so the test reads exactly
what the browser would get: which entities, at which sim times, with how many robots, and
the team PHD image of each step against the monitor's own.

Marked ``full``: the view's package (rerun-sdk) is an extra that ``scripts/test.sh --full``
installs (``scripts/setup.sh --with-view``).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest

from phd_swarm.testing import small_static_scenario

pytestmark = [pytest.mark.ros, pytest.mark.full]


class Recorded:
    """Keeps what a RecordingStream is asked to log, with the sim time it was set to."""

    def __init__(self) -> None:
        self.time: float | None = None
        self.logs: dict[str, list[tuple[float | None, tuple]]] = defaultdict(list)
        self.blueprints = 0

    def send_blueprint(self, blueprint) -> None:
        self.blueprints += 1

    def set_time(self, timeline: str, duration: float) -> None:
        assert timeline == "sim_time"
        self.time = duration

    def log(self, path: str, *archetypes, static: bool = False) -> None:
        self.logs[path].append((None if static else self.time, archetypes))

    def flush(self) -> None:
        pass


def test_drawn_topics_choose_the_exact_grid_and_the_teams():
    from phd_swarm.nodes.viewer import drawn_topics

    graph = {
        "/world/markers": ["visualization_msgs/msg/MarkerArray"],
        "/world/robots": ["phd_swarm_msgs/msg/TeamState"],
        "/world/truth": ["phd_swarm_msgs/msg/TargetSet"],
        "/monitor/density": ["phd_swarm_msgs/msg/DensityGrid"],
        "/monitor/density_grid": ["nav_msgs/msg/OccupancyGrid"],
        "/robot_0/density": ["phd_swarm_msgs/msg/DensityGrid"],
        "/robot_0/density_grid": ["nav_msgs/msg/OccupancyGrid"],
        "/robot_0/search_map": ["phd_swarm_msgs/msg/DensityGrid"],
        "/robot_0/markers": ["visualization_msgs/msg/MarkerArray"],
        "/other/map": ["nav_msgs/msg/OccupancyGrid"],
        "/other/team": ["phd_swarm_msgs/msg/TeamState"],
    }
    assert drawn_topics(graph) == {
        "/monitor/density": "phd_swarm_msgs/msg/DensityGrid",
        "/other/map": "nav_msgs/msg/OccupancyGrid",
        "/robot_0/markers": "visualization_msgs/msg/MarkerArray",
        "/robot_0/search_map": "phd_swarm_msgs/msg/DensityGrid",
        "/world/markers": "visualization_msgs/msg/MarkerArray",
        "/world/robots": "phd_swarm_msgs/msg/TeamState",
    }


def test_the_view_of_a_lockstep_run_has_every_step_and_the_monitors_phd(tmp_path):
    import rerun as rr

    from phd_swarm.nodes import view_scene
    from phd_swarm.nodes.viewer import MAP, ViewerNode
    from phd_swarm.testing import InProcessRos, start_swarm

    steps, robots = 8, 3
    scenario = small_static_scenario(robots=robots, steps=steps)
    rec = Recorded()
    entities = [f"{MAP}/{e}" for e in (
        "world/markers/robots/points", "world/markers/targets/points",
        "world/markers/fov/lines", "monitor/markers/cells/lines", "monitor/density")] + [
        f"/metrics/{m}" for m in ("ospa/total", "cardinality/true", "robots/alive")]
    with InProcessRos(executor="events") as ros:
        _, monitor, _ = start_swarm(ros, tmp_path, scenario)
        viewer = ros.add(ViewerNode(recording=rec, context=ros.context))
        ros.spin_until(lambda: monitor.done, timeout=120)
        last = (steps - 1) * scenario.dt
        ros.spin_until(lambda: all(any(t == last for t, _ in rec.logs[e]) for e in entities),
                       timeout=30)
        viewer.close()
    times = {k * scenario.dt for k in range(steps)}
    for entity in entities:
        assert {t for t, _ in rec.logs[entity]} == times, entity
    # The world's map is flipped once, statically; the layout sent once.
    assert rec.logs[MAP][0][0] is None and rec.blueprints == 1
    # Every robot drawn at every step, and trailed.
    for _, (points,) in rec.logs[f"{MAP}/world/markers/robots/points"]:
        assert len(points.positions.as_arrow_array()) == robots
    # The team state of step 0 is published as the world starts, before the viewer (made
    # after it here) reads /world/robots (volatile); every later one is drawn.
    assert viewer.robots == robots and viewer.steps >= set(range(1, steps))
    # Trails as wide as the map's robots: a 40 m map draws them at 0.4 of the 100 m size.
    from phd_swarm.nodes.markers import marker_size
    assert marker_size(scenario.env) == pytest.approx(0.4)
    assert viewer._trails.radius == pytest.approx(0.5 * view_scene.TRAIL_WIDTH * 0.4)
    assert not viewer.rejected
    # The heat map of step k is the monitor's team PHD image of step k, pixel for pixel.
    by_time = {t: arch for t, arch in rec.logs[f"{MAP}/monitor/density"]}
    for k, image in monitor.images.items():
        expected = view_scene.grid_image(np.asarray(image), (0.0, 0.0), 1.0).rgba
        logged_image = by_time[k * scenario.dt][0]
        assert isinstance(logged_image, rr.Image)
        pixels = np.asarray(logged_image.buffer.as_arrow_array()[0].values).reshape(
            expected.shape)
        np.testing.assert_array_equal(pixels, expected)


def test_robots_grids_are_composed_per_step_and_bad_ones_counted():
    """Two robots' search maps: step k's team layer is their bin-wise maximum.

    It is drawn when a later step arrives (or at close); a grid whose data does not fit is
    counted, not drawn, and the node goes on.
    """
    from rclpy.qos import DurabilityPolicy, QoSProfile

    from phd_swarm.nodes import view_scene
    from phd_swarm.nodes.viewer import MAP, ViewerNode
    from phd_swarm.testing import InProcessRos
    from phd_swarm_msgs.msg import DensityGrid

    def grid(robot: int, step: int, values, width: int = 2) -> DensityGrid:
        msg = DensityGrid(owner_id=robot, step=step, x_min=0.0, y_min=0.0, resolution=1.0,
                          width=width, height=1, data=[float(v) for v in values])
        msg.header.stamp.sec = step
        return msg

    rec = Recorded()
    qos = QoSProfile(depth=10, durability=DurabilityPolicy.VOLATILE)
    with InProcessRos() as ros:
        pub = ros.node("robots")
        writers = {r: pub.create_publisher(DensityGrid, f"/robot_{r}/search_map", qos)
                   for r in (0, 1)}
        viewer = ros.add(ViewerNode(recording=rec, context=ros.context))
        ros.spin_until(lambda: all(w.get_subscription_count() for w in writers.values()),
                       timeout=10)
        def sent(*messages) -> None:
            counts = {t: viewer.counts[t] + viewer.rejected[t] for t in viewer.counts}
            for robot, msg in messages:
                writers[robot].publish(msg)
            want = {f"/robot_{r}/search_map": 0 for r, _ in messages}
            for r, _ in messages:
                want[f"/robot_{r}/search_map"] += 1
            assert ros.spin_until(lambda: all(
                viewer.counts[t] + viewer.rejected[t] == counts.get(t, 0) + n
                for t, n in want.items()), timeout=10)

        sent((0, grid(0, 0, [0.2, 0.0])), (1, grid(1, 0, [0.1, 0.9])))
        assert not rec.logs[f"{MAP}/team/search_map"]            # step 0 may still grow
        sent((1, grid(1, 1, [1.0], width=3)))                    # 3 bins, 1 value: refused
        assert viewer.rejected["/robot_1/search_map"] == 1
        sent((0, grid(0, 1, [0.5, 0.5])))                        # robot 1 has not moved on
        assert not rec.logs[f"{MAP}/team/search_map"]
        sent((0, grid(0, 2, [0.7, 0.7])))      # step 2: step 0 is done, and step 1 (robot 0's)
        drawn = list(rec.logs[f"{MAP}/team/search_map"])
        sent((1, grid(1, 0, [1.0, 1.0])))                        # too late for step 0
        assert viewer._composers["search_map"].late == 1
        viewer.close()
        closed = rec.logs[f"{MAP}/team/search_map"][len(drawn):]
    assert [t for t, _ in drawn] == [0.0, 1.0]
    image = drawn[0][1][0]
    pixels = np.asarray(image.buffer.as_arrow_array()[0].values).reshape(1, 2, 4)
    expected = view_scene.grid_image(np.array([[0.2, 0.9]]), (0.0, 0.0), 1.0).rgba
    np.testing.assert_array_equal(pixels, expected)
    assert [t for t, _ in closed] == [2.0]                       # the rest, at close
