"""Tests for the centralised grid PHD filter (the reference for the distributed one)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.estimators.grid_phd import filter as phd_grid
from phd_swarm.core.estimators.grid_phd.central import CentralPhdFilter
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.models import dames_moving, dames_static
from phd_swarm.core.scan import Scan

GRID = Grid(Environment(0.0, 0.0, 30.0, 20.0), 1.0)


def _overlapping_scans(seed: int, n: int = 8) -> list[Scan]:
    """Scans from sensors packed in a 10 x 6 m patch, so their 5 m disks overlap."""
    rng = np.random.default_rng(seed)
    scans = []
    for r in range(n):
        q = rng.uniform([10.0, 7.0], [20.0, 13.0])
        z = q + rng.uniform(-4.0, 4.0, (rng.integers(0, 4), 2))
        scans.append(Scan(robot_id=r, step=0, sensor=q, z=z))
    return scans


def test_initial_weights_and_precomputed_models():
    models = dames_moving()
    f = CentralPhdFilter(Grid(Environment(0.0, 0.0, 100.0, 100.0), 1.0), models)
    assert f.weights.shape == (100, 100)
    assert np.all(f.weights == 1e-4)
    assert f.total_mass == pytest.approx(1.0, rel=1e-12)
    assert f.kernel.shape == (5, 5)
    assert f.birth_img.sum() == pytest.approx(0.09994, rel=1e-12)
    assert f.ps_img.min() == 0.5


def test_weights_are_read_only_snapshots():
    f = CentralPhdFilter(GRID, dames_static())
    before = f.weights
    with pytest.raises(ValueError):
        before[0, 0] = 1.0
    f.update_all(_overlapping_scans(0))
    f.predict()
    assert np.all(before == 1e-4)
    assert not np.array_equal(f.weights, before)


def test_weights_setter_validates():
    f = CentralPhdFilter(GRID, dames_static())
    img = np.full(GRID.shape, 0.5)
    f.weights = img
    img[0, 0] = 7.0                     # the filter keeps its own copy
    assert f.weights[0, 0] == 0.5 and f.total_mass == pytest.approx(0.5 * GRID.size)
    with pytest.raises(ValueError, match="shape"):
        f.weights = np.zeros((3, 3))
    with pytest.raises(ValueError, match="non-negative"):
        f.weights = np.full(GRID.shape, -1.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_update_all_sorts_by_robot_id(seed):
    scans = _overlapping_scans(seed)
    shuffled = list(np.random.default_rng(seed + 100).permutation(scans))
    a = CentralPhdFilter(GRID, dames_static())
    b = CentralPhdFilter(GRID, dames_static())
    a.update_all(scans)
    b.update_all(shuffled)
    assert a.weights.tobytes() == b.weights.tobytes()
    # The order matters here (overlapping fields of view), so the sort is doing work.
    c = CentralPhdFilter(GRID, dames_static())
    for scan in reversed(scans):
        c.update(scan)
    assert np.max(np.abs(c.weights - a.weights)) > 1e-9


def test_update_all_is_stable_for_equal_ids():
    s1, s2 = _overlapping_scans(5, n=2)
    s2 = Scan(robot_id=s1.robot_id, step=0, sensor=s2.sensor, z=s2.z)
    a = CentralPhdFilter(GRID, dames_static())
    a.update_all([s1, s2])
    b = CentralPhdFilter(GRID, dames_static())
    b.update(s1)
    b.update(s2)
    assert a.weights.tobytes() == b.weights.tobytes()


def test_update_equals_the_dense_eq4_over_the_whole_map():
    # Eq. 4-6 written out over every bin of the map (p_d and psi are 0 outside the field
    # of view), one scan after the other in robot-id order.
    scans = _overlapping_scans(3)
    f = CentralPhdFilter(GRID, dames_static())
    f.weights = np.random.default_rng(3).uniform(0.0, 0.01, GRID.shape)
    w = f.weights.ravel().copy()
    f.update_all(scans)
    m = f.models
    for scan in sorted(scans, key=lambda s: s.robot_id):
        ps = phd_grid.psi(m, GRID.centres, scan.z, scan.sensor)
        pd = m.detection.probability(GRID.centres, scan.sensor)
        eta = m.clutter.intensity(scan.z) + ps @ w
        w = (1.0 - pd) * w + (ps / eta[:, None]).sum(axis=0) * w
    np.testing.assert_allclose(f.weights.ravel(), w, rtol=1e-12, atol=0.0)


def test_step_is_predict_then_updates():
    models = dames_moving()
    scans = _overlapping_scans(4)
    a = CentralPhdFilter(GRID, models)
    b = CentralPhdFilter(GRID, models)
    a.step(scans)
    b.predict()
    b.update_all(scans)
    assert a.weights.tobytes() == b.weights.tobytes()
    expected = phd_grid.predict_image(np.full(GRID.shape, 1e-4), a.kernel, a.ps_img,
                                      a.birth_img)
    c = CentralPhdFilter(GRID, models)
    c.predict()
    assert c.weights.tobytes() == expected.tobytes()


def test_no_scans_leaves_the_weights():
    f = CentralPhdFilter(GRID, dames_static())
    before = f.weights
    f.update_all([])
    assert f.weights.tobytes() == before.tobytes()
    f.step([])                                   # static model: predict is the identity
    assert f.weights.tobytes() == before.tobytes()


def test_static_target_measured_repeatedly_concentrates_mass():
    rng = np.random.default_rng(42)
    models = dames_static()
    target = np.array([12.3, 8.7])
    f = CentralPhdFilter(GRID, models)
    for step in range(15):
        sensor = target + rng.uniform(-2.0, 2.0, 2)
        z = []
        if rng.uniform() < models.detection.p_d:
            z.append(target + rng.normal(0.0, np.sqrt(models.measurement.variance), 2))
        for _ in range(rng.poisson(models.clutter.expected_count(models.detection.fov_area))):
            r, a = 5.0 * np.sqrt(rng.uniform()), rng.uniform(0.0, 2 * np.pi)
            z.append(sensor + r * np.array([np.cos(a), np.sin(a)]))
        f.step([Scan(robot_id=0, step=step, sensor=sensor, z=np.array(z).reshape(-1, 2))])
    best = np.argmax(f.weights)
    assert np.linalg.norm(GRID.centres[best] - target) <= 1.0
    # Of the order of one target's worth of mass within 2 m of it (the last scans' hits and
    # misses move it by tens of percent), and little anywhere else.
    near = np.linalg.norm(GRID.centres - target, axis=1) <= 2.0
    assert 0.5 < f.weights.ravel()[near].sum() < 1.5
    assert f.weights.ravel()[~near].sum() < 0.1


def test_moving_models_track_a_walking_target():
    rng = np.random.default_rng(7)
    models = dames_moving()
    target = np.array([8.0, 10.0])
    f = CentralPhdFilter(GRID, models)
    for step in range(20):
        target = target + np.array([0.5, 0.0])
        sensor = target + rng.uniform(-1.0, 1.0, 2)
        z = target + rng.normal(0.0, 0.5, (1, 2))
        f.step([Scan(robot_id=0, step=step, sensor=sensor, z=z)])
    best = np.argmax(f.weights)
    assert np.linalg.norm(GRID.centres[best] - target) <= 1.5


def test_the_central_filter_is_an_estimator_with_estimates_and_a_count():
    from phd_swarm.core.estimators.base import Estimator
    from phd_swarm.core.extraction import extract_targets

    f = CentralPhdFilter(GRID, dames_static())
    assert isinstance(f, Estimator)
    for scan in _overlapping_scans(3):
        f.update(scan)
    np.testing.assert_array_equal(f.estimates(), extract_targets(GRID, f.weights))
    assert f.expected_count() == f.total_mass
