"""Tests for the range-bearing sensor's model (Papaioannou Sec. VI-A).

h(x, s) and its range-dependent noise, the likelihood over positions and over particle
states, the inverse model of the births, and the plane-uniform clutter in (r, phi); each
against a hand computation, scipy or a seeded draw.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from phd_swarm.core.sensors.range_bearing_model import (
    RangeBearingSensor,
    clutter_density_square,
    range_bearing_log_likelihood,
    wrap_angle,
)

SENSOR = np.array([2.0, -1.0])
PAPER = RangeBearingSensor()


def test_wrap_angle():
    a = np.array([0.0, np.pi, -np.pi, 3 * np.pi, -3 * np.pi, 2 * np.pi, -1e-20, 1e-20,
                  np.pi + 1e-9, -np.pi + 1e-9, 7.0, -7.0])
    w = wrap_angle(a)
    assert np.all((w > -np.pi) & (w <= np.pi))
    np.testing.assert_allclose(w[:6], [0.0, np.pi, np.pi, np.pi, np.pi, 0.0], atol=1e-12)
    np.testing.assert_allclose(w[6:8], [0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(w[8:], [-np.pi + 1e-9, -np.pi + 1e-9, 7 - 2 * np.pi,
                                       -7 + 2 * np.pi], atol=1e-12)


def test_measure_and_noise_by_hand():
    pos = np.array([[5.0, 3.0], [2.0, -1.0], [-1.0, -1.0 - 1e-12]])
    z = PAPER.measure(pos, SENSOR)
    np.testing.assert_allclose(z[0], [5.0, np.arctan2(4.0, 3.0)])
    np.testing.assert_allclose(z[1], [0.0, 0.0])            # on the sensor: atan2(0, 0) = 0
    assert z[2, 1] == pytest.approx(-np.pi)                  # just below the cut (target at -x)
    sd = PAPER.noise_sd(pos, SENSOR)
    np.testing.assert_allclose(sd[0], [1.0 + 5e-5 * 5.0, np.pi / 180 + 1e-5 * 5.0])
    np.testing.assert_allclose(sd[1], [1.0, np.pi / 180])
    assert PAPER == RangeBearingSensor(1.0, 5e-5, np.pi / 180, 1e-5)


def test_simulate_matches_log_likelihood():
    """Seeded draws agree with the likelihood, across the +-pi cut."""
    target = SENSOR + np.array([[-30.0, 0.2]])              # bearing pi - 0.0067
    h, sd = PAPER.measure(target, SENSOR)[0], PAPER.noise_sd(target, SENSOR)[0]
    n = 20000
    z = PAPER.simulate(np.random.default_rng(7), np.repeat(target, n, axis=0), SENSOR)
    np.testing.assert_array_equal(
        z, PAPER.simulate(np.random.default_rng(7), np.repeat(target, n, axis=0), SENSOR))
    assert np.all((z[:, 1] > -np.pi) & (z[:, 1] <= np.pi))
    assert 0.2 < np.mean(z[:, 1] < 0.0) < 0.5              # both sides of the cut occur
    dev = np.column_stack([z[:, 0] - h[0], wrap_angle(z[:, 1] - h[1])])
    np.testing.assert_array_less(np.abs(dev.mean(axis=0)), 4.0 * sd / np.sqrt(n))
    np.testing.assert_allclose(dev.std(axis=0), sd, rtol=0.03)
    # E[log g(z)] is minus the entropy of the Gaussian: -(log(2 pi sz sp) + 1).
    ll = PAPER.log_likelihood(z, target, SENSOR)[:, 0]
    expected = -(np.log(2 * np.pi * sd[0] * sd[1]) + 1.0)
    assert abs(ll.mean() - expected) < 4.0 * ll.std() / np.sqrt(n)
    # point values against scipy, with the bearing difference wrapped
    pos = np.array([[5.0, 3.0], [-28.0, -0.1], [2.5, -1.0]])
    ll = PAPER.log_likelihood(z[:5], pos, SENSOR)
    for i in range(5):
        for j in range(3):
            hj, sj = PAPER.measure(pos[j:j + 1], SENSOR)[0], PAPER.noise_sd(pos[j:j + 1],
                                                                             SENSOR)[0]
            nu = [z[i, 0] - hj[0], wrap_angle(z[i, 1] - hj[1])]
            assert ll[i, j] == pytest.approx(
                multivariate_normal.logpdf(nu, np.zeros(2), np.diag(sj**2)), rel=1e-12)


def test_state_log_likelihood_for_particles():
    states = np.array([[5.0, 3.0, 1.0, 0.0], [-28.0, -0.1, 0.0, 2.0]])
    z = np.array([[4.0, 0.6], [30.0, -3.1]])
    ll = range_bearing_log_likelihood(PAPER)(z, states, SENSOR)
    np.testing.assert_array_equal(ll, PAPER.log_likelihood(z, states[:, :2], SENSOR))
    ll2 = range_bearing_log_likelihood(PAPER, (2, 3))(z, states[:, [2, 3, 0, 1]], SENSOR)
    np.testing.assert_array_equal(ll2, ll)
    with pytest.raises(ValueError, match="position_index"):
        range_bearing_log_likelihood(PAPER, (0, 5))(z, states, SENSOR)


def test_likelihood_integrates_to_one_over_the_circle():
    target = SENSOR + np.array([[-5.0, 0.01]])              # mass on both sides of +-pi
    r = np.linspace(5.0 - 10, 5.0 + 10, 401)                  # sd 1 m: 0.05 m steps
    phi = np.linspace(-np.pi, np.pi, 4001)                    # sd 0.018 rad: 0.0016 rad
    gr, gp = np.meshgrid(r, phi, indexing="ij")
    g = np.exp(PAPER.log_likelihood(np.column_stack([gr.ravel(), gp.ravel()]), target,
                                    SENSOR)[:, 0]).reshape(gr.shape)
    total = np.trapezoid(np.trapezoid(g, phi, axis=1), r)
    assert total == pytest.approx(1.0, abs=1e-6)


def test_to_positions_inverts_measure():
    pos = SENSOR + np.array([[3.0, 4.0], [-10.0, 0.5], [0.0, -7.0]])
    z = PAPER.measure(pos, SENSOR)
    back, cov = PAPER.to_positions(z, SENSOR)
    np.testing.assert_allclose(back, pos, atol=1e-12)
    # along the x axis the covariance is diag(sigma_r^2, (r sigma_phi)^2)
    _, cov = PAPER.to_positions(np.array([[10.0, 0.0], [0.0, 1.0]]), SENSOR)
    sd = PAPER.noise_sd(SENSOR + np.array([[10.0, 0.0]]), SENSOR)[0]
    np.testing.assert_allclose(cov[0], np.diag([sd[0]**2, (10.0 * sd[1])**2]), atol=1e-15)
    assert np.all(np.linalg.eigvalsh(cov[1]) > 0.0)         # r = 0 still positive definite


def test_clutter_density_square():
    side, rate = 10.0, 10.0
    z = np.array([[1.0, 0.3], [4.9, 0.0], [5.1, 0.0], [7.0, np.pi / 4], [7.2, np.pi / 4],
                  [-0.5, 0.0], [6.0, 3 * np.pi / 4 + 2 * np.pi]])
    k = clutter_density_square(z, SENSOR, side, rate)
    np.testing.assert_allclose(k, [0.1 * 1.0, 0.1 * 4.9, 0.0, 0.1 * 7.0, 0.0, 0.0, 0.1 * 6.0])
    # it integrates to the rate over r >= 0, phi in (-pi, pi]
    r = np.linspace(0.0, side, 2001)
    phi = np.linspace(-np.pi, np.pi, 2001)
    gr, gp = np.meshgrid(r, phi, indexing="ij")
    kk = clutter_density_square(np.column_stack([gr.ravel(), gp.ravel()]), SENSOR, side,
                                rate).reshape(gr.shape)
    assert np.trapezoid(np.trapezoid(kk, phi, axis=1), r) == pytest.approx(rate, rel=2e-3)
    # and it is what points uniform over the square look like in (r, phi)
    rng = np.random.default_rng(3)
    n = 400_000
    pts = SENSOR + rng.uniform(-side / 2, side / 2, (n, 2))
    zc = PAPER.measure(pts, SENSOR)
    for r0, r1, p0, p1 in ((1.0, 2.0, 0.0, 0.5), (3.0, 4.0, -2.0, -1.5), (4.0, 5.0, 3.0, np.pi)):
        frac = np.mean((zc[:, 0] >= r0) & (zc[:, 0] < r1) & (zc[:, 1] >= p0)
                       & (zc[:, 1] < p1))
        # kappa / rate = r / A integrated over the cell (inside the square)
        expected = (r1**2 - r0**2) / 2 * (p1 - p0) / side**2
        assert frac == pytest.approx(expected, rel=0.03)


def test_bad_input_refused():
    z = np.array([[3.0, 0.1]])
    for field in ("zeta0", "beta_zeta", "phi0", "beta_phi"):
        with pytest.raises(ValueError, match=field):
            RangeBearingSensor(**{field: -1e-3})
        with pytest.raises(ValueError, match=field):
            RangeBearingSensor(**{field: np.nan})
    for field in ("zeta0", "phi0"):
        with pytest.raises(ValueError, match=field):
            RangeBearingSensor(**{field: 0.0})
    with pytest.raises(ValueError, match="finite"):
        PAPER.measure(np.array([[np.nan, 1.0]]), SENSOR)
    with pytest.raises(ValueError, match="sensor position must be finite"):
        PAPER.log_likelihood(z, np.zeros((1, 2)), np.array([0.0, np.inf]))
    with pytest.raises(ValueError, match="shape"):
        PAPER.simulate(np.random.default_rng(0), np.zeros(2), SENSOR)
    with pytest.raises(ValueError, match="side"):
        clutter_density_square(z, SENSOR, 0.0, 1.0)
    with pytest.raises(ValueError, match="rate"):
        clutter_density_square(z, SENSOR, 1.0, -1.0)
