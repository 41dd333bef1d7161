"""Tests for the GP motion predictor (Sung & Tokekar 2022, Sec. V-B, eq. 7-8)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import null_space
from scipy.optimize import approx_fprime
from scipy.stats import multivariate_normal

from phd_swarm.core.estimators.sung.gp_motion import (
    GpHyperparameters,
    _lml_and_grad,
    fit_hyperparameters,
    log_marginal_likelihood,
    predict_next,
    predict_tracks,
    se_kernel,
)


def _dense_predict(t: np.ndarray, m: np.ndarray, k: float, hp: GpHyperparameters
                   ) -> np.ndarray:
    """Eq. 8 for one track, one dimension at a time, with a dense np.linalg.solve."""
    out = np.empty(m.shape[1])
    for d in range(m.shape[1]):
        prior = m[:, d].mean() if hp.mean == "window" else 0.0
        gram = np.array([[hp.signal_sd**2 * np.exp(-0.5 * ((a - b) / hp.length_scale) ** 2)
                          for b in t] for a in t]) + hp.noise_sd**2 * np.eye(len(t))
        k_star = np.array([hp.signal_sd**2 * np.exp(-0.5 * ((k - a) / hp.length_scale) ** 2)
                           for a in t])
        out[d] = prior + k_star @ np.linalg.solve(gram, m[:, d] - prior)
    return out


def _random_windows(rng: np.random.Generator, n: int, w: int, d: int, offset: float = 0.0
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Irregular increasing steps (N, W), means (N, W, d) and next steps (N,)."""
    times = 50.0 + np.cumsum(rng.integers(1, 4, size=(n, w)), axis=1).astype(float)
    means = offset + rng.normal(scale=3.0, size=(n, w, d))
    k_next = times[:, -1] + rng.integers(1, 3, size=n)
    return times, means, k_next


# ---------------------------------------------------------------- eq. 7 and eq. 8


def test_se_kernel_is_eq_7_elementwise():
    hp = GpHyperparameters(signal_sd=1.7, length_scale=2.5, noise_sd=0.1, window=5)
    a = np.array([0.0, 1.0, 3.5, 10.0])
    b = np.array([0.0, 2.0, -1.0])
    k = se_kernel(a, b, hp)
    assert k.shape == (4, 3)
    for i, ai in enumerate(a):
        for j, bj in enumerate(b):
            assert k[i, j] == pytest.approx(1.7**2 * np.exp(-0.5 * ((ai - bj) / 2.5) ** 2),
                                            rel=1e-14)
    assert k[0, 0] == pytest.approx(1.7**2)        # sigma_f^2 at zero distance
    assert k[1, 1] == pytest.approx(1.7**2 * np.exp(-0.5 * (1.0 / 2.5) ** 2))


@pytest.mark.parametrize("mean", ["window", "zero"])
def test_predict_next_equals_dense_per_track_per_dimension(mean):
    rng = np.random.default_rng(7)
    times, means, k_next = _random_windows(rng, n=7, w=10, d=2, offset=20.0)
    hp = GpHyperparameters(signal_sd=2.0, length_scale=4.0, noise_sd=0.3, window=10,
                           mean=mean)
    got = predict_next(times, means, k_next, hp)
    assert got.shape == (7, 2)
    want = np.array([_dense_predict(times[i], means[i], k_next[i], hp) for i in range(7)])
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-9)


def test_zero_mean_is_the_literal_formula_and_window_mean_is_not_far_from_origin():
    rng = np.random.default_rng(3)
    times, means, k_next = _random_windows(rng, n=5, w=8, d=2, offset=100.0)
    zero = GpHyperparameters(2.0, 3.0, 0.5, window=8, mean="zero")
    window = GpHyperparameters(2.0, 3.0, 0.5, window=8, mean="window")
    # eq. 8 as printed: K(k, K) [K(K, K) + sigma_n^2 I]^-1 M^d, no mean anywhere
    literal = np.array([
        se_kernel(k_next[i:i + 1], times[i], zero)
        @ np.linalg.solve(se_kernel(times[i], times[i], zero) + 0.25 * np.eye(8), means[i])
        for i in range(5)])[:, 0, :]
    np.testing.assert_allclose(predict_next(times, means, k_next, zero), literal,
                               rtol=0.0, atol=1e-9)
    # at ~100 m with sigma_f = 2 m the zero-mean prediction is pulled far toward 0 m
    with_window = predict_next(times, means, k_next, window)
    assert np.all(np.abs(with_window - literal) > 10.0)
    assert np.all(np.abs(with_window - 100.0) < 15.0)


