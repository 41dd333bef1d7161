"""Tests for the track layer (Sung & Tokekar Sec. V-F)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.estimators.tracks import TrackLayer


def _covs(n: int, var: float = 1.0) -> np.ndarray:
    return np.broadcast_to(var * np.eye(2), (n, 2, 2)).copy()


def test_ids_persist_and_tracks_confirm_at_the_life_threshold():
    layer = TrackLayer(gate=10.0, confirm_after=3)
    rng = np.random.default_rng(0)
    targets = np.array([[0.0, 0.0], [20.0, 5.0]])
    for k in range(5):
        ids = layer.update(k, targets + rng.normal(0.0, 0.3, targets.shape), _covs(2))
        assert ids.tolist() == [0, 1]
        assert len(layer.confirmed()) == (2 if k >= 2 else 0)
        assert len(layer.tentative()) == (0 if k >= 2 else 2)
    assert [t.life for t in layer.tracks] == [5, 5]
    assert layer.tracks[0].steps == [0, 1, 2, 3, 4]


def test_a_target_outside_every_gate_starts_a_track():
    layer = TrackLayer(gate=10.0)
    layer.update(0, np.array([[0.0, 0.0]]), _covs(1))
    # squared Mahalanobis distance 3.2^2 = 10.24 > 10 with unit covariance
    ids = layer.update(1, np.array([[3.2, 0.0]]), _covs(1))
    assert ids.tolist() == [1]
    ids = layer.update(2, np.array([[3.1, 0.0]]), _covs(1))   # 9.61 <= 10: gated
    assert ids.tolist() == [1]                                # nearest: track 1 at 3.2


def test_the_nearest_of_several_targets_keeps_the_track():
    layer = TrackLayer(gate=10.0)
    layer.update(0, np.array([[0.0, 0.0]]), _covs(1))
    ids = layer.update(1, np.array([[2.0, 0.0], [0.5, 0.0], [-1.0, 0.0]]), _covs(3))
    assert ids[1] == 0                     # 0.5 m away: keeps track 0
    assert sorted(ids[[0, 2]].tolist()) == [1, 2]
    assert layer.tracks[0].life == 2


def test_unobserved_tracks_keep_their_history():
    layer = TrackLayer(gate=10.0, confirm_after=2)
    for k in range(2):
        layer.update(k, np.array([[0.0, 0.0], [50.0, 0.0]]), _covs(2))
    layer.update(2, np.array([[50.2, 0.0]]), _covs(1))
    assert [t.life for t in layer.tracks] == [2, 3]
    assert len(layer.confirmed()) == 2
    np.testing.assert_array_equal(layer.tracks[0].last, [0.0, 0.0])


def test_the_gate_uses_the_target_covariance():
    layer = TrackLayer(gate=4.0)
    layer.update(0, np.array([[0.0, 0.0]]), _covs(1))
    # 5 m away: squared distance 25 with unit covariance, 25 / 9 with variance 9
    assert layer.update(1, np.array([[5.0, 0.0]]), _covs(1, 9.0)).tolist() == [0]
    assert layer.update(2, np.array([[10.0, 0.0]]), _covs(1)).tolist() == [1]


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="gate must be finite and > 0"):
        TrackLayer(gate=0.0)
    with pytest.raises(ValueError, match="confirm_after must be an integer >= 1"):
        TrackLayer(gate=1.0, confirm_after=0)
    layer = TrackLayer(gate=1.0)
    with pytest.raises(ValueError, match="states must be finite"):
        layer.update(0, np.array([[np.nan, 0.0]]), _covs(1))
    with pytest.raises(ValueError, match=r"states must be \(N, d\)"):
        layer.update(0, np.zeros((2, 2)), _covs(1))
    with pytest.raises(ValueError, match="covs must be positive definite"):
        layer.update(0, np.zeros((1, 2)), np.zeros((1, 2, 2)))
    assert layer.update(0, np.empty((0, 2)), np.empty((0, 2, 2))).size == 0


def test_copies_of_one_component_keep_their_own_tracks():
    # A component of weight ~3 is extracted as three targets at one mean (Vo & Ma
    # Table III): after the first step each copy keeps a track of its own.
    layer = TrackLayer(gate=10.0)
    first = layer.update(0, np.zeros((3, 2)), _covs(3))
    for k in range(1, 5):
        ids = layer.update(k, np.full((3, 2), 0.01 * k), _covs(3))
        assert sorted(ids.tolist()) == sorted(first.tolist())
    assert len(layer.tracks) == 3 and len(layer.confirmed()) == 3


def test_a_target_displaced_by_a_nearer_one_takes_its_next_gating_track():
    layer = TrackLayer(gate=10.0)
    layer.update(0, np.array([[0.0, 0.0], [2.0, 0.0]]), _covs(2))
    # Both targets are nearest to track 0; the nearer keeps it, the other takes track 1.
    ids = layer.update(1, np.array([[0.2, 0.0], [0.9, 0.0]]), _covs(2))
    assert ids.tolist() == [0, 1]


def test_a_tracks_window_is_its_last_steps_and_states_as_arrays():
    layer = TrackLayer(gate=10.0)
    for k in range(40):
        layer.update(k, np.array([[0.1 * k, 0.0]]), _covs(1))
    track = layer.tracks[0]
    steps, states = track.window(25)
    np.testing.assert_array_equal(steps, np.arange(15, 40))
    np.testing.assert_array_equal(states, np.stack(track.states[-25:]))
    assert not states.flags.writeable
    assert track.window(100)[0].shape == (40,)
    # Appended to by hand (the lists are public): the arrays follow.
    track.steps.append(40)
    track.states.append(np.array([4.0, 0.0]))
    np.testing.assert_array_equal(track.window(2)[1], [[0.1 * 39, 0.0], [4.0, 0.0]])
