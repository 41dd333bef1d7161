from __future__ import annotations

import numpy as np

from phd_swarm.core.models import DiskDetection, PhdModels, UniformClutter
from phd_swarm.core.sensors.disk import simulate_scan


def test_scan_is_reproducible_from_the_seed():
    models = PhdModels()
    targets = np.array([[1.0, 1.0], [3.0, -2.0], [40.0, 40.0]])
    a = simulate_scan(np.random.default_rng(5), models, np.zeros(2), targets)
    b = simulate_scan(np.random.default_rng(5), models, np.zeros(2), targets)
    assert np.array_equal(a, b)


def test_detection_rate_and_clutter_count():
    models = PhdModels()
    rng = np.random.default_rng(0)
    targets = np.array([[2.0, 1.0], [30.0, 30.0]])
    sizes = [len(simulate_scan(rng, models, np.zeros(2), targets)) for _ in range(4000)]
    # p_d = 0.8 for the target inside the 5 m disk, none for the far one, plus clutter with
    # mean 3.66e-3 * pi * 25 = 0.287 per scan (Dames eq. 9, 11).
    assert abs(np.mean(sizes) - (0.8 + 0.2874)) < 0.05


def test_measurement_noise_has_the_model_variance():
    models = PhdModels(detection=DiskDetection(p_d=1.0), clutter=UniformClutter(density=0.0))
    rng = np.random.default_rng(2)
    z = np.vstack([simulate_scan(rng, models, np.zeros(2), np.array([[2.0, 1.0]]))
                   for _ in range(4000)])
    assert z.shape == (4000, 2)
    assert np.allclose(z.mean(axis=0), [2.0, 1.0], atol=0.03)
    assert np.allclose(z.std(axis=0), 0.5, atol=0.02)  # variance 0.25 m^2 (eq. 10)


def test_no_detection_outside_the_field_of_view_and_clutter_inside_it():
    models = PhdModels(detection=DiskDetection(p_d=1.0, radius=5.0),
                       clutter=UniformClutter(density=0.5))
    rng = np.random.default_rng(1)
    z = simulate_scan(rng, models, np.array([10.0, 10.0]), np.array([[30.0, 30.0]]))
    assert len(z) > 10  # ~39 clutter points expected
    assert np.all(np.linalg.norm(z - [10.0, 10.0], axis=1) <= 5.0)