def test_window_mean_is_translation_equivariant_zero_mean_is_not():
    rng = np.random.default_rng(4)
    times, means, k_next = _random_windows(rng, n=6, w=10, d=3)
    shift = np.array([150.0, -80.0, 5.0])
    hp = GpHyperparameters(2.0, 4.0, 0.3, window=10, mean="window")
    np.testing.assert_allclose(predict_next(times, means + shift, k_next, hp),
                               predict_next(times, means, k_next, hp) + shift, atol=1e-9)
    zero = GpHyperparameters(2.0, 4.0, 0.3, window=10, mean="zero")
    assert not np.allclose(predict_next(times, means + shift, k_next, zero),
                           predict_next(times, means, k_next, zero) + shift, atol=1.0)


# ---------------------------------------------------------------- straight and smooth tracks


@pytest.mark.parametrize("velocity", [[1.2, -0.9], [0.0, 3.0], [-20.0, 5.0]])
@pytest.mark.parametrize("origin", [[0.0, 0.0], [100.0, 200.0], [-1e4, 3e3]])
def test_straight_line_one_step_ahead_within_10_percent_of_the_step(velocity, origin):
    """A noise-free constant-velocity line, W = 10, lambda = 10 steps, sigma_n/sigma_f = 0.005.

    An SE-kernel GP has no linear trend in its prior, so it does not extrapolate a line
    exactly: beyond the data its mean reverts to the prior mean (here the window average)
    over ~lambda steps. With lambda as long as the window and little noise the reversion
    one step ahead is small: about 4% of the step here. With the window mean the error is
    linear in the velocity and independent of the origin, so the bound holds for any line;
    the last point is off by a whole step.
    """
    hp = GpHyperparameters(signal_sd=10.0, length_scale=10.0, noise_sd=0.05, window=10)
    v = np.array(velocity)
    k = np.arange(25.0)
    pos = np.array(origin) + k[:, None] * v
    pred = predict_tracks([(k[:-1], pos[:-1])], k[-1], hp)[0]
    step = np.linalg.norm(v)
    assert np.linalg.norm(pred - pos[-1]) < 0.1 * step
    assert np.linalg.norm(pos[-2] - pos[-1]) == pytest.approx(step)


def test_straight_line_far_from_origin_defeats_the_zero_mean():
    hp = GpHyperparameters(signal_sd=10.0, length_scale=10.0, noise_sd=0.05, window=10,
                           mean="zero")
    k = np.arange(25.0)
    v = np.array([1.2, -0.9])
    pos = np.array([100.0, 200.0]) + k[:, None] * v
    pred = predict_tracks([(k[:-1], pos[:-1])], k[-1], hp)[0]
    assert np.linalg.norm(pred - pos[-1]) > 0.3 * np.linalg.norm(v)


def _cv_tracks(rng: np.random.Generator, n: int, steps: int = 120, speed: float = 1.5,
               sigma_a: float = 0.05, sigma_z: float = 0.3):
    """Nearly constant-velocity 2-D tracks: (steps, true positions, noisy positions) [m]."""
    out = []
    for _ in range(n):
        heading = rng.uniform(0.0, 2.0 * np.pi)
        v0 = speed * np.array([np.cos(heading), np.sin(heading)])
        vel = v0 + np.cumsum(sigma_a * rng.normal(size=(steps, 2)), axis=0)
        pos = rng.uniform(-200.0, 200.0, size=2) + np.cumsum(vel, axis=0)
        out.append((np.arange(steps, dtype=float), pos,
                    pos + sigma_z * rng.normal(size=pos.shape)))
    return out


