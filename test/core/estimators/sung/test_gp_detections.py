"""Sung & Tokekar's GP fed by detections (issue 34): the association rule and the history."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core import registry
from phd_swarm.core.estimators.sung.estimator import SungEstimator
from phd_swarm.core.estimators.sung.gp_detections import DetectionHistories, majority_measurement
from phd_swarm.core.estimators.sung.gp_motion import predict_tracks
from phd_swarm.core.scan import Scan
from phd_swarm.sim.presets import sung_tokekar

# ---------------------------------------------------------------- the association rule


def test_a_component_is_a_measurements_when_it_is_mostly_made_of_it():
    shares = np.array([[1.9, 0.0],      # a detected target: its detection term and newborn
                       [0.0, 0.0],      # out of view: missed-detection terms only
                       [0.3, 0.05],     # mostly missed mass, a little of each measurement
                       [0.0, 1.0],      # a newborn on its own
                       [0.5, 0.0]])     # exactly half: not more than half
    weights = np.array([1.95, 2.0, 1.0, 1.0, 1.0])
    assert majority_measurement(shares, weights).tolist() == [0, -1, -1, 1, -1]
    assert majority_measurement(np.empty((3, 0)), np.ones(3)).tolist() == [-1, -1, -1]
    with pytest.raises(ValueError, match=r"shares must have shape \(2, M\)"):
        majority_measurement(np.zeros((3, 1)), np.ones(2))


def test_detection_histories_append_per_track_and_refuse_repeats():
    h = DetectionHistories()
    h.record(4, np.array([2, 0]), np.array([[1.0, 2.0], [3.0, 4.0]]))
    h.record(7, np.array([2]), np.array([[1.5, 2.5]]))
    assert (h.count(2), h.count(0), h.count(9)) == (2, 1, 0)
    steps, pos = h.window(2, 10)
    np.testing.assert_array_equal(steps, [4.0, 7.0])
    np.testing.assert_array_equal(pos, [[1.0, 2.0], [1.5, 2.5]])
    assert h.history(9) == ([], [])
    with pytest.raises(ValueError, match="at most one detection per step"):
        h.record(8, np.array([1, 1]), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="step 7 is not after its last detection"):
        h.record(7, np.array([2]), np.zeros((1, 2)))


# ---------------------------------------------------------------- through the estimator

#: One target moving 0.5, 0.25 m a step, seen without noise for six steps from 3 m away,
#: then four steps with the robot 200 m away (out of the 25 m FoV: p_D ~ 0).
SEEN, UNSEEN = range(6), range(6, 10)
VELOCITY = np.array([0.5, 0.25])
GP = {"gp_prediction": True, "gp_signal_sd": 10.0, "gp_length_scale": 20.0,
      "gp_noise_sd": 0.5, "gp_window": 10}


def _estimator(**options) -> SungEstimator:
    sc = sung_tokekar(targets=1).with_system(options={
        "false_positive_prob": 0.0, "initial_belief": "none", **GP, **options})
    return SungEstimator(registry.lookup("estimator", "sung_gmphd").setup(sc, sc.system))


def _run(est: SungEstimator, clutter_at: int | None = None) -> np.ndarray:
    """Run the steps above; returns the track's target position after each step (10, 2)."""
    x0 = np.array([60.0, 70.0])
    out = []
    for k in [*SEEN, *UNSEEN]:
        est.predict()
        if k in SEEN:
            scan = Scan(0, k, x0 + k * VELOCITY + [3.0, 0.0], (x0 + k * VELOCITY)[None])
        else:
            sensor = x0 + [200.0, 0.0]
            z = (sensor + [1.0, 1.0])[None] if k == clutter_at else np.empty((0, 2))
            scan = Scan(0, k, sensor, z)
        est.update(scan)
        targets, _, _, ids = est.targets()
        out.append(targets[ids == 0][0])
    return np.array(out)


def test_a_track_out_of_view_is_predicted_from_its_detections_not_its_predictions():
    x0 = np.array([60.0, 70.0])
    z = x0 + np.arange(6)[:, None] * VELOCITY
    est = _estimator(gp_input="detections")
    positions = _run(est, clutter_at=8)
    assert est.confirmed_mask()[est.targets()[3] == 0].all()
    # The detection history is the six measurements at their steps, nothing else: the
    # four steps out of view (and the false positive at step 8, far from the track: its
    # own newborn, its own track) add nothing to it.
    steps, history = est.detections.history(0)
    assert steps == list(SEEN)
    np.testing.assert_array_equal(np.array(history), z)
    assert est.detections.history(1)[0] == [8] and est.tracks.tracks[1].steps == [8]
    # Out of view the component is eq. 8 at step k on those six points: the GP
    # extrapolates in time from the last detection steps (p_D ~ 0 leaves the mean as
    # predicted).
    for k in UNSEEN:
        want = predict_tracks([(np.arange(6.0), z)], float(k), est.setup.gp)[0]
        np.testing.assert_allclose(positions[k], want, rtol=0, atol=1e-9)
    # The track layer still associates the extracted targets (its life counts them).
    track = est.tracks.tracks[0]
    assert track.steps == list(range(10))
    np.testing.assert_array_equal(np.array(track.states[6:]), positions[6:])


def test_fed_by_estimates_the_history_holds_the_tracks_own_predictions():
    est = _estimator()                                      # gp_input: estimates
    assert est.detections is None
    positions = _run(est)
    track = est.tracks.tracks[0]
    assert track.steps == list(range(10))
    # Each prediction out of view is eq. 8 on the history up to the step before, which
    # holds the predictions of the steps before it.
    for k in UNSEEN:
        steps = np.array(track.steps[:k], dtype=float)
        states = np.array(track.states[:k])
        want = predict_tracks([(steps, states)], float(k), est.setup.gp)[0]
        np.testing.assert_allclose(positions[k], want, rtol=0, atol=1e-9)
    # Fed by detections, the same steps give other positions (the history there is the
    # six measurements alone).
    other = _run(_estimator(gp_input="detections"))
    assert np.abs(other[6:] - positions[6:]).min() > 1e-3


def test_export_import_round_trip_carries_the_mixture_and_keeps_the_histories():
    # What sung_gmphd exports is its components (its exchange is `none`: nothing travels);
    # the track layer and the detection histories are the robot's own and stay.
    est = _estimator(gp_input="detections")
    _run(est)
    arrays = est.export_state()
    assert set(arrays) == {"weights", "means", "covs"}
    other = _estimator(gp_input="detections")
    other.import_state(arrays)
    for key, value in other.export_state().items():
        assert np.array_equal(value, arrays[key])
    before = est.detections.history(0)
    est.import_state(arrays)
    after = est.detections.history(0)
    assert after[0] == before[0]
    np.testing.assert_array_equal(np.array(after[1]), np.array(before[1]))


def test_a_confirmed_track_never_detected_keeps_the_linear_model():
    # A component of the initial belief, extracted and confirmed out of view, never seen.
    est = _estimator(gp_input="detections", initial_belief="exact", initial_variance=4.0)
    far = est.mixture.means[0] + [300.0, 0.0]
    for k in range(5):
        before = est.mixture.means.copy()
        est.predict()
        np.testing.assert_array_equal(est.mixture.means, before)    # F = I
        est.update(Scan(0, k, far, np.empty((0, 2))))
    assert est.confirmed_mask().all() and est.detections.count(0) == 0
