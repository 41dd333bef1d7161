"""Papaioannou et al.'s sensor: square FoV, range-bearing, plane-uniform clutter (Sec. VI-A)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core import registry
from phd_swarm.core.sensors.range_bearing_model import RangeBearingSensor
from phd_swarm.core.sensors.square_range_bearing import SquareRangeBearing, simulate_scan


def test_targets_inside_the_closed_square_are_measured_by_range_and_bearing():
    sensor = SquareRangeBearing(side=10.0, p_d=1.0, clutter_rate=0.0)
    targets = np.array([[53.0, 54.0], [55.0, 45.0], [56.0, 50.0], [20.0, 20.0]])
    z = simulate_scan(np.random.default_rng(1), sensor, np.array([50.0, 50.0]), targets)
    assert z.shape == (2, 2)                      # the corner (55, 45) counts: closed square
    truth = RangeBearingSensor().measure(targets[:2], np.array([50.0, 50.0]))
    np.testing.assert_allclose(z[:, 0], truth[:, 0], atol=5.0)        # sd ~1 m
    np.testing.assert_allclose(z[:, 1], truth[:, 1], atol=0.1)        # sd ~1 degree


def test_clutter_is_poisson_with_the_rate_and_uniform_over_the_square():
    sensor = SquareRangeBearing(side=10.0, p_d=0.99, clutter_rate=10.0)
    rng = np.random.default_rng(2)
    s = np.array([50.0, 50.0])
    scans = [simulate_scan(rng, sensor, s, np.empty((0, 2))) for _ in range(2000)]
    counts = np.array([len(z) for z in scans])
    assert counts.mean() == pytest.approx(10.0, abs=0.2)
    z = np.concatenate(scans)
    xy = s + z[:, :1] * np.stack([np.cos(z[:, 1]), np.sin(z[:, 1])], axis=1)
    assert sensor.inside(xy, s).all()
    assert np.abs(xy - s).mean(axis=0) == pytest.approx([2.5, 2.5], abs=0.05)   # uniform


def test_the_scan_is_reproducible_and_the_part_reads_its_options():
    sensor = SquareRangeBearing()
    t = np.array([[51.0, 49.0], [58.0, 50.0]])
    a = simulate_scan(np.random.default_rng(5), sensor, np.array([50.0, 50.0]), t)
    b = simulate_scan(np.random.default_rng(5), sensor, np.array([50.0, 50.0]), t)
    assert np.array_equal(a, b)
    part = registry.lookup("sensor", "square_range_bearing")
    assert {"square_fov", "range_bearing_measurement"} <= part.provides
    np.testing.assert_allclose(sensor.clutter_intensity(np.array([[3.0, 0.0], [9.0, 0.0]]),
                                                        np.zeros(2)), [10 * 3.0 / 100, 0.0])


@pytest.mark.parametrize("kw", [{"side": 0.0}, {"p_d": 1.5}, {"clutter_rate": -1.0}])
def test_bad_settings_are_refused(kw):
    with pytest.raises(ValueError, match="square_range_bearing"):
        SquareRangeBearing(**kw)


def test_polar_clutter_is_uniform_over_the_measurement_space():
    sensor = SquareRangeBearing(clutter_rate=10.0, clutter_max_range=100.0)
    rng = np.random.default_rng(6)
    z = np.concatenate([simulate_scan(rng, sensor, np.zeros(2), np.empty((0, 2)))
                        for _ in range(500)])
    assert len(z) / 500 == pytest.approx(10.0, abs=0.3)
    assert 0.0 <= z[:, 0].min() and z[:, 0].max() <= 100.0
    assert z[:, 0].mean() == pytest.approx(50.0, abs=2.0)              # uniform in range
    assert np.abs(z[:, 1]).max() <= np.pi
    kappa = sensor.clutter_intensity(np.array([[3.0, 0.0], [150.0, 0.0]]), np.zeros(2))
    np.testing.assert_allclose(kappa, [10.0 / (2 * np.pi * 100.0), 0.0])
    assert SquareRangeBearing().polar_clutter_density is None
