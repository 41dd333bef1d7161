"""Tests for the GM-PHD estimator and its measurement-driven birth rules."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from phd_swarm.core.estimators.base import Estimator
from phd_swarm.core.estimators.gm_phd.births import AdaptiveBirth, PerMeasurementBirth
from phd_swarm.core.estimators.gm_phd.estimator import GmPhdEstimator, LinearMeasurement
from phd_swarm.core.estimators.gm_phd.filter import GaussianMixture, GmPhdModel, constant_p_d
from phd_swarm.core.scan import Scan


def _static_model(**kw) -> GmPhdModel:
    args = dict(F=np.eye(2), Q=0.01 * np.eye(2), H=np.eye(2), R=0.25 * np.eye(2), p_s=1.0,
                birth_weights=np.empty(0), birth_means=np.empty((0, 2)),
                birth_covs=np.empty((0, 2, 2)), clutter_intensity=1e-3)
    args.update(kw)
    return GmPhdModel(**args)


def _scan(k: int, z, sensor=(0.0, 0.0)) -> Scan:
    return Scan(robot_id=0, step=k, sensor=np.asarray(sensor, dtype=float),
                z=np.asarray(z, dtype=float).reshape(-1, 2))


def test_is_an_estimator_and_exports_its_mixture():
    est = GmPhdEstimator(_static_model(), GaussianMixture(
        np.array([1.0]), np.array([[1.0, 2.0]]), np.eye(2)[None]))
    assert isinstance(est, Estimator)
    arrays = est.export_state()
    other = GmPhdEstimator(_static_model())
    other.import_state(arrays, "robot 2")
    np.testing.assert_array_equal(other.mixture.means, [[1.0, 2.0]])
    with pytest.raises(ValueError, match="robot 2: state dimension 4"):
        other.import_state({"weights": np.ones(1), "means": np.zeros((1, 4)),
                            "covs": np.eye(4)[None]}, "robot 2")


def test_adaptive_birth_weights_sum_to_nu_and_favour_free_measurements():
    rule = AdaptiveBirth(expected_births=0.3)
    pos = np.array([[0.0, 0.0], [5.0, 5.0], [9.0, 1.0]])
    covs = np.broadcast_to(np.eye(2), (3, 2, 2))
    mix = rule.components(pos, covs, np.array([0.9, 0.0, 0.5]), dim=2)
    assert mix.weights.sum() == pytest.approx(0.3)
    # (1 - U) = 0.1, 1.0, 0.5 over 1.6
    np.testing.assert_allclose(mix.weights, 0.3 * np.array([0.1, 1.0, 0.5]) / 1.6)
    np.testing.assert_array_equal(mix.means, pos)
    # Every measurement explained: no births, no division by zero.
    none = rule.components(pos, covs, np.ones(3), dim=2)
    np.testing.assert_array_equal(none.weights, 0.0)


def test_birth_components_place_the_velocity_prior():
    rule = PerMeasurementBirth(other_mean=[0.1, -0.1], other_cov=4.0 * np.eye(2))
    mix = rule.components(np.array([[3.0, 4.0]]), 0.25 * np.eye(2)[None], dim=4)
    np.testing.assert_allclose(mix.means, [[3.0, 4.0, 0.1, -0.1]])
    np.testing.assert_allclose(mix.covs[0], np.diag([0.25, 0.25, 4.0, 4.0]))
    assert mix.weights.tolist() == [1.0]
    with pytest.raises(ValueError, match=r"other_cov must have shape \(2, 2\)"):
        PerMeasurementBirth(other_cov=np.eye(3)).components(
            np.zeros((1, 2)), np.eye(2)[None], dim=4)


def test_adaptive_newborns_appear_next_step_without_a_missed_detection_term():
    est = GmPhdEstimator(_static_model(), p_d=constant_p_d(0.9),
                         birth=AdaptiveBirth(expected_births=0.2))
    est.predict()
    est.update(_scan(0, [[3.0, 4.0]]))
    assert len(est.mixture) == 0          # births are for the next step
    est.predict()
    assert est.expected_count() == pytest.approx(0.2)
    est.update(_scan(1, np.empty((0, 2))))
    # Not detected: a newborn has no missed-detection term, so it is gone.
    assert est.expected_count() == pytest.approx(0.0)


def test_adaptive_birth_finds_targets_without_a_birth_intensity():
    rng = np.random.default_rng(11)
    targets = np.array([[2.0, 3.0], [8.0, 7.0], [5.0, -4.0]])
    est = GmPhdEstimator(_static_model(clutter_intensity=0.01), p_d=constant_p_d(0.95),
                         birth=AdaptiveBirth(expected_births=0.5))
    for k in range(30):
        det = targets[rng.uniform(size=3) < 0.95]
        z = det + rng.normal(scale=0.5, size=det.shape)
        clutter = rng.uniform(-10.0, 10.0, size=(rng.poisson(1.0), 2))
        est.predict()
        est.update(_scan(k, np.vstack([z, clutter])))
    assert round(est.expected_count()) == 3
    found = est.estimates()
    assert len(found) == 3
    d = np.linalg.norm(found[:, None] - targets[None], axis=-1)
    assert d.min(axis=0).max() < 0.5


def test_per_measurement_birth_adds_unit_components_after_reduction():
    est = GmPhdEstimator(_static_model(), p_d=constant_p_d(0.9), birth=PerMeasurementBirth())
    est.predict()
    est.update(_scan(0, [[1.0, 1.0], [4.0, 4.0]]))
    np.testing.assert_allclose(est.mixture.weights, [1.0, 1.0])
    np.testing.assert_allclose(est.mixture.covs, np.broadcast_to(0.25 * np.eye(2), (2, 2, 2)))
    # The overestimate the paper reports: a detected target gains weight each scan.
    est.predict()
    est.update(_scan(1, [[1.0, 1.0]]))
    assert est.expected_count() > 2.0


def test_births_need_position_measurements():
    h = np.array([[0.0, 1.0], [1.0, 0.0]])
    est = GmPhdEstimator(_static_model(H=h), birth=PerMeasurementBirth())
    est.predict()
    with pytest.raises(ValueError, match=r"need position measurements, H = \[I_2 0\]"):
        est.update(_scan(0, [[1.0, 1.0]]))


def test_linear_measurement_clutter_is_per_measurement():
    lin = LinearMeasurement.of(_static_model(clutter_intensity=0.02))
    np.testing.assert_array_equal(lin.clutter(np.zeros((3, 2)), np.zeros(2)), [0.02] * 3)


def test_empty_scan_and_nan_measurements():
    est = GmPhdEstimator(_static_model(), GaussianMixture(
        np.array([1.0]), np.array([[1.0, 2.0]]), np.eye(2)[None]), p_d=constant_p_d(0.5))
    est.update(_scan(0, np.empty((0, 2))))
    assert est.expected_count() == pytest.approx(0.5)
    # A scan refuses NaN itself; the estimator checks again for scans built elsewhere.
    with pytest.raises(ValueError, match="measurements must be finite"):
        _scan(1, [[np.nan, 1.0]])
    bad = SimpleNamespace(sensor=np.zeros(2), z=np.array([[0.0, 0.0], [np.nan, 1.0]]))
    with pytest.raises(ValueError, match=r"row 1 is \[nan, 1.0\]"):
        est.update(bad)


def test_limited_fov_rule_pushes_edge_components_away_on_a_miss():
    """Sung & Tokekar Alg. 1 lines 5-7, eq. 11, on a miss.

    mu <- mu + p_D (mu - y) for the missed-detection term of a component whose p_D lies
    between the thresholds; the others keep their means.
    """
    from phd_swarm.core.sensors.fov_detection import DiskFov

    sensor = np.array([0.0, 0.0])
    means = np.array([[25.0, 0.0], [5.0, 0.0], [60.0, 0.0]])   # edge, inside, outside
    mix = GaussianMixture(np.ones(3), means, np.broadcast_to(np.eye(2), (3, 2, 2)).copy())
    fov = DiskFov(radius=25.0, p_inside=0.98)
    p_d = fov(means, mix.covs, sensor)
    assert 0.4 <= p_d[0] <= 0.6 and p_d[1] > 0.6 and p_d[2] < 0.4
    est = GmPhdEstimator(_static_model(prune_threshold=1e-9, merge_threshold=0.0), mix,
                         p_d=fov, fov_push=(0.4, 0.6))
    est.update(_scan(0, np.empty((0, 2)), sensor))
    out = est.mixture.means[np.argsort(est.mixture.means[:, 0])]
    np.testing.assert_allclose(out, [[5.0, 0.0], [25.0 + 25.0 * p_d[0], 0.0], [60.0, 0.0]])
    off = GmPhdEstimator(_static_model(prune_threshold=1e-9, merge_threshold=0.0), mix,
                         p_d=fov)
    off.update(_scan(0, np.empty((0, 2)), sensor))
    np.testing.assert_allclose(np.sort(off.mixture.means[:, 0]), [5.0, 25.0, 60.0])
    with pytest.raises(ValueError, match="fov_push must be"):
        GmPhdEstimator(_static_model(), fov_push=(0.6, 0.4))


def test_the_threshold_reading_pushes_edge_components_just_until_p_d_is_the_lower_one():
    from phd_swarm.core.sensors.fov_detection import DiskFov

    sensor = np.array([10.0, -5.0])
    direction = np.array([[1.0, 0.0], [0.6, 0.8], [-0.8, 0.6], [0.0, 1.0]])
    means = sensor + np.array([[24.8], [25.0], [25.05], [5.0]]) * direction
    covs = np.array([np.eye(2), [[2.0, 0.5], [0.5, 1.0]], 0.5 * np.eye(2), np.eye(2)])
    mix = GaussianMixture(np.ones(4), means, covs)
    fov = DiskFov(radius=25.0, p_inside=0.98)
    p_d = fov(means, covs, sensor)
    assert np.all((p_d[:3] >= 0.4) & (p_d[:3] <= 0.6)) and p_d[3] > 0.6
    est = GmPhdEstimator(_static_model(prune_threshold=1e-9, merge_threshold=0.0), mix,
                         p_d=fov, fov_push=(0.4, 0.6), fov_push_to="threshold")
    est.update(_scan(0, np.empty((0, 2)), sensor))
    out = est.mixture
    by_input = [int(np.argmin(np.abs(out.weights - (1 - p) * 1.0))) for p in p_d]
    moved = out.means[by_input]
    # Edge components: on their ray from the sensor, farther out, with p_D = 0.4.
    for i in range(3):
        step = moved[i] - means[i]
        assert np.dot(step, direction[i]) > 0
        assert abs(step[0] * direction[i][1] - step[1] * direction[i][0]) < 1e-9
        assert fov(moved[i:i + 1], covs[i:i + 1], sensor)[0] == pytest.approx(0.4, abs=1e-9)
        # Far less than the paper's p_D times ~25 m.
        assert np.hypot(*step) < 0.5 * p_d[i] * 25.0
    np.testing.assert_allclose(moved[3], means[3])
    with pytest.raises(ValueError, match="fov_push_to"):
        GmPhdEstimator(_static_model(), fov_push=(0.4, 0.6), fov_push_to="far")


def test_undetected_births_keep_a_missed_term_or_are_dropped():
    from phd_swarm.core.sensors.fov_detection import DiskFov

    # A wide birth at the sensor (sd = the FoV's radius): integrated p_D = 0.9 (1 - e^-1/2).
    model = _static_model(birth_weights=[0.05], birth_means=[[0.0, 0.0]],
                          birth_covs=[625.0 * np.eye(2)], prune_threshold=1e-9,
                          merge_threshold=0.0)   # no merging, whichever rule
    fov = DiskFov(25.0, 0.9)
    p_d = 0.9 * (1.0 - np.exp(-0.5))
    keep = GmPhdEstimator(model, p_d=fov)
    drop = GmPhdEstimator(model, p_d=fov, undetected_births="drop")
    for est in (keep, drop):
        est.predict()
        est.update(_scan(0, np.empty((0, 2))))
    np.testing.assert_allclose(keep.mixture.weights, [0.05 * (1.0 - p_d)], rtol=1e-9)
    assert len(drop.mixture) == 0
    # A detection: the birth's detection term is the same either way; "keep" adds the miss.
    z = np.array([[3.0, 4.0]])
    for est in (keep, drop):
        est.mixture = GaussianMixture.empty(2)
        est.predict()
        est.update(_scan(1, z))
    s = 625.25
    q = np.exp(-0.5 * 25.0 / s) / (2.0 * np.pi * s)
    w_det = p_d * 0.05 * q / (1e-3 + p_d * 0.05 * q)
    np.testing.assert_allclose(drop.mixture.weights, [w_det], rtol=1e-9)
    np.testing.assert_allclose(sorted(keep.mixture.weights),
                               sorted([w_det, 0.05 * (1.0 - p_d)]), rtol=1e-9)
    with pytest.raises(ValueError, match="undetected_births"):
        GmPhdEstimator(model, undetected_births="forget")


@pytest.mark.parametrize("birth", [None, PerMeasurementBirth(1.0)])
def test_the_shares_follow_each_measurement_through_the_reduction(birth):
    # One component at the origin, a measurement near it and one far away.
    start = GaussianMixture(np.array([1.0]), np.zeros((1, 2)), np.eye(2)[None])
    z = np.array([[0.5, 0.0], [50.0, 0.0]])
    plain = GmPhdEstimator(_static_model(), start, p_d=constant_p_d(0.9), birth=birth)
    est = GmPhdEstimator(_static_model(), start, p_d=constant_p_d(0.9), birth=birth,
                         record_shares=True)
    for e in (plain, est):
        e.predict()
        e.update(_scan(0, z))
    # The filter is the same, bit for bit.
    for key, value in plain.mixture.to_arrays().items():
        assert np.array_equal(value, est.mixture.to_arrays()[key])
    assert plain.shares is None
    # By hand: S = P + Q + R = 1.26 I; w(z) = p q(z) / (kappa + p q(z)), the far term
    # ~0 (pruned). The missed term (0.1) and z's detection term merge into one component.
    q = np.exp(-0.5 * 0.25 / 1.26) / (2.0 * np.pi * 1.26)
    w_z = 0.9 * q / (1e-3 + 0.9 * q)
    expected = [[w_z, 0.0]] + ([[1.0, 0.0], [0.0, 1.0]] if birth else [])
    np.testing.assert_allclose(est.shares, expected, rtol=1e-12)
    assert est.mixture.weights[0] == pytest.approx(0.1 + w_z, rel=1e-12)
    assert np.all(est.shares.sum(axis=1) <= est.mixture.weights + 1e-12)
    # An empty scan: no shares; an import forgets them.
    est.predict()
    est.update(_scan(1, np.empty((0, 2))))
    assert est.shares.shape == (len(est.mixture), 0)
    est.import_state(start.to_arrays())
    assert est.shares is None