def test_fitted_gp_predicts_noisy_smooth_tracks_far_better_than_the_last_point():
    """Fit on 20 noisy CV tracks, predict 20 others one step ahead from noisy windows.

    The last noisy point is off by a step (1.5 m) plus noise; the GP averages the noise
    over the window and follows the velocity. Measured: GP RMSE 0.38 m, last point 1.72 m,
    sigma_z 0.3 m. The bound (half the last-point RMSE, and under 2 sigma_z) fails for a
    GP that lags like a window average (about W/2 steps behind) or ignores the data.
    """
    rng = np.random.default_rng(11)
    w = 10
    train = [(s, z) for s, _, z in _cv_tracks(rng, 20)]
    hp = fit_hyperparameters(train, window=w)
    test = _cv_tracks(rng, 20)
    idx = np.arange(w, 120)[:, None] + np.arange(-w, 0)        # windows before each step
    times = np.concatenate([s[idx] for s, _, _ in test])
    means = np.concatenate([z[idx] for _, _, z in test])
    k_next = np.concatenate([s[w:] for s, _, _ in test])
    truth = np.concatenate([x[w:] for _, x, _ in test])
    pred = predict_next(times, means, k_next, hp)
    rmse_gp = np.sqrt(np.mean(np.sum((pred - truth) ** 2, axis=1)))
    rmse_last = np.sqrt(np.mean(np.sum((means[:, -1] - truth) ** 2, axis=1)))
    assert rmse_gp < 0.5 * rmse_last
    assert rmse_gp < 2.0 * 0.3


# ---------------------------------------------------------------- predict_tracks


def test_predict_tracks_groups_by_length_and_uses_the_last_window():
    rng = np.random.default_rng(5)
    hp = GpHyperparameters(2.0, 3.0, 0.4, window=6)
    lengths = [1, 3, 6, 6, 15, 2, 9]
    histories = []
    for n in lengths:
        steps = 10.0 + np.cumsum(rng.integers(1, 3, size=n)).astype(float)
        histories.append((steps, 40.0 + rng.normal(size=(n, 2))))
    k_next = np.array([s[-1] + 1.0 for s, _ in histories])
    got = predict_tracks(histories, k_next, hp)
    assert got.shape == (7, 2)
    for i, (steps, states) in enumerate(histories):
        if len(steps) == 1:
            np.testing.assert_array_equal(got[i], states[0])
        else:
            want = _dense_predict(steps[-6:], states[-6:], k_next[i], hp)
            np.testing.assert_allclose(got[i], want, atol=1e-9)


@pytest.mark.parametrize("mean", ["window", "zero"])
def test_the_gaps_cache_gives_eq_8_as_the_offsets_cache_does(mean):
    rng = np.random.default_rng(8)
    hp = GpHyperparameters(2.0, 4.0, 0.3, window=10, mean=mean)
    times, means, k_next = _random_windows(rng, 6, 10, 2, offset=50.0)
    # One history asked at later and later steps (a track out of view): one factor.
    times[3:] = times[2]
    means[3:] = means[2]
    k_next[3:] = times[2, -1] + np.arange(1.0, 4.0)
    gaps = predict_next(times, means, k_next, hp, cache="gaps")
    np.testing.assert_allclose(gaps, predict_next(times, means, k_next, hp), rtol=1e-12,
                               atol=1e-9)
    for i in range(6):
        np.testing.assert_allclose(gaps[i], _dense_predict(times[i], means[i], k_next[i], hp),
                                   atol=1e-9)
    with pytest.raises(ValueError, match="cache must be one of"):
        predict_next(times, means, k_next, hp, cache="weights")


@pytest.mark.parametrize("mean", ["window", "zero"])
def test_single_point_track_predicts_that_point(mean):
    hp = GpHyperparameters(2.0, 3.0, 0.4, window=6, mean=mean)
    got = predict_tracks([([4], [[120.0, -30.0]])], 5, hp)
    np.testing.assert_array_equal(got, [[120.0, -30.0]])


def test_predict_tracks_scalar_step_and_no_tracks():
    hp = GpHyperparameters(2.0, 3.0, 0.4, window=4)
    k = np.arange(5.0)
    h = [(k, np.c_[k, 2 * k]), (k + 1, np.c_[k, -k])]
    np.testing.assert_array_equal(predict_tracks(h, 7.0, hp), predict_tracks(h, [7.0, 7.0], hp))
    assert predict_tracks([], 3.0, hp).shape == (0, 0)
    assert predict_next(np.empty((0, 4)), np.empty((0, 4, 2)), np.empty(0), hp).shape == (0, 2)


# ---------------------------------------------------------------- likelihood and fitting


