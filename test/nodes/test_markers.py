"""Marker builders: point counts, colours, headers, ids, serialisation, empty inputs."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.nodes import markers
from phd_swarm.nodes.markers import COLOURS, FOV_SEGMENTS, team_markers, world_markers

STAMP = Time(sec=12, nanosec=500_000_000)
FRAME = "map"


def by_ns(array: MarkerArray) -> dict[str, list[Marker]]:
    out: dict[str, list[Marker]] = {}
    for m in array.markers:
        out.setdefault(m.ns, []).append(m)
    return out


def xy(marker: Marker) -> np.ndarray:
    return np.array([[p.x, p.y, p.z] for p in marker.points]).reshape(-1, 3)


def rgba(colour) -> tuple[float, ...]:
    return tuple(np.float32(v) for v in (colour.r, colour.g, colour.b, colour.a))


def expected(name: str) -> tuple[float, ...]:
    return tuple(np.float32(v) for v in COLOURS[name])


def check_common(array: MarkerArray) -> None:
    keys = [(m.ns, m.id) for m in array.markers]
    assert len(keys) == len(set(keys)), "marker (ns, id) pairs must be unique"
    for m in array.markers:
        assert m.header.frame_id == FRAME
        assert (m.header.stamp.sec, m.header.stamp.nanosec) == (12, 500_000_000)
        assert m.action in (Marker.ADD, Marker.DELETE)
        assert all(p.z == 0.0 for p in m.points)
    data = serialize_message(array)
    back = deserialize_message(data, MarkerArray)
    assert [(m.ns, m.id, len(m.points)) for m in back.markers] == \
        [(m.ns, m.id, len(m.points)) for m in array.markers]


@pytest.fixture
def world():
    positions = np.array([[10.0, 10.0], [50.0, 20.0], [90.0, 80.0]])
    alive = np.array([True, False, True])
    targets = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0], [7.0, 8.0]])
    return world_markers(STAMP, FRAME, positions, alive, 5.0, targets)


def test_world_namespaces_types_and_counts(world):
    check_common(world)
    ns = by_ns(world)
    assert set(ns) == {"robots", "robot_ids", "fov", "targets"}
    (robots,) = ns["robots"]
    assert robots.type == Marker.SPHERE_LIST and len(robots.points) == 3
    assert [m.type for m in ns["robot_ids"]] == [Marker.TEXT_VIEW_FACING] * 3
    assert [m.text for m in ns["robot_ids"]] == ["0", "1", "2"]
    assert [m.id for m in ns["robot_ids"]] == [0, 1, 2]
    (fov,) = ns["fov"]
    # Only the two live robots have a field of view: FOV_SEGMENTS edges, 2 points each.
    assert fov.type == Marker.LINE_LIST
    assert len(fov.points) == 2 * 2 * FOV_SEGMENTS
    (cubes,) = ns["targets"]
    assert cubes.type == Marker.CUBE_LIST
    np.testing.assert_array_equal(xy(cubes)[:, :2], [[1, 2], [3, 4], [5, 6], [7, 8]])


def test_world_colours_alive_and_dead(world):
    (robots,) = by_ns(world)["robots"]
    assert len(robots.colors) == len(robots.points)
    assert [rgba(c) for c in robots.colors] == [expected("robot_alive"),
                                                expected("robot_dead"),
                                                expected("robot_alive")]


def test_fov_is_a_closed_polygon_on_the_sensing_circle(world):
    (fov,) = by_ns(world)["fov"]
    pts = xy(fov)[:, :2].reshape(2, FOV_SEGMENTS, 2, 2)   # robot, edge, end, xy
    for centre, edges in zip([[10.0, 10.0], [90.0, 80.0]], pts, strict=True):
        np.testing.assert_allclose(np.linalg.norm(edges - centre, axis=-1), 5.0)
        # Each edge ends where the next starts, the last one where the first starts.
        np.testing.assert_allclose(edges[:, 1], np.roll(edges[:, 0], -1, axis=0))


def test_world_ids_and_non_finite_positions():
    positions = np.array([[1.0, 1.0], [np.nan, 2.0]])
    out = world_markers(STAMP, FRAME, positions, [True, True], 5.0, [[np.inf, 0.0]],
                        ids=[7, 9])
    check_common(out)
    ns = by_ns(out)
    assert len(ns["robots"][0].points) == 1 and len(ns["robots"][0].colors) == 1
    assert [(m.id, m.action, m.text) for m in ns["robot_ids"]] == \
        [(7, Marker.ADD, "7"), (9, Marker.DELETE, "")]
    assert len(ns["fov"][0].points) == 2 * FOV_SEGMENTS
    assert len(ns["targets"][0].points) == 0


def test_world_empty_inputs():
    out = world_markers(STAMP, FRAME, np.zeros((0, 2)), np.zeros(0, bool), 5.0,
                        np.zeros((0, 2)))
    check_common(out)
    assert [(m.ns, len(m.points)) for m in out.markers] == \
        [("robots", 0), ("fov", 0), ("targets", 0)]


def test_world_rejects_inconsistent_inputs():
    with pytest.raises(ValueError, match="alive"):
        world_markers(STAMP, FRAME, np.zeros((2, 2)), [True], 5.0, np.zeros((0, 2)))
    with pytest.raises(ValueError, match="fov_radius"):
        world_markers(STAMP, FRAME, np.zeros((1, 2)), [True], -1.0, np.zeros((0, 2)))


def test_team_counts_and_geometry():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    pentagon = np.array([[5.0, 5.0], [7.0, 5.0], [8.0, 6.0], [6.0, 8.0], [4.0, 6.0]])
    cells = {3: pentagon, 1: square, 4: np.array([[0.0, 0.0], [1.0, 1.0]])}
    positions = {1: np.array([0.5, 0.5]), 3: np.array([6.0, 6.0]), 9: np.array([1.0, 1.0])}
    goals = {1: np.array([0.6, 0.4]), 3: np.array([6.5, 6.2]), 5: np.array([2.0, 2.0])}
    estimates = np.array([[1.0, 1.0], [2.0, 2.0]])
    out = team_markers(STAMP, FRAME, cells, positions, goals, estimates)
    check_common(out)
    ns = by_ns(out)
    assert set(ns) == {"cells", "goals", "estimates"}
    (edges,) = ns["cells"]
    assert edges.type == Marker.LINE_LIST
    # 4 + 5 edges, 2 points each; the 2-vertex cell is not a polygon and is left out.
    assert len(edges.points) == 2 * (4 + 5)
    seg = xy(edges)[:, :2].reshape(-1, 2, 2)
    np.testing.assert_array_equal(seg[:4, 0], square)               # id order: 1 then 3
    np.testing.assert_array_equal(seg[:4, 1], np.roll(square, -1, axis=0))
    np.testing.assert_array_equal(seg[4:, 1], np.roll(pentagon, -1, axis=0))
    spheres, lines = ns["goals"]
    assert (spheres.id, spheres.type, len(spheres.points)) == (0, Marker.SPHERE_LIST, 3)
    assert (lines.id, lines.type) == (1, Marker.LINE_LIST)
    # Robots 1 and 3 have both a position and a goal.
    np.testing.assert_array_equal(xy(lines)[:, :2],
                                  [[0.5, 0.5], [0.6, 0.4], [6.0, 6.0], [6.5, 6.2]])
    (found,) = ns["estimates"]
    assert found.type == Marker.SPHERE_LIST and len(found.points) == 2
    assert rgba(found.color) == expected("estimate")


def test_team_empty_inputs():
    out = team_markers(STAMP, FRAME, {}, {}, {}, np.zeros((0, 2)))
    check_common(out)
    assert [(m.ns, m.id, len(m.points)) for m in out.markers] == \
        [("cells", 0, 0), ("goals", 0, 0), ("goals", 1, 0), ("estimates", 0, 0)]


def test_team_grid_and_meetings():
    nodes = np.array([[0.0, 0.0], [0.5, 0.0], [np.nan, 1.0], [0.5, 0.5]])
    positions = {0: np.array([0.5, 0.5]), 2: np.array([0.5, 0.5]), 3: np.array([0.0, 0.0])}
    out = team_markers(STAMP, FRAME, {}, positions, {}, np.zeros((0, 2)), grid_nodes=nodes,
                       meeting_ids=[2, 0, 7])
    check_common(out)
    ns = by_ns(out)
    (grid,) = ns["grid"]
    assert (grid.type, grid.scale.x) == (Marker.POINTS, markers.GRID_NODE_SIZE)
    np.testing.assert_array_equal(xy(grid)[:, :2], nodes[[0, 1, 3]])
    (meet,) = ns["meetings"]
    assert meet.type == Marker.SPHERE_LIST and rgba(meet.color) == expected("meeting")
    # Robots 0 and 2 met on one node; robot 7 has no position and is left out.
    np.testing.assert_array_equal(xy(meet)[:, :2], [[0.5, 0.5], [0.5, 0.5]])
    quiet = team_markers(STAMP, FRAME, {}, positions, {}, np.zeros((0, 2)), meeting_ids=[])
    assert [(m.ns, len(m.points)) for m in quiet.markers][-1] == ("meetings", 0)
    assert "grid" not in by_ns(quiet)


def test_fixed_ids_across_calls():
    rng = np.random.default_rng(3)

    def keys() -> list[tuple[str, int]]:
        pos = rng.random((5, 2)) * 100
        w = world_markers(STAMP, FRAME, pos, rng.random(5) > 0.5, 5.0, rng.random((4, 2)))
        t = team_markers(STAMP, FRAME, {i: pos[i] + rng.random((6, 2)) for i in range(5)},
                         dict(enumerate(pos)), dict(enumerate(pos + 1)), rng.random((3, 2)))
        return [(m.ns, m.id) for m in [*w.markers, *t.markers]]

    assert keys() == keys()


def test_sizes_are_metres():
    w = by_ns(world_markers(STAMP, FRAME, [[0.0, 0.0]], [True], 5.0, [[1.0, 1.0]]))
    assert w["robots"][0].scale.x == markers.ROBOT_DIAMETER
    assert w["fov"][0].scale.x == markers.FOV_LINE_WIDTH
    assert w["robot_ids"][0].scale.z == markers.ROBOT_ID_HEIGHT


def test_sizes_scale_with_the_map():
    from phd_swarm.core.geometry.grid import Environment

    assert markers.marker_size(Environment(0.0, 0.0, 100.0, 100.0)) == 1.0
    small = markers.marker_size(Environment(0.0, 0.0, 5.0, 2.0))
    assert small == 0.05
    pos, targets = np.array([[1.0, 1.0]]), np.array([[2.0, 2.0]])
    one = by_ns(world_markers(STAMP, FRAME, pos, [True], 1.0, targets))
    scaled = by_ns(world_markers(STAMP, FRAME, pos, [True], 1.0, targets, size=small))
    for ns in ("robots", "fov", "targets", "robot_ids"):
        np.testing.assert_allclose([scaled[ns][0].scale.x, scaled[ns][0].scale.z],
                                   [small * one[ns][0].scale.x, small * one[ns][0].scale.z],
                                   err_msg=ns)
        assert max(one[ns][0].scale.x, one[ns][0].scale.z) > 0, ns
    assert scaled["robot_ids"][0].pose.position.y == pytest.approx(
        1.0 + small * markers.ROBOT_ID_OFFSET)
    team = by_ns(team_markers(STAMP, FRAME, {}, {0: pos[0]}, {0: targets[0]}, targets,
                              meeting_ids=[0], size=small))
    assert team["goals"][0].scale.x == pytest.approx(small * markers.GOAL_DIAMETER)
    assert team["meetings"][0].scale.x == pytest.approx(small * markers.MEETING_DIAMETER)
