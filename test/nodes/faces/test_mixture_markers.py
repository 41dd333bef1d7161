"""One robot's markers: 2-sigma ellipses, targets and track ids, DELETEs, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from phd_swarm.nodes.faces.gaussian_mixture import MixtureArrays, TrackArrays
from phd_swarm.nodes.faces.mixture_markers import (
    ELLIPSE_SEGMENTS,
    MAX_COMPONENTS,
    MIN_ALPHA,
    ROBOT_COLOURS,
    RobotMarkers,
    ellipse_vertices,
)
from phd_swarm.nodes.markers import COLOURS, FOV_SEGMENTS

from ..test_markers import FRAME, STAMP
from ..test_markers import check_common as check_shared

NAMESPACES = ["robot_3/robot", "robot_3/fov", "robot_3/components", "robot_3/targets",
              "robot_3/path"]


def by_ns(array: MarkerArray) -> dict[str, list[Marker]]:
    out: dict[str, list[Marker]] = {}
    for m in array.markers:
        out.setdefault(m.ns, []).append(m)
    return out


def one(array: MarkerArray, ns: str) -> Marker:
    (m,) = by_ns(array)[f"robot_3/{ns}"]
    return m


def xy(marker: Marker) -> np.ndarray:
    return np.array([[p.x, p.y] for p in marker.points]).reshape(-1, 2)


def alpha(colours) -> np.ndarray:
    return np.array([c.a for c in colours])


def check_common(array: MarkerArray) -> None:
    check_shared(array)  # unique ids, frame, stamp, actions, z = 0, serialisable
    for m in array.markers:
        assert m.pose.position.z == 0.0
        assert all(np.isfinite([p.x, p.y]).all() for p in m.points)
        assert not m.colors or len(m.colors) == len(m.points)
    back = deserialize_message(serialize_message(array), MarkerArray)
    assert [(m.ns, m.id, m.action, len(m.points), len(m.colors), m.text)
            for m in back.markers] == \
        [(m.ns, m.id, m.action, len(m.points), len(m.colors), m.text) for m in array.markers]


def rotated(cov, deg):
    t = np.radians(deg)
    r = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    return r @ cov @ r.T


def mixture(weights, means, covs):
    return MixtureArrays(np.asarray(weights, float), np.asarray(means, float),
                         np.asarray(covs, float))


def tracks(ids, confirmed, positions):
    n = len(ids)
    return TrackArrays(np.asarray(ids, np.int64), np.full(n, 3, np.int64),
                       np.asarray(confirmed, bool), np.ones(n),
                       np.asarray(positions, float).reshape(n, 2), np.tile(np.eye(2), (n, 1, 1)))


# A 4D state (x, y, vx, vy): only the position block is drawn.
COV4 = np.zeros((4, 4))
COV4[:2, :2] = rotated(np.diag([16.0, 0.25]), 35.0)
COV4[2:, 2:] = np.eye(2)
COV4[:2, 2:] = COV4[2:, :2] = 0.1
MEANS = np.array([[40.0, 60.0, 1.0, 0.0], [-5.0, 3.0, 0.0, 0.0], [90.0, 10.0, 0.0, 1.0]])
COVS = np.stack([COV4, np.diag([1.0, 9.0, 1.0, 1.0]), np.diag([0.5, 0.5, 1.0, 1.0])])
WEIGHTS = np.array([0.9, 0.05, 3.0])


def test_empty_mixture_and_no_tracks_give_valid_markers():
    rm = RobotMarkers(3, FRAME, 25.0)
    empty = mixture(np.empty(0), np.empty((0, 4)), np.empty((0, 4, 4)))
    for mix, trk in ((None, None), (empty, tracks([], [], np.empty((0, 2))))):
        out = rm.build(STAMP, np.array([10.0, 20.0]), mix, trk, np.empty((0, 2)))
        check_common(out)
        assert [m.ns for m in out.markers] == NAMESPACES
        assert all(m.action == Marker.ADD and m.id == 0 for m in out.markers)
        assert len(one(out, "robot").points) == 1
        assert len(one(out, "fov").points) == FOV_SEGMENTS + 1
        assert one(out, "components").points == [] and one(out, "targets").points == []
        assert one(out, "path").points == []  # the robot alone is no line


def test_namespaces_types_colours_and_counts():
    rm = RobotMarkers(3, FRAME, 25.0)
    trk = tracks([7, 11, 12], [True, False, True], [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    path = np.array([[12.5, 12.5], [12.5, 137.5], [0.0, 0.0]])
    out = rm.build(STAMP, np.array([10.0, 20.0]), mixture(WEIGHTS, MEANS, COVS), trk, path)
    check_common(out)
    ns = by_ns(out)
    assert list(ns) == NAMESPACES[:4] + ["robot_3/track_ids", "robot_3/path"]

    robot = one(out, "robot")
    assert robot.type == Marker.SPHERE_LIST
    np.testing.assert_array_equal(xy(robot), [[10.0, 20.0]])
    assert robot.color.b == pytest.approx(COLOURS["robot_alive"][2])

    fov = one(out, "fov")
    assert fov.type == Marker.LINE_STRIP
    ring = xy(fov)
    assert len(ring) == FOV_SEGMENTS + 1 and np.array_equal(ring[0], ring[-1])
    np.testing.assert_allclose(np.hypot(*(ring - [10.0, 20.0]).T), 25.0, rtol=1e-12)

    comps = one(out, "components")
    assert comps.type == Marker.LINE_LIST
    assert len(comps.points) == 3 * 2 * ELLIPSE_SEGMENTS
    # Heaviest first: weights 3.0, 0.9, 0.05 -> alpha 1, 0.9, 0.2 (clipped).
    a = alpha(comps.colors).reshape(3, 2 * ELLIPSE_SEGMENTS)
    np.testing.assert_allclose(a, np.repeat([[1.0], [0.9], [MIN_ALPHA]], 2 * ELLIPSE_SEGMENTS,
                                            axis=1), rtol=1e-6)
    assert comps.colors[0].r == pytest.approx(ROBOT_COLOURS["component"][0])

    targets = one(out, "targets")
    assert targets.type == Marker.SPHERE_LIST
    np.testing.assert_array_equal(xy(targets), trk.positions)
    confirmed, tentative = ROBOT_COLOURS["track_confirmed"], ROBOT_COLOURS["track_tentative"]
    assert [c.g for c in targets.colors] == pytest.approx(
        [confirmed[1], tentative[1], confirmed[1]])

    texts = ns["robot_3/track_ids"]
    assert [(m.id, m.type, m.action, m.text) for m in texts] == [
        (0, Marker.TEXT_VIEW_FACING, Marker.ADD, "7"),
        (1, Marker.TEXT_VIEW_FACING, Marker.ADD, "12")]
    assert texts[1].pose.position.x == 5.0 and texts[1].pose.position.y > 6.0

    line = one(out, "path")
    assert line.type == Marker.LINE_STRIP
    np.testing.assert_array_equal(xy(line), [[10.0, 20.0], *path])


def test_ellipse_points_lie_at_two_sigma():
    rm = RobotMarkers(3, FRAME, 25.0)
    out = rm.build(STAMP, np.zeros(2), mixture(WEIGHTS, MEANS, COVS), None, np.empty((0, 2)))
    pts = xy(one(out, "components")).reshape(3, ELLIPSE_SEGMENTS, 2, 2)
    order = [2, 0, 1]  # heaviest first
    for k, j in enumerate(order):
        # Every point of the LINE_LIST (both ends of every edge) is on the contour.
        d = pts[k].reshape(-1, 2) - MEANS[j, :2]
        inv = np.linalg.inv(COVS[j, :2, :2])
        maha = np.sqrt(np.einsum("na,ab,nb->n", d, inv, d))
        np.testing.assert_allclose(maha, 2.0, rtol=0, atol=1e-9)
        # Closed polygon: each edge ends where the next one starts, the last at the first.
        assert np.array_equal(pts[k, 1:, 0], pts[k, :-1, 1])
        assert np.array_equal(pts[k, -1, 1], pts[k, 0, 0])
    # The rotated anisotropic one spans 2 sigma = 8 m along its 35 degree axis.
    span = pts[1].reshape(-1, 2) - MEANS[0, :2]
    axis = np.array([np.cos(np.radians(35.0)), np.sin(np.radians(35.0))])
    assert np.max(span @ axis) == pytest.approx(8.0, rel=1e-12)
    assert np.max(span @ [-axis[1], axis[0]]) == pytest.approx(1.0, rel=0.01)


def test_ellipse_vertices_vectorised_matches_each_component():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(50, 2, 2))
    covs = a @ a.transpose(0, 2, 1) + 0.01 * np.eye(2)
    means = rng.uniform(0.0, 100.0, (50, 2))
    v = ellipse_vertices(means, covs)
    assert v.shape == (50, ELLIPSE_SEGMENTS, 2)
    d = v - means[:, None, :]
    maha = np.einsum("jsa,jab,jsb->js", d, np.linalg.inv(covs), d)
    np.testing.assert_allclose(np.sqrt(maha), 2.0, atol=1e-9)
    assert ellipse_vertices(np.empty((0, 2)), np.empty((0, 2, 2))).shape == \
        (0, ELLIPSE_SEGMENTS, 2)


def test_components_are_capped_heaviest_first():
    j = MAX_COMPONENTS + 50
    w = np.arange(j, dtype=float)  # the heaviest are the last
    means = np.column_stack([np.arange(j, dtype=float), np.zeros(j)])
    out = RobotMarkers(3, FRAME, 25.0).build(
        STAMP, np.zeros(2), mixture(w, means, np.tile(np.eye(2), (j, 1, 1))), None,
        np.empty((0, 2)))
    pts = xy(one(out, "components")).reshape(MAX_COMPONENTS, -1, 2)
    centres = pts.mean(axis=1)
    np.testing.assert_allclose(centres[:, 0], np.arange(j - 1, 49, -1), atol=1e-9)


def test_ids_are_fixed_and_stale_track_ids_are_deleted():
    rm = RobotMarkers(3, FRAME, 25.0)
    mix = mixture(WEIGHTS, MEANS, COVS)

    def step(ids, confirmed):
        pos = np.column_stack([np.arange(len(ids), dtype=float), np.ones(len(ids))])
        out = rm.build(STAMP, np.array([1.0, 1.0]), mix, tracks(ids, confirmed, pos),
                       np.array([[5.0, 5.0]]))
        check_common(out)
        return out, [(m.id, m.action, m.text) for m in by_ns(out).get("robot_3/track_ids", [])]

    first, texts = step([4, 5, 6, 9], [True, True, True, True])
    assert texts == [(0, Marker.ADD, "4"), (1, Marker.ADD, "5"), (2, Marker.ADD, "6"),
                     (3, Marker.ADD, "9")]
    second, texts = step([5, 9, 10], [True, False, True])  # 2 confirmed: ids 2, 3 go
    assert texts == [(0, Marker.ADD, "5"), (1, Marker.ADD, "10"),
                     (2, Marker.DELETE, ""), (3, Marker.DELETE, "")]
    # Every other marker keeps its (ns, id) from call to call, action ADD.
    lists = [(m.ns, m.id, m.action) for m in first.markers if "track_ids" not in m.ns]
    assert lists == [(m.ns, m.id, m.action) for m in second.markers
                     if "track_ids" not in m.ns]
    _, texts = step([5, 9, 10], [True, False, True])  # deleted once, not again
    assert texts == [(0, Marker.ADD, "5"), (1, Marker.ADD, "10")]
    _, texts = step([], [])
    assert texts == [(0, Marker.DELETE, ""), (1, Marker.DELETE, "")]
    _, texts = step([], [])
    assert texts == []


def test_non_finite_inputs_are_left_out():
    rm = RobotMarkers(3, FRAME, 25.0)
    means = MEANS.copy()
    means[1, 0] = np.nan
    covs = COVS.copy()
    covs[2, 0, 0] = np.inf
    weights = np.array([0.9, 0.05, 3.0, np.nan, 1.0])
    means = np.vstack([means, [[1.0, 1.0, 0.0, 0.0], [2.0, 2.0, 0.0, 0.0]]])
    bad = np.diag([-1.0, 1.0, 1.0, 1.0])  # negative variance: no real ellipse
    covs = np.concatenate([covs, [COV4, bad]])
    trk = tracks([1, 2, 3], [True, True, False],
                 [[np.nan, 2.0], [3.0, 4.0], [5.0, np.inf]])
    path = np.array([[1.0, 1.0], [np.nan, 0.0], [2.0, 2.0]])
    out = rm.build(STAMP, np.array([10.0, 20.0]), mixture(weights, means, covs), trk, path)
    check_common(out)
    comps = one(out, "components")
    assert len(comps.points) == 1 * 2 * ELLIPSE_SEGMENTS  # only component 0 is drawable
    np.testing.assert_allclose(xy(comps).mean(axis=0), MEANS[0, :2], atol=1e-9)
    np.testing.assert_array_equal(xy(one(out, "targets")), [[3.0, 4.0]])
    assert [m.text for m in by_ns(out).get("robot_3/track_ids", [])] == ["2"]
    np.testing.assert_array_equal(xy(one(out, "path")), [[10.0, 20.0], [1.0, 1.0],
                                                          [2.0, 2.0]])

    lost = rm.build(STAMP, np.array([np.nan, 20.0]), None, None, path)
    check_common(lost)
    assert one(lost, "robot").points == [] and one(lost, "fov").points == []
    np.testing.assert_array_equal(xy(one(lost, "path")), [[1.0, 1.0], [2.0, 2.0]])


def test_zero_radius_draws_no_fov_and_bad_arguments_raise():
    out = RobotMarkers(3, FRAME, 0.0).build(STAMP, np.zeros(2), None, None, np.empty((0, 2)))
    assert one(out, "fov").points == []
    for radius in (-1.0, np.inf, np.nan):
        with pytest.raises(ValueError, match="fov_radius"):
            RobotMarkers(3, FRAME, radius)
    rm = RobotMarkers(3, FRAME, 25.0)
    with pytest.raises(ValueError, match="mixture"):
        rm.build(STAMP, np.zeros(2), mixture([1.0], [[1.0]], [[[1.0]]]), None,
                 np.empty((0, 2)))
    with pytest.raises(ValueError, match="tracks"):
        rm.build(STAMP, np.zeros(2), None,
                 TrackArrays(np.arange(2), np.ones(3), np.ones(3, bool), np.ones(3),
                             np.zeros((3, 2)), np.tile(np.eye(2), (3, 1, 1))),
                 np.empty((0, 2)))


def test_a_large_marker_array_serialises():
    rng = np.random.default_rng(0)
    j, n = 100, 20
    a = rng.normal(size=(j, 4, 4))
    mix = mixture(rng.uniform(0.0, 1.5, j), rng.uniform(0.0, 150.0, (j, 4)),
                  a @ a.transpose(0, 2, 1) + np.eye(4))
    trk = tracks(np.arange(n), np.arange(n) % 2 == 0, rng.uniform(0.0, 150.0, (n, 2)))
    out = RobotMarkers(3, FRAME, 25.0).build(STAMP, np.array([75.0, 75.0]), mix, trk,
                                             rng.uniform(0.0, 150.0, (15, 2)))
    check_common(out)
    assert len(one(out, "components").points) == j * 2 * ELLIPSE_SEGMENTS
    assert len(out.markers) == 5 + n // 2


def test_a_reward_set_is_drawn_as_cubes_when_given():
    markers = RobotMarkers(3, FRAME, 0.6)
    without = markers.build(STAMP, np.zeros(2), None, None, np.empty((0, 2)))
    assert "robot_3/rewards" not in by_ns(without)
    array = markers.build(STAMP, np.zeros(2), None, None, np.empty((0, 2)),
                          rewards=np.array([[1.0, 2.0], [np.nan, 0.0], [3.0, 4.0]]))
    check_common(array)
    reward = one(array, "rewards")
    assert reward.type == Marker.CUBE_LIST
    np.testing.assert_array_equal(xy(reward), [[1.0, 2.0], [3.0, 4.0]])
