"""What the live view draws from messages (phd_swarm.nodes.view_scene): pure functions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from nav_msgs.msg import OccupancyGrid
from rclpy.serialization import serialize_message
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.nodes import cdr
from phd_swarm.nodes import view_scene as scene
from phd_swarm.nodes.markers import COLOURS, FOV_SEGMENTS, world_markers_cdr
from phd_swarm_msgs.msg import DensityGrid, TeamMetrics

STAMP = Time(sec=3, nanosec=500_000_000)


def decoded_world(positions, alive, targets) -> dict:
    data = world_markers_cdr(STAMP, "map", np.asarray(positions, float), np.asarray(alive),
                             5.0, np.asarray(targets, float).reshape(-1, 2))
    return cdr.decode(MarkerArray, data)


def by_path(shapes) -> dict[str, scene.Shape]:
    return {s.path: s for s in shapes}


def test_world_markers_become_points_lines_and_labels():
    msg = decoded_world([[10.0, 20.0], [30.0, 40.0]], [True, False], [[1.0, 2.0]])
    shapes = by_path(scene.marker_shapes(msg))
    assert set(shapes) == {"robots/points", "robot_ids/labels", "fov/lines",
                           "targets/points"}
    robots = shapes["robots/points"]
    np.testing.assert_allclose(robots.positions, [[10, 20], [30, 40]])
    blue = np.rint(255 * np.array(COLOURS["robot_alive"])).astype(np.uint8)
    np.testing.assert_array_equal(robots.colours[0], blue)
    assert robots.colours[1][3] < 255                 # the dead one translucent
    np.testing.assert_allclose(robots.radii, 0.5)      # half the 1 m sphere
    assert sorted(shapes["robot_ids/labels"].labels) == ["0", "1"]
    # One pair of points per FOV edge, of the live robot only, on its 5 m circle.
    fov = shapes["fov/lines"]
    assert len(fov.strips) == FOV_SEGMENTS
    ends = np.concatenate(fov.strips)
    np.testing.assert_allclose(np.hypot(*(ends - [10, 20]).T), 5.0, atol=1e-9)
    np.testing.assert_allclose(shapes["targets/points"].positions, [[1, 2]])
    assert scene.stamp_seconds(msg["markers"][0]["header"]) == 3.5


def marker(**fields) -> Marker:
    m = Marker(**{"ns": "things", "id": 0, "action": Marker.ADD, **fields})
    m.pose.orientation.w = 1.0
    return m


def shapes_of(*markers: Marker) -> list[scene.Shape]:
    return scene.marker_shapes(cdr.decode(MarkerArray, serialize_message(
        MarkerArray(markers=list(markers)))))


def test_pose_places_the_points_and_non_finite_ones_are_left_out():
    m = marker(type=Marker.SPHERE_LIST, points=[Point(x=1.0), Point(x=math.nan)],
               color=ColorRGBA(r=1.0, a=1.0))
    m.scale.x = 2.0
    m.pose.position.x, m.pose.position.y = 10.0, 5.0
    m.pose.orientation.z, m.pose.orientation.w = math.sin(math.pi / 4), math.cos(math.pi / 4)
    (points,) = shapes_of(m)
    np.testing.assert_allclose(points.positions, [[10.0, 6.0]], atol=1e-12)  # (1, 0) by 90 deg
    np.testing.assert_allclose(points.radii, [1.0])
    np.testing.assert_array_equal(points.colours, [[255, 0, 0, 255]])


def test_line_strip_and_line_list():
    strip = marker(type=Marker.LINE_STRIP, points=[Point(x=0.0), Point(x=1.0), Point(y=1.0)])
    pairs = marker(type=Marker.LINE_LIST, id=1,
                   points=[Point(x=0.0), Point(x=1.0), Point(y=2.0), Point(y=3.0), Point()])
    (lines,) = shapes_of(strip, pairs)
    assert lines.path == "things/lines"
    assert [len(s) for s in lines.strips] == [3, 2, 2]    # the odd last point is dropped


def test_delete_and_delete_all_clear():
    gone = marker(type=Marker.SPHERE_LIST, action=Marker.DELETE)
    assert [(s.path, s.kind) for s in shapes_of(gone)] == [("things", "clear")]
    everything = Marker(action=Marker.DELETEALL)
    kept = marker(type=Marker.SPHERE_LIST, points=[Point()])
    assert [(s.path, s.kind) for s in shapes_of(marker(type=Marker.CUBE_LIST), everything,
                                                kept)] == [("", "clear"), ("things/points",
                                                                           "points")]


def test_density_window_image_is_placed_on_the_map():
    grid = DensityGrid(x_min=-50.0, y_min=-50.0, resolution=2.0, origin_col=3, origin_row=1,
                       width=2, height=3, data=[0.0, 0.01, 0.04, 0.25, 1.0, 4.0])
    values, origin, res = scene.density_values(cdr.decode(DensityGrid,
                                                          serialize_message(grid)))
    assert values.shape == (3, 2) and origin == (-44.0, -48.0) and res == 2.0
    image = scene.grid_image(values, origin, res)
    assert image.rgba.shape == (3, 2, 4) and (image.rgba[..., 3] == 255).all()
    # sqrt colour scale, clipped at 1: 1.0 and 4.0 are the same colour, 0.25 is half-way.
    np.testing.assert_array_equal(image.rgba[2, 0], image.rgba[2, 1])
    assert not np.array_equal(image.rgba[0, 0], image.rgba[1, 1])
    bad = cdr.decode(DensityGrid, serialize_message(DensityGrid(width=2, height=2,
                                                                data=[1.0])))
    with pytest.raises(ValueError, match="2 x 2 bins holds 1 values"):
        scene.density_values(bad)


def test_occupancy_grid_reads_0_to_100():
    grid = OccupancyGrid()
    grid.info.width, grid.info.height, grid.info.resolution = 2, 1, 0.5
    grid.info.origin.position.x = 7.0
    grid.data = [-1, 100]
    image = scene.occupancy_image(cdr.decode(OccupancyGrid, serialize_message(grid)))
    assert image.origin == (7.0, 0.0) and image.resolution == 0.5
    full = scene.grid_image(np.array([[0.0, 1.0]]), (0.0, 0.0), 1.0)
    np.testing.assert_array_equal(image.rgba, full.rgba)


def test_metrics_leave_out_nan():
    msg = cdr.decode(TeamMetrics, serialize_message(TeamMetrics(
        ospa=3.0, ospa_localisation=math.nan, cardinality_true=4, robots_alive=2)))
    out = scene.metric_scalars(msg)
    assert out["ospa/total"] == 3.0 and out["cardinality/true"] == 4.0
    assert "ospa/localisation" not in out and out["robots/alive"] == 2.0


def test_trails_keep_the_last_steps_of_each_robot():
    trails = scene.Trails(steps=3)
    assert trails.add([5, 2], [[0, 0], [1, 1]]).strips == []       # one position each
    shape = trails.add([2, 5], [[1, 2], [0, 1]])
    assert len(shape.strips) == 2 and trails.robots == 2
    trails.add([5, 2, 9], [[0, 2], [1, 3], [9, 9]])                 # robot 9 joins
    shape = trails.add([5, 2, 9], [[0, 3], [math.nan, math.nan], [9, 8]])
    by_start = {tuple(s[-1]): s for s in shape.strips}
    np.testing.assert_allclose(by_start[(0.0, 3.0)], [[0, 1], [0, 2], [0, 3]])  # 3 steps
    np.testing.assert_allclose(by_start[(1.0, 3.0)], [[1, 2], [1, 3]])   # NaN left out
    np.testing.assert_allclose(by_start[(9.0, 8.0)], [[9, 9], [9, 8]])


def test_large_grids_are_reduced_by_their_maximum():
    values = np.zeros((1000, 999))
    values[0, 998] = 0.5                                   # a peak at the last column
    reduced, f = scene.reduce_grid(values)
    assert f == 2 and reduced.shape == (500, 500) and reduced.size <= scene.MAX_IMAGE_BINS
    assert reduced[0, 499] == 0.5 and reduced.sum() == 0.5
    image = scene.grid_image(values, (1.0, 2.0), 0.1)
    assert image.rgba.shape == (500, 500, 4) and image.resolution == pytest.approx(0.2)
    small = np.ones((3, 4))
    assert scene.reduce_grid(small)[1] == 1 and scene.reduce_grid(small, limit=3)[0].shape \
        == (1, 2)
