"""The particle PHD estimator's stages, the births of a scan, roughening, draw-free extraction.

What a composing estimator (``papaioannou_sat``) relies on: :meth:`SmcPhdEstimator.update`
is :meth:`~SmcPhdEstimator.update_weights` then :meth:`~SmcPhdEstimator.resample`, draw for
draw; :class:`ScanBirth` births join the predicted particles before the weights are updated;
``Resampling.roughening`` jitters the resampled particles; ``extraction="measurement_only"``
draws nothing from the filter's generator.
"""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.estimators.smc_phd.estimator import (
    MeasurementBirth,
    Resampling,
    ScanBirth,
    SmcPhdEstimator,
)
from phd_swarm.core.estimators.smc_phd.filter import ParticleSet, extract_by_measurement
from phd_swarm.core.estimators.smc_phd.filter import resample as resample_particles
from phd_swarm.core.estimators.smc_phd.filter import update as update_particles
from phd_swarm.core.estimators.smc_phd.models import (
    constant_p_d,
    gaussian_birth,
    gaussian_measurement_sampler,
    linear_gaussian_log_likelihood,
    linear_gaussian_transition,
)
from phd_swarm.core.scan import Scan

H = np.eye(2)
SENSOR = np.array([5.0, 5.0])


def _near_measurements(rng: np.random.Generator, z: np.ndarray, sensor: np.ndarray
                       ) -> ParticleSet:
    """20 newborn particles around each measurement, 0.1 of a target each measurement."""
    n = 20
    states = np.repeat(z, n, axis=0) + 0.2 * rng.standard_normal((len(z) * n, 2))
    return ParticleSet(np.full(len(states), 0.1 / n), states, np.ones(len(states), bool))


def _estimator(birth, seed: int = 3, **kw) -> SmcPhdEstimator:
    args = dict(dim=2, transition=linear_gaussian_transition(np.eye(2), 0.01 * np.eye(2)),
                p_s=0.95, log_likelihood=linear_gaussian_log_likelihood(H, 0.25 * np.eye(2)),
                p_d=constant_p_d(0.9), clutter=1e-2, birth=birth,
                rng=np.random.default_rng(seed), resampling=Resampling(per_target=200))
    args.update(kw)
    return SmcPhdEstimator(**args)


def _scans(steps: int = 6):
    rng = np.random.default_rng(8)
    x = np.array([[4.0, 6.0], [7.0, 3.0]])
    return [Scan(0, k, SENSOR, x + 0.5 * rng.standard_normal(x.shape)) for k in range(steps)]


def _births():
    return (gaussian_birth([0.2], [[5.0, 5.0]], [4.0 * np.eye(2)], 100),
            MeasurementBirth(0.2, gaussian_measurement_sampler(0.25 * np.eye(2),
                                                                np.empty((0, 0))), 50),
            ScanBirth(_near_measurements))


@pytest.mark.parametrize("kind", [0, 1, 2], ids=["fixed", "measurement", "scan"])
@pytest.mark.parametrize("extraction", ["kmeans", "measurement"])
def test_update_is_update_weights_then_resample_draw_for_draw(kind, extraction):
    a = _estimator(_births()[kind], extraction=extraction)
    b = _estimator(_births()[kind], extraction=extraction)
    for scan in _scans():
        a.predict()
        b.predict()
        a.update(scan)
        result = b.update_weights(scan)
        assert b.last_update is result
        assert b.expected_count() == pytest.approx(result.particles.mass)
        b.resample()
        for key in ("weights", "states", "newborn"):
            np.testing.assert_array_equal(a.export_state()[key], b.export_state()[key])
        np.testing.assert_array_equal(a.estimate_states(), b.estimate_states())
    assert a.rng.random() == b.rng.random()


def test_scan_births_join_the_predicted_particles_before_the_update():
    """The update of :func:`update` on predicted + the scan's births, by hand."""
    est = _estimator(ScanBirth(_near_measurements), resampling=Resampling(n=300),
                     extraction="measurement_only")
    scan = _scans(1)[0]
    est.predict()
    assert len(est.particles) == 0                      # nothing is born at the prediction
    rng = np.random.default_rng(3)
    born = _near_measurements(rng, scan.z, scan.sensor)
    expect = update_particles(born, scan.z, lambda z, x: linear_gaussian_log_likelihood(
        H, 0.25 * np.eye(2))(z, x), 0.9, 1e-2)
    result = est.update_weights(scan)
    np.testing.assert_array_equal(result.particles.states, born.states)
    np.testing.assert_array_equal(result.particles.weights, expect.particles.weights)
    assert result.particles.newborn.all()
    # no missed-detection term for the newborns: all their weight is in the detections
    assert result.particles.mass == pytest.approx(expect.detection_mass.sum())
    est.resample()
    assert len(est.particles) == 300


def test_no_scan_births_leave_the_particles_unchanged():
    empty = ScanBirth(lambda rng, z, sensor: ParticleSet.empty(2))
    est = _estimator(empty, particles=ParticleSet(np.full(4, 0.5), np.full((4, 2), 5.0),
                                                  np.zeros(4, bool)),
                     extraction="measurement_only")
    est.predict()
    predicted = est.particles
    post = est.update_weights(Scan(0, 0, SENSOR, np.empty((0, 2)))).particles
    np.testing.assert_array_equal(post.states, predicted.states)
    np.testing.assert_array_equal(post.weights, (1.0 - 0.9) * predicted.weights)   # missed


def test_roughening_jitters_every_resampled_coordinate_by_its_sd():
    particles = ParticleSet(np.full(5, 0.4), np.arange(10.0).reshape(5, 2), np.zeros(5, bool))
    est = _estimator(ScanBirth(lambda rng, z, sensor: ParticleSet.empty(2)),
                     resampling=Resampling(n=4000, roughening=0.3), particles=particles,
                     extraction="measurement_only")
    est.update_weights(Scan(0, 0, SENSOR, np.empty((0, 2))))
    posterior = est.particles
    est.resample()
    # the draws: resampling's one uniform, then one standard normal per coordinate
    rng = np.random.default_rng(3)
    plain = resample_particles(posterior, rng, n=4000)
    jitter = rng.standard_normal(plain.states.shape) * 0.3
    np.testing.assert_array_equal(est.particles.states, plain.states + jitter)
    np.testing.assert_array_equal(est.particles.weights, plain.weights)
    assert (est.particles.states - plain.states).std() == pytest.approx(0.3, rel=0.05)
    with pytest.raises(ValueError, match="roughening must be finite and >= 0"):
        Resampling(roughening=-0.1)


def test_measurement_only_extraction_draws_nothing():
    """Its generator is the caller's alone: no seed at construction or after an update."""
    est = _estimator(ScanBirth(_near_measurements), extraction="measurement_only")
    assert est.estimate_states().shape == (0, 2)          # no update yet: no estimates
    twin = np.random.default_rng(3)
    assert est.rng.random() == twin.random()              # the constructor drew nothing
    for scan in _scans(3):
        est.predict()
        est.update(scan)
    np.testing.assert_array_equal(est.estimate_states(),
                                  extract_by_measurement(est.last_update))
    est.predict()
    assert est.last_update is None and est.estimates().shape == (0, 2)
    with pytest.raises(ValueError, match="sample must be callable"):
        ScanBirth(sample=3)
