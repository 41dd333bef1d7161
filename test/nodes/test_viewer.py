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
