"""Tests for the target and sensor models and the paper presets (Dames eq. 9-14)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.models import (
    DiskDetection,
    GaussianMeasurement,
    RandomWalkMotion,
    chen_clustered,
    dames_moving,
    dames_static,
)

MAP_1M = Grid(Environment(0.0, 0.0, 100.0, 100.0), 1.0)


def test_birth_mass_is_a_tenth_per_step():
    # Eq. 14: 5.26e-5 per m^2 within 5 m of the boundary; bin centres 0.5..4.5 m from it
    # give 100^2 - 90^2 = 1900 bins of 1 m^2.
    birth = dames_moving().birth.mass(MAP_1M)
    assert np.count_nonzero(birth) == 1900
    assert birth.sum() == pytest.approx(1900 * 5.26e-5, rel=1e-12)
    assert round(birth.sum(), 4) == 0.0999


def test_survival_is_half_on_the_two_bin_ring():
    # Eq. 13: p_s = 0.5 within 2 m of the boundary (centres 0.5 and 1.5 m from it).
    ps = dames_moving().survival.probability(MAP_1M).reshape(MAP_1M.shape)
    ring = np.ones(MAP_1M.shape, dtype=bool)
    ring[2:-2, 2:-2] = False
    assert np.all(ps[ring] == 0.5) and np.all(ps[~ring] == 1.0)
    assert ring.sum() == 100 ** 2 - 96 ** 2


def test_static_preset_has_unit_survival_and_no_birth():
    models = dames_static()
    assert np.all(models.survival.probability(MAP_1M) == 1.0)
    assert np.all(models.birth.mass(MAP_1M) == 0.0)
    assert models.initial_density * MAP_1M.bin_area * MAP_1M.size == pytest.approx(1.0)


def test_clutter_expected_count_for_the_5m_disk():
    # Eq. 11: 3.66e-3 per m^2 over pi * 5^2 m^2.
    models = dames_static()
    count = models.clutter.expected_count(models.detection.fov_area)
    assert count == pytest.approx(0.287, abs=5e-4)
    np.testing.assert_array_equal(models.clutter.intensity(np.zeros((3, 2))), [3.66e-3] * 3)


def test_detection_disk_is_inclusive():
    det = DiskDetection()
    pts = np.array([[5.0, 0.0], [3.0, 4.0], [5.0 + 1e-9, 0.0], [0.0, 0.0]])
    np.testing.assert_array_equal(det.probability(pts, np.zeros(2)), [0.8, 0.8, 0.0, 0.8])


def test_measurement_likelihood_is_a_normalised_gaussian():
    g = GaussianMeasurement(variance=0.25)
    z = np.array([[1.0, 1.0], [1.5, 1.0]])
    x = np.array([[1.0, 1.0]])
    expected = np.array([[1.0], [math.exp(-0.5 * 0.25 / 0.25)]]) / (2 * math.pi * 0.25)
    np.testing.assert_allclose(g.likelihood(z, x), expected, rtol=1e-14)
    # Integral over z of g(z | x) is 1 (midpoint sum over +-6 sd, which drops ~1.5e-8).
    s = np.arange(-3.0, 3.0, 0.01) + 0.005
    zz = np.stack(np.meshgrid(s, s), axis=-1).reshape(-1, 2)
    assert g.likelihood(zz, np.zeros(2)).sum() * 1e-4 == pytest.approx(1.0, rel=1e-7)


@pytest.mark.parametrize("preset, res, side", [
    (dames_moving, 1.0, 5), (dames_moving, 0.1, 41), (chen_clustered, 0.1, 29),
    (chen_clustered, 1.0, 3),
])
def test_kernel_sums_to_one_is_symmetric_and_truncated(preset, res, side):
    motion = preset().motion
    ker = motion.kernel(res)
    assert ker.shape == (side, side)
    assert ker.sum() == pytest.approx(1.0, abs=1e-14)
    assert np.all(ker >= 0)
    # Symmetric to the precision of the normal CDF differences in the far tail.
    for mirrored in (ker[::-1, :], ker[:, ::-1], ker.T):
        np.testing.assert_allclose(ker, mirrored, rtol=1e-8, atol=1e-16)
    k = side // 2
    off = np.arange(-k, k + 1) * res
    dist = np.hypot(off[:, None], off[None, :])
    inside = dist <= motion.truncation + 1e-9
    assert np.all(ker[~inside] == 0.0)
    assert np.all(ker[inside] > 0.0)
    assert ker[k, k] == ker.max()


def test_kernel_values_match_the_truncated_gaussian_by_hand():
    # 1 m bins, sd 0.35 m, truncation 2 m: offsets with centre distance <= 2 m are kept.
    ker = RandomWalkMotion(sd=0.35, truncation=2.0).kernel(1.0)

    def phi(x):
        return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))

    m = [phi((j + 0.5) / 0.35) - phi((j - 0.5) / 0.35) for j in range(-2, 3)]
    raw = np.outer(m, m)
    raw[[0, 0, 1, 1, 3, 3, 4, 4], [1, 3, 0, 4, 0, 4, 1, 3]] = 0.0  # |(2, 1)| = 2.24 m > 2
    raw[[0, 0, 4, 4], [0, 4, 0, 4]] = 0.0
    np.testing.assert_allclose(ker, raw / raw.sum(), rtol=1e-9, atol=1e-18)


def test_static_kernel_is_identity():
    np.testing.assert_array_equal(dames_static().motion.kernel(0.1), np.ones((1, 1)))
    assert dames_static().motion.is_identity
    assert dames_static().motion.support_radius == 0.0


def _models(cfg, where="scenario.yaml"):
    """Models from a config's ``models`` block, through the scenario loader.

    That is the one path by which models come from a file.
    """
    from phd_swarm.sim.scenario_dict import scenario_from_dict

    return scenario_from_dict({"preset": "dames_static", "models": cfg}, where).models


def test_a_models_block_builds_nested_models():
    m = _models({"detection": {"p_d": 0.9, "radius": 4},
                 "motion": {"sd": 0.35, "truncation": 2.0}, "initial_density": 2e-4})
    assert m.detection == DiskDetection(p_d=0.9, radius=4.0)
    assert m.motion.kernel(1.0).shape == (5, 5)
    assert m.initial_density == 2e-4
    assert m.clutter == dames_static().clutter


@pytest.mark.parametrize("cfg, key", [
    ({"detectoin": {"p_d": 0.9}}, "detectoin"),
    ({"detection": {"pd": 0.9}}, "detection.pd"),
    ({"detection": {"p_d": "0.9"}}, "detection.p_d"),
    ({"detection": {"p_d": True}}, "detection.p_d"),
    ({"measurement": {"variance": [0.25]}}, "measurement.variance"),
    ({"initial_density": "1e-4"}, "initial_density"),
    ({"initial_density": None}, "initial_density"),
    ({"detection": {"p_d": 1.5}}, "detection.p_d"),
    ({"detection": {"radius": -1.0}}, "detection.radius"),
    ({"clutter": {"density": float("nan")}}, "clutter.density"),
    ({"survival": {"p_near": -0.1}}, "survival.p_near"),
    ({"birth": {"margin": -5}}, "birth.margin"),
    ({"initial_density": -1.0}, "initial_density"),
    ({"detection": 0.8}, "detection"),
])
def test_a_bad_models_block_is_refused_naming_the_file_and_key(cfg, key):
    with pytest.raises(ValueError) as exc:
        _models(cfg)
    assert str(exc.value).startswith("scenario.yaml: ")
    assert f"models.{key}" in str(exc.value), str(exc.value)


def test_a_models_block_must_be_a_mapping():
    with pytest.raises(ValueError, match="scenario.yaml: models: expected a mapping"):
        _models([("detection", {})])
