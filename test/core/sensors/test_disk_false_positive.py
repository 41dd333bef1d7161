from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.models import DiskDetection, GaussianMeasurement, PhdModels
from phd_swarm.core.registry import lookup
from phd_swarm.core.sensors.disk_false_positive import DiskFalsePositiveSensor, simulate_scan
from phd_swarm.sim.presets import sung_tokekar


def _sensor(fp: float, p_d: float = 0.98) -> DiskFalsePositiveSensor:
    return DiskFalsePositiveSensor(
        PhdModels(detection=DiskDetection(p_d=p_d, radius=25.0),
                  measurement=GaussianMeasurement(variance=1.0)), fp)


@pytest.mark.parametrize("fp", [0.0, 0.1, 0.2])
def test_one_false_positive_with_the_given_probability_uniform_in_the_disk(fp):
    sensor = _sensor(fp, p_d=0.0)          # no detections: every measurement is false
    rng = np.random.default_rng(3)
    scans = [simulate_scan(rng, sensor, np.array([10.0, 20.0]), np.array([[12.0, 20.0]]))
             for _ in range(20000)]
    sizes = np.array([len(z) for z in scans])
    assert sizes.max() <= 1
    assert abs(sizes.mean() - fp) < 4 * np.sqrt(fp * (1 - fp) / 20000) + 1e-12
    if fp:
        z = np.vstack([s for s in scans if len(s)])
        r = np.hypot(z[:, 0] - 10.0, z[:, 1] - 20.0)
        assert r.max() <= 25.0
        # Uniform in the disk: P(r <= R / 2) = 1 / 4.
        assert abs(np.mean(r <= 12.5) - 0.25) < 0.03


def test_detections_inside_the_disk_only_with_the_model_noise():
    sensor = _sensor(0.0)
    rng = np.random.default_rng(4)
    targets = np.array([[5.0, 0.0], [40.0, 0.0]])   # inside and outside the 25 m disk
    z = np.vstack([simulate_scan(rng, sensor, np.zeros(2), targets) for _ in range(5000)])
    assert abs(len(z) / 5000 - 0.98) < 0.01
    assert np.allclose(z.mean(axis=0), [5.0, 0.0], atol=0.05)
    assert np.allclose(z.std(axis=0), 1.0, atol=0.03)


def test_the_clutter_intensity_is_the_rate_over_the_disk_area():
    assert _sensor(0.2).clutter_intensity() == pytest.approx(0.2 / (np.pi * 625.0))


def test_the_registered_sensor_reads_the_option_and_the_world_uses_it():
    sc = sung_tokekar().with_system(options={"false_positive_prob": 0.2})
    part = lookup("sensor", "disk_false_positive")
    model = part.setup(sc, sc.system)
    assert model.false_positive_prob == 0.2 and model.radius == 25.0
    with pytest.raises(ValueError, match="false_positive_prob"):
        sung_tokekar().with_system(options={"false_positive_prob": 1.5})
