"""Gaussian mixtures and track sets: exact round trips, and clear errors for bad messages."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.faces.gaussian_mixture import (
    EstimatorView,
    TrackArrays,
    gaussian_mixture,
    mixture_from_ros,
    track_set,
    tracks_from_ros,
)


def _mixture(j: int = 3):
    rng = np.random.default_rng(0)
    a = rng.normal(size=(j, 2, 2))
    covs = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(2)
    return rng.random(j), rng.normal(size=(j, 2)) * 50, covs


def _tracks() -> TrackArrays:
    w, m, c = _mixture(2)
    return TrackArrays(np.array([4, 9]), np.array([5, 1]), np.array([True, False]), w, m, c)


def test_a_mixture_travels_exactly():
    w, m, c = _mixture()
    back = mixture_from_ros(gaussian_mixture(0, 5, w, m, c, 1.0, "map"), 10)
    assert np.array_equal(back.weights, w) and np.array_equal(back.means, m)
    assert np.array_equal(back.covs, c)
    empty = mixture_from_ros(gaussian_mixture(0, 5, np.empty(0), np.empty((0, 2)),
                                              np.empty((0, 2, 2)), 1.0, "map"), 10)
    assert empty.means.shape == (0, 2) and empty.covs.shape == (0, 2, 2)


def test_tracks_travel_exactly_and_read_as_an_estimator():
    t = _tracks()
    back = tracks_from_ros(track_set(0, 5, t, 1.0, "map"), 10)
    for name in ("track_ids", "life", "confirmed", "weights", "positions", "covs"):
        assert np.array_equal(getattr(back, name), getattr(t, name)), name
    w, m, c = _mixture()
    view = EstimatorView(mixture_from_ros(gaussian_mixture(0, 5, w, m, c, 1.0, "map"), 10),
                         back)
    assert np.array_equal(view.targets()[3], [4, 9])
    assert view.confirmed_mask().tolist() == [True, False]


@pytest.mark.parametrize("spoil, field", [
    (lambda msg: setattr(msg, "means", list(msg.means)[:-1]), "means"),
    (lambda msg: setattr(msg, "weights", [np.nan, 1.0, 1.0]), "weights"),
    (lambda msg: setattr(msg, "weights", [-1.0, 1.0, 1.0]), "weights"),
    (lambda msg: setattr(msg, "covariances", [1.0, 2.0, 0.0, 1.0] * 3), "symmetric"),
    (lambda msg: setattr(msg, "covariances", [-1.0, 0.0, 0.0, 1.0] * 3), "positive"),
    (lambda msg: setattr(msg, "dim", 0), "dim"),
])
def test_a_bad_mixture_is_refused_naming_the_field(spoil, field):
    msg = gaussian_mixture(0, 5, *_mixture(), 1.0, "map")
    spoil(msg)
    with pytest.raises(InvalidMessage, match=field):
        mixture_from_ros(msg, 10)
    with pytest.raises(InvalidMessage, match="more than 2"):
        mixture_from_ros(gaussian_mixture(0, 5, *_mixture(), 1.0, "map"), 2)


@pytest.mark.parametrize("spoil, field", [
    (lambda msg: setattr(msg, "life", [1]), "life"),
    (lambda msg: setattr(msg, "confirmed", [True]), "confirmed"),
    (lambda msg: setattr(msg, "weights", [np.inf, 1.0]), "weights"),
    (lambda msg: msg.positions.__setitem__(0, type(msg.positions[0])(x=np.nan)),
     "positions"),
    (lambda msg: setattr(msg, "covariances", [0.0] * 8), "positive"),
])
def test_a_bad_track_set_is_refused_naming_the_field(spoil, field):
    msg = track_set(0, 5, _tracks(), 1.0, "map")
    spoil(msg)
    with pytest.raises(InvalidMessage, match=field):
        tracks_from_ros(msg, 10)


def test_a_reward_set_travels_exactly_and_a_bad_one_is_refused():
    from geometry_msgs.msg import Point

    from phd_swarm.nodes.faces.meet_merge import reward_points, reward_set

    pts = np.array([[1.25, 2.5], [3.0, -0.125]])
    msg = reward_set(4, 7, pts, 1.0, "map", met=[1, 2])
    assert list(msg.met_ids) == [1, 2]
    np.testing.assert_array_equal(reward_points(msg), pts)
    with pytest.raises(InvalidMessage, match="more than 1"):
        reward_points(msg, max_rewards=1)
    msg.positions[1] = Point(x=float("nan"), y=0.0)
    with pytest.raises(InvalidMessage, match="positions"):
        reward_points(msg)