def _windows_of(tracks, w):
    for steps, pos in tracks:
        for s in range(0, len(steps) - w + 1, w):
            yield steps[s:s + w], pos[s:s + w]


@pytest.mark.parametrize("mean", ["zero", "window"])
def test_log_marginal_likelihood_matches_dense_gaussian_densities(mean):
    rng = np.random.default_rng(9)
    tracks = [(np.cumsum(rng.integers(1, 3, size=n)).astype(float),
               30.0 + rng.normal(size=(n, 2))) for n in (12, 7, 5, 16)]
    hp = GpHyperparameters(1.3, 2.5, 0.4, window=5, mean=mean)
    want = 0.0
    for t, y in _windows_of(tracks, 5):
        cov = se_kernel(t, t, hp) + 0.4**2 * np.eye(5)
        for d in range(2):
            if mean == "zero":                                   # R&W eq. 2.30
                want += multivariate_normal(np.zeros(5), cov).logpdf(y[:, d])
            else:   # the deviations from the average, in orthonormal coordinates
                q = null_space(np.ones((1, 5))).T                # (4, 5), q 1 = 0
                want += multivariate_normal(np.zeros(4), q @ cov @ q.T).logpdf(q @ y[:, d])
    assert log_marginal_likelihood(tracks, hp) == pytest.approx(want, rel=1e-10)


def test_window_likelihood_ignores_where_the_track_is():
    rng = np.random.default_rng(2)
    tracks = [(np.arange(20.0), rng.normal(size=(20, 2)))]
    moved = [(s, p + [500.0, -300.0]) for s, p in tracks]
    hp = GpHyperparameters(1.0, 3.0, 0.2, window=10)
    assert log_marginal_likelihood(moved, hp) == pytest.approx(
        log_marginal_likelihood(tracks, hp), rel=1e-9)


@pytest.mark.parametrize("mean", ["zero", "window"])
def test_analytic_gradient_matches_finite_differences(mean):
    rng = np.random.default_rng(6)
    times = np.cumsum(rng.integers(1, 3, size=(4, 8)), axis=1).astype(float)
    values = 10.0 + rng.normal(size=(4, 8, 2))
    x = np.log([1.3, 2.5, 0.4])
    _, grad = _lml_and_grad(times, values, x, mean, want_grad=True)
    numeric = approx_fprime(x, lambda p: _lml_and_grad(times, values, p, mean, False)[0],
                            1e-7)
    np.testing.assert_allclose(grad, numeric, rtol=1e-5)


def _gp_tracks(rng, n, steps, sf, ell, sn, offset=0.0):
    k = np.arange(steps, dtype=float)
    chol = np.linalg.cholesky(sf**2 * np.exp(-0.5 * ((k[:, None] - k) / ell) ** 2)
                              + 1e-9 * np.eye(steps))
    f = np.einsum("ij,njd->nid", chol, rng.normal(size=(n, steps, 2)))
    return [(k, offset + f[i] + sn * rng.normal(size=(steps, 2))) for i in range(n)]


@pytest.mark.parametrize(("mean", "offset"), [("zero", 0.0), ("window", 0.0),
                                              ("window", 150.0)])
def test_fit_recovers_known_hyperparameters(mean, offset):
    sf, ell, sn = 2.0, 4.0, 0.3
    rng = np.random.default_rng(1)
    tracks = _gp_tracks(rng, 20, 200, sf, ell, sn, offset)
    hp = fit_hyperparameters(tracks, window=10, mean=mean)
    assert (hp.window, hp.mean) == (10, mean)
    assert hp.signal_sd == pytest.approx(sf, rel=0.3)
    assert hp.length_scale == pytest.approx(ell, rel=0.3)
    assert hp.noise_sd == pytest.approx(sn, rel=0.3)
    true = GpHyperparameters(sf, ell, sn, window=10, mean=mean)
    assert log_marginal_likelihood(tracks, hp) >= log_marginal_likelihood(tracks, true)


def test_fit_from_a_given_start_and_with_a_stride():
    rng = np.random.default_rng(8)
    tracks = _gp_tracks(rng, 10, 120, 2.0, 4.0, 0.3)
    init = GpHyperparameters(5.0, 10.0, 1.0, window=2)
    hp = fit_hyperparameters(tracks, window=10, init=init, stride=5)
    assert hp.length_scale == pytest.approx(4.0, rel=0.3)
    assert log_marginal_likelihood(tracks, hp, stride=5) >= log_marginal_likelihood(
        tracks, GpHyperparameters(2.0, 4.0, 0.3, window=10), stride=5)


# ---------------------------------------------------------------- bad inputs


@pytest.mark.parametrize(("kw", "name"), [
    ({"signal_sd": -1.0}, "signal_sd"),
    ({"signal_sd": 0.0}, "signal_sd"),
    ({"length_scale": np.nan}, "length_scale"),
    ({"noise_sd": -0.1}, "noise_sd"),
    ({"noise_sd": "a"}, "noise_sd"),
    ({"window": 1}, "window"),
    ({"window": 2.5}, "window"),
    ({"window": True}, "window"),
    ({"mean": "constant"}, "mean"),
])
def test_bad_hyperparameters_raise_naming_the_argument(kw, name):
    args = dict(signal_sd=1.0, length_scale=2.0, noise_sd=0.1, window=5)
    args.update(kw)
    with pytest.raises(ValueError, match=name):
        GpHyperparameters(**args)


def test_bad_predict_inputs_raise_naming_the_argument():
    hp = GpHyperparameters(1.0, 2.0, 0.1, window=5)
    t = np.tile(np.arange(5.0), (3, 1))
    m = np.zeros((3, 5, 2))
    k = np.full(3, 5.0)
    with pytest.raises(ValueError, match="times"):
        predict_next(np.arange(5.0), m, k, hp)
    with pytest.raises(ValueError, match="means"):
        predict_next(t, np.zeros((3, 4, 2)), k, hp)
    with pytest.raises(ValueError, match="k_next"):
        predict_next(t, m, np.zeros(2), hp)
    bad = m.copy()
    bad[1, 2, 0] = np.nan
    with pytest.raises(ValueError, match="means must be finite"):
        predict_next(t, bad, k, hp)
    with pytest.raises(ValueError, match="times must be finite"):
        predict_next(np.where(t == 3.0, np.inf, t), m, k, hp)
    with pytest.raises(ValueError, match="k_next must be finite"):
        predict_next(t, m, np.array([5.0, np.nan, 5.0]), hp)
    with pytest.raises(ValueError, match="a must have shape"):
        se_kernel(np.zeros((2, 2)), np.zeros(2), hp)


def test_bad_track_histories_raise_naming_the_track():
    hp = GpHyperparameters(1.0, 2.0, 0.1, window=5)
    good = (np.arange(4.0), np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"histories\[1\] steps must be strictly"):
        predict_tracks([good, ([0.0, 2.0, 1.0], np.zeros((3, 2)))], 5.0, hp)
    with pytest.raises(ValueError, match=r"histories\[1\] states"):
        predict_tracks([good, (np.arange(4.0), np.zeros((4, 3)))], 5.0, hp)
    with pytest.raises(ValueError, match=r"histories\[0\] states must be finite"):
        predict_tracks([(np.arange(2.0), [[0.0, np.nan], [1.0, 1.0]])], 5.0, hp)
    with pytest.raises(ValueError, match=r"histories\[0\] steps must have shape"):
        predict_tracks([(np.empty(0), np.empty((0, 2)))], 5.0, hp)
    with pytest.raises(ValueError, match="k_next"):
        predict_tracks([good], [1.0, 2.0], hp)


def test_bad_fit_inputs_raise_naming_the_argument():
    tracks = [(np.arange(20.0), np.random.default_rng(0).normal(size=(20, 2)))]
    with pytest.raises(ValueError, match="window"):
        fit_hyperparameters(tracks, window=1)
    with pytest.raises(ValueError, match="mean"):
        fit_hyperparameters(tracks, window=5, mean="linear")
    with pytest.raises(ValueError, match="stride"):
        fit_hyperparameters(tracks, window=5, stride=0)
    with pytest.raises(ValueError, match="init"):
        fit_hyperparameters(tracks, window=5, init=(1.0, 2.0, 0.1))
    with pytest.raises(ValueError, match=r"tracks\[0\] positions must be finite"):
        fit_hyperparameters([(np.arange(3.0), [[0, 0], [np.inf, 0], [1, 1]])], window=2)
    with pytest.raises(ValueError, match="tracks must hold at least one track"):
        fit_hyperparameters(tracks, window=30)
