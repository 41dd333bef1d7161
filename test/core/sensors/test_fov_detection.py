"""Tests for the limited-FoV detection probabilities (Sung & Tokekar eq. 9-10)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import integrate
from scipy.special import ndtr
from scipy.stats import multivariate_normal, ncx2, norm

from phd_swarm.core.sensors.fov_detection import DiskFov, SquareFov, disk_mass, square_mass

R = 5.0  # disk radius / square half-width used throughout [m]
TOL = 1e-6


def _cov(s_major: float, s_minor: float, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([s_major**2, s_minor**2]) @ rot.T


def _corr(sx: float, sy: float, rho: float) -> np.ndarray:
    return np.array([[sx * sx, rho * sx * sy], [rho * sx * sy, sy * sy]])


# ----------------------------------------------------------------- brute-force references

def _nquad_mass(m, p, x_range, y_range_of, x_hints, nsd=10.0) -> float:
    """Mass of N(m, p) over {x in x_range, y in y_range_of(x)}: scipy nquad of the pdf.

    The pdf is written as N(x) N(y | x); each range is cut to the Gaussian's +-10 sd
    (mass left out < 1e-22), which keeps the adaptive rules on the Gaussian.
    """
    sx = np.sqrt(p[0, 0])
    beta = p[0, 1] / p[0, 0]
    s = np.sqrt(p[1, 1] - beta * p[0, 1])
    x0, x1 = max(x_range[0], m[0] - nsd * sx), min(x_range[1], m[0] + nsd * sx)
    if x0 >= x1:
        return 0.0

    def y_range(x):
        mu = m[1] + beta * (x - m[0])
        lo, hi = y_range_of(x)
        lo, hi = max(lo, mu - nsd * s), min(hi, mu + nsd * s)
        return lo, max(lo, hi)

    def pdf(y, x):
        return norm.pdf(x, m[0], sx) * norm.pdf(y, m[1] + beta * (x - m[0]), s)

    hints = [h for h in [m[0], *x_hints(beta)] if x0 < h < x1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        v, _ = integrate.nquad(pdf, [y_range, [x0, x1]], opts=[
            dict(epsabs=1e-10, epsrel=1e-10, limit=100),
            dict(epsabs=1e-9, epsrel=1e-9, limit=100, points=hints)])
    return v


def _disk_ref(m, p, c, radius) -> float:
    def chord(x):
        w = np.sqrt(max(radius**2 - (x - c[0]) ** 2, 0.0))
        return c[1] - w, c[1] + w

    def hints(beta):  # where the conditional-mean line y = m_y + beta (x - m_x) meets the circle
        a, d0 = 1 + beta * beta, m[1] - beta * m[0] - c[1]
        b, cc = 2 * (beta * d0 - c[0]), c[0] ** 2 + d0 * d0 - radius**2
        disc = b * b - 4 * a * cc
        return [] if disc < 0 else [(-b - np.sqrt(disc)) / (2 * a), (-b + np.sqrt(disc)) / (2 * a)]

    return _nquad_mass(m, p, (c[0] - radius, c[0] + radius), chord, hints)


def _square_ref(m, p, c, h) -> float:
    def hints(beta):
        return [] if beta == 0 else [m[0] + (c[1] + k - m[1]) / beta for k in (-h, h)]

    return _nquad_mass(m, p, (c[0] - h, c[0] + h), lambda x: (c[1] - h, c[1] + h), hints)


def _disk_1d_ref(m, p, c, radius, outer: int) -> float:
    """Adaptive 1-D reference in the principal axes, cut at every feature (for tiny sds).

    ``outer`` 0 integrates over the minor axis, 1 over the major one.
    """
    lam, vec = np.linalg.eigh(p)
    sd = np.sqrt(np.maximum(lam, 0.0))
    mu = vec.T @ (np.asarray(m) - c)
    sa, ma, sb, mb = sd[outer], mu[outer], sd[1 - outer], abs(mu[1 - outer])
    lo, hi = max(-radius, ma - 12 * sa), min(radius, ma + 12 * sa)
    if lo >= hi:
        return 0.0

    def f(a):
        w = np.sqrt(max(radius**2 - a * a, 0.0))
        return norm.pdf(a, ma, sa) * (ndtr((w - mb) / sb) - ndtr((-w - mb) / sb))

    cuts = [ma + k * sa for k in (-6, -3, -1, 0, 1, 3, 6)]
    for k in (-3, -1, 0, 1, 3):
        w = mb + k * sb
        if 0 <= w < radius:
            cuts += [np.sqrt(radius**2 - w * w), -np.sqrt(radius**2 - w * w)]
    edges = [lo, *sorted(x for x in set(cuts) if lo < x < hi), hi]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        return sum(integrate.quad(f, a0, a1, limit=500, epsabs=1e-15, epsrel=1e-13)[0]
                   for a0, a1 in zip(edges[:-1], edges[1:], strict=True))


def _square_1d_ref(m, p, c, h) -> float:
    """Adaptive 1-D reference: x-integral of N(x) P(y in [cy - h, cy + h] | x), cut at features."""
    sx = np.sqrt(p[0, 0])
    beta = p[0, 1] / p[0, 0]
    s = np.sqrt(max(p[1, 1] - beta * p[0, 1], 0.0))
    lo, hi = max(c[0] - h, m[0] - 12 * sx), min(c[0] + h, m[0] + 12 * sx)
    if lo >= hi:
        return 0.0

    def f(x):
        mu = m[1] + beta * (x - m[0])
        return norm.pdf(x, m[0], sx) * (ndtr((c[1] + h - mu) / s) - ndtr((c[1] - h - mu) / s))

    cuts = [m[0] + k * sx for k in (-6, -3, -1, 0, 1, 3, 6)]
    if beta != 0.0:
        cuts += [m[0] + (c[1] + e + k * s - m[1]) / beta
                 for e in (-h, h) for k in (-3, -1, 0, 1, 3)]
    edges = [lo, *sorted(x for x in set(cuts) if lo < x < hi), hi]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        return sum(integrate.quad(f, a0, a1, limit=500, epsabs=1e-15, epsrel=1e-13)[0]
                   for a0, a1 in zip(edges[:-1], edges[1:], strict=True))


# Hand-picked hard cases (mean, covariance), FoV centred at the origin.
HARD = [
    ("tiny, on the edge", [R, 0.0], _cov(1e-3, 1e-3, 0.0)),
    ("tiny, just inside at 30 deg", [(R - 2e-3) * np.cos(0.5), (R - 2e-3) * np.sin(0.5)],
     _cov(1e-3, 5e-4, 1.0)),
    ("small, on the edge at 45 deg", [R / np.sqrt(2), R / np.sqrt(2)], _cov(0.1, 0.1, 0.0)),
    ("thin ridge tangent to the edge", [0.0, R - 0.005], _cov(1.0, 0.002, 0.0)),
    ("thin ridge across the edge", [R, 0.0], _cov(1.0, 0.002, 0.0)),
    ("thin ridge oblique on the edge", [0.0, -R], _cov(2.0, 0.01, 0.3)),
    ("rho = 0.99999", [3.0, 4.0], _corr(1.0, 2.0, 0.99999)),
    ("rho = -0.9999, outside", [R + 0.5, 0.0], _corr(2.0, 1.0, -0.9999)),
    ("big, centred", [0.0, 0.0], _cov(20.0, 8.0, 0.7)),
    ("huge, off centre", [30.0, -40.0], _cov(300.0, 100.0, 0.2)),
    ("comparable, outside", [7.0, 1.0], _cov(1.5, 0.8, 2.0)),
    ("corner of the square", [R, R], _cov(0.3, 0.05, 0.8)),
    ("far away", [60.0, 0.0], _cov(1.0, 1.0, 0.0)),
]


def _random_cases(seed: int, n: int = 20, log_sd=(-2.5, 1.0), log_aspect=2.0):
    rng = np.random.default_rng(seed)
    cases = []
    for _ in range(n):
        s_minor = 10 ** rng.uniform(*log_sd)
        s_major = s_minor * 10 ** rng.uniform(0.0, log_aspect)
        p = _cov(s_major, s_minor, rng.uniform(0.0, np.pi))
        r = R + rng.normal() * 2.0 * s_major
        phi = rng.uniform(0.0, 2 * np.pi)
        cases.append((np.array([r * np.cos(phi), r * np.sin(phi)]), p))
    return cases


# ----------------------------------------------------------------- accuracy

@pytest.mark.parametrize("name,mean,cov", HARD, ids=[h[0] for h in HARD])
def test_hard_cases_match_adaptive_references(name, mean, cov):
    m, c = np.array(mean), np.zeros(2)
    disk = disk_mass(m[None], cov[None], c, R)[0]
    for outer in (0, 1):
        assert disk == pytest.approx(_disk_1d_ref(m, cov, c, R, outer), abs=TOL)
    square = square_mass(m[None], cov[None], c, R)[0]
    assert square == pytest.approx(_square_1d_ref(m, cov, c, R), abs=TOL)
    # the square the other way round (integrating over y), and scipy's multivariate normal
    swap = np.array([[0.0, 1.0], [1.0, 0.0]])
    assert square == pytest.approx(_square_1d_ref(swap @ m, swap @ cov @ swap, c, R), abs=TOL)
    ref = multivariate_normal(m, cov, abseps=1e-12, releps=1e-12).cdf([R, R], lower_limit=[-R, -R])
    assert square == pytest.approx(ref, abs=TOL)


def test_random_cases_match_brute_force_nquad():
    # a 2-D brute force, on moderate covariances where scipy's nquad is reliable and quick
    cases = _random_cases(1, n=5, log_sd=(-1.0, 0.3), log_aspect=1.0)
    means = np.array([c[0] for c in cases])
    covs = np.array([c[1] for c in cases])
    centre = np.array([0.4, -0.3])
    disk = disk_mass(means + centre, covs, centre, R)
    square = square_mass(means + centre, covs, centre, R)
    for j, (m, p) in enumerate(cases):
        assert disk[j] == pytest.approx(_disk_ref(m + centre, p, centre, R), abs=TOL), j
        assert square[j] == pytest.approx(_square_ref(m + centre, p, centre, R), abs=TOL), j


def test_random_cases_match_adaptive_references():
    cases = _random_cases(8, n=20, log_sd=(-4.0, 1.5), log_aspect=3.0)
    means = np.array([c[0] for c in cases])
    covs = np.array([c[1] for c in cases])
    centre = np.array([-3.0, 2.0])
    disk = disk_mass(means + centre, covs, centre, R)
    square = square_mass(means + centre, covs, centre, R)
    for j, (m, p) in enumerate(cases):
        for outer in (0, 1):
            assert disk[j] == pytest.approx(_disk_1d_ref(m + centre, p, centre, R, outer),
                                            abs=TOL), j
        assert square[j] == pytest.approx(_square_1d_ref(m + centre, p, centre, R), abs=TOL), j


def test_disk_isotropic_matches_noncentral_chi_square():
    # |X - c|^2 / s^2 ~ chi'^2(2, |m - c|^2 / s^2): an exact, independent closed form
    rng = np.random.default_rng(2)
    s = 10 ** rng.uniform(-3.5, 1.5, 200)
    dist = np.abs(R + rng.normal(size=200) * 3 * s)
    dist[::4] = rng.uniform(0, R + 2, 50)
    phi = rng.uniform(0, 2 * np.pi, 200)
    means = np.stack([dist * np.cos(phi), dist * np.sin(phi)], axis=1)
    covs = s[:, None, None] ** 2 * np.eye(2)
    exact = ncx2.cdf(R**2 / s**2, 2, dist**2 / s**2)
    assert np.max(np.abs(disk_mass(means, covs, np.zeros(2), R) - exact)) <= TOL


def test_disk_extreme_covariances_match_adaptive_1d_reference():
    # sds down to 1e-7 R and aspect ratios up to 1e5, on the edge in all directions
    rng = np.random.default_rng(3)
    means, covs = [], []
    for s_minor in (5e-7, 3e-2):
        for aspect in (1.001, 1e3, 1e5):
            for phi in (0.0, np.pi / 4, 1.3, np.pi / 2):
                angle = rng.uniform(0, np.pi)
                p = _cov(s_minor * aspect, s_minor, angle)
                n = np.array([np.cos(angle + phi), np.sin(angle + phi)])
                means.append((R + rng.choice([-1.0, 0.0, 0.5]) * np.sqrt(n @ p @ n)) * n)
                covs.append(p)
    got = disk_mass(np.array(means), np.array(covs), np.zeros(2), R)
    for j, (m, p) in enumerate(zip(means, covs, strict=True)):
        for outer in (0, 1):
            assert got[j] == pytest.approx(_disk_1d_ref(m, p, np.zeros(2), R, outer),
                                           abs=TOL), (j, outer)


# ----------------------------------------------------------------- limits

@pytest.mark.parametrize("mass", [disk_mass, square_mass])
def test_tiny_covariance_gives_indicator_of_the_mean(mass):
    means = np.array([[0.0, 0.0], [R - 1e-3, 0.0], [R + 1e-3, 0.0], [0.0, -R - 1.0], [R, 0.0]])
    covs = np.tile(_cov(1e-7, 3e-8, 0.4), (5, 1, 1))
    got = mass(means, covs, np.zeros(2), R)
    np.testing.assert_allclose(got, [1.0, 1.0, 0.0, 0.0, 0.5], atol=1e-6)


def test_tiny_covariance_on_the_edge_sees_a_half_plane():
    # boundary locally straight: P ~ Phi(delta / s_n), s_n the sd along the outward normal
    p = _cov(2e-6, 5e-7, 0.9)
    for phi in (0.0, 1.0, 2.5):
        n = np.array([np.cos(phi), np.sin(phi)])
        s_n = np.sqrt(n @ p @ n)
        for delta in (-2.0, -0.3, 0.0, 1.0):
            m = (R - delta * s_n) * n
            got = disk_mass(m[None], p[None], np.zeros(2), R)[0]
            assert got == pytest.approx(ndtr(delta), abs=1e-5)


@pytest.mark.parametrize("mass,area", [(disk_mass, np.pi * R**2), (square_mass, 4 * R**2)])
def test_huge_covariance_gives_area_times_density(mass, area):
    base = _cov(1.0, 0.6, 0.5)
    for scale in (1e3, 1e5):
        p = scale**2 * base
        got = mass(np.zeros((1, 2)), p[None], np.zeros(2), R)[0]
        expected = area / (2 * np.pi * np.sqrt(np.linalg.det(p)))
        assert got == pytest.approx(expected, rel=10 * (R / scale) ** 2)


@pytest.mark.parametrize("mass", [disk_mass, square_mass])
def test_far_away_means_give_zero(mass):
    means = np.array([[1e3, 0.0], [-40.0, 30.0], [0.0, -R - 20.0], [1e6, -1e6]])
    covs = np.array([np.eye(2), _cov(3.0, 0.1, 0.3), 0.25 * np.eye(2), 1e4 * np.eye(2)])
    got = mass(means, covs, np.zeros(2), R)
    assert np.all(got >= 0.0)
    assert np.all(got < 1e-12)


def test_singular_covariances():
    # a point mass: the indicator (1/2 on the edge); a line mass: a 1-D normal probability
    point = np.zeros((3, 2, 2))
    means = np.array([[1.0, 2.0], [R, 0.0], [R + 1e-9, 0.0]])
    np.testing.assert_allclose(disk_mass(means, point, np.zeros(2), R), [1.0, 0.5, 0.0])
    np.testing.assert_allclose(square_mass(means, point, np.zeros(2), R), [1.0, 0.5, 0.0])
    np.testing.assert_allclose(square_mass(np.array([[R, R]]), point[:1], np.zeros(2), R),
                               [0.25])
    s, y0 = 2.0, 3.0
    line = np.array([[[s * s, 0.0], [0.0, 0.0]]])
    w = np.sqrt(R * R - y0 * y0)
    got = disk_mass(np.array([[0.5, y0]]), line, np.zeros(2), R)[0]
    assert got == pytest.approx(ndtr((w - 0.5) / s) - ndtr((-w - 0.5) / s), abs=1e-12)
    got = square_mass(np.array([[0.5, y0]]), line, np.zeros(2), R)[0]
    assert got == pytest.approx(ndtr((R - 0.5) / s) - ndtr((-R - 0.5) / s), abs=1e-12)
    # perfectly correlated: all the mass on the line y = x
    diag = np.array([[[1.0, 1.0], [1.0, 1.0]]])
    got = square_mass(np.array([[0.0, 0.0]]), diag, np.zeros(2), R)[0]
    assert got == pytest.approx(ndtr(R) - ndtr(-R), abs=1e-12)
    got = disk_mass(np.array([[0.0, 0.0]]), diag, np.zeros(2), R)[0]
    assert got == pytest.approx(ndtr(R / np.sqrt(2)) - ndtr(-R / np.sqrt(2)), abs=1e-12)


# ----------------------------------------------------------------- symmetry, vectorisation

def test_disk_is_invariant_under_rotation_about_the_centre():
    rng = np.random.default_rng(4)
    means = rng.normal(size=(30, 2)) * 4
    covs = np.array([_cov(*(10 ** rng.uniform(-2, 0.5, 2)), rng.uniform(0, np.pi))
                     for _ in range(30)])
    centre = np.array([1.0, -2.0])
    base = disk_mass(means + centre, covs, centre, R)
    for angle in (0.3, np.pi / 2, 2.0):
        c, s = np.cos(angle), np.sin(angle)
        rot = np.array([[c, -s], [s, c]])
        got = disk_mass(means @ rot.T + centre, rot @ covs @ rot.T, centre, R)
        np.testing.assert_allclose(got, base, atol=1e-9)


@pytest.mark.parametrize("mass", [disk_mass, square_mass])
def test_reflections_and_swaps(mass):
    rng = np.random.default_rng(5)
    means = rng.normal(size=(30, 2)) * 4
    covs = np.array([_corr(*(10 ** rng.uniform(-1.5, 0.5, 2)), rng.uniform(-0.99, 0.99))
                     for _ in range(30)])
    base = mass(means, covs, np.zeros(2), R)
    flip = np.diag([-1.0, 1.0])
    swap = np.array([[0.0, 1.0], [1.0, 0.0]])
    for t in (flip, swap, -np.eye(2)):
        got = mass(means @ t.T, t @ covs @ t.T, np.zeros(2), R)
        np.testing.assert_allclose(got, base, atol=1e-12)


@pytest.mark.parametrize("mass", [disk_mass, square_mass])
def test_vectorised_equals_per_component_and_uses_the_position_block(mass):
    cases = _random_cases(6, n=25)
    means = np.array([c[0] for c in cases])
    covs = np.array([c[1] for c in cases])
    got = mass(means, covs, np.zeros(2), R)
    one = [mass(m[None], p[None], np.zeros(2), R)[0] for m, p in cases]
    np.testing.assert_allclose(got, one, rtol=0, atol=1e-15)
    # a 4-D state: only the first two coordinates and their 2x2 block count
    big = np.zeros((25, 4, 4))
    big[:, :2, :2] = covs
    big[:, 2:, 2:] = np.eye(2) * 7.0
    big[:, :2, 2:] = big[:, 2:, :2] = 0.5
    state = np.hstack([means, np.full((25, 2), 9.0)])
    np.testing.assert_array_equal(mass(state, big, np.zeros(2), R), got)
    assert mass(np.empty((0, 2)), np.empty((0, 2, 2)), np.zeros(2), R).shape == (0,)


# ----------------------------------------------------------------- models

def test_integrated_models_scale_the_mass():
    cases = _random_cases(7, n=10)
    means = np.array([c[0] for c in cases]) + [1.0, 2.0]
    covs = np.array([c[1] for c in cases])
    sensor = np.array([1.0, 2.0])
    np.testing.assert_allclose(DiskFov(R, 0.8)(means, covs, sensor),
                               0.8 * disk_mass(means, covs, sensor, R))
    np.testing.assert_allclose(SquareFov(2 * R, 0.7)(means, covs, sensor),
                               0.7 * square_mass(means, covs, sensor, R))


@pytest.mark.parametrize("model", [DiskFov(R, 0.9, integrate=False),
                                   SquareFov(2 * R, 0.9, integrate=False)])
def test_at_mean_form_is_the_point_model_at_the_means(model):
    sensor = np.array([2.0, -1.0])
    means = sensor + np.array([[0.0, 0.0], [R, 0.0], [R + 1e-9, 0.0], [3.0, 3.0],
                               [4.0, 4.0], [-R, -R], [0.0, -10.0]])
    covs = np.tile(np.eye(2), (7, 1, 1)) * 50.0  # ignored by this form
    got = model(means, covs, sensor)
    np.testing.assert_array_equal(got, model.at_points(means, sensor))
    disk = isinstance(model, DiskFov)
    inside = ([True, True, False, True, False, False, False] if disk
              else [True, True, False, True, True, True, False])
    np.testing.assert_array_equal(got, np.where(inside, 0.9, 0.0))
    # and the limit of the integrated form as the covariance shrinks (off the edge)
    integrated = type(model)(model.radius if disk else model.side, 0.9)
    off = [0, 3, 4, 6]
    tiny = np.tile(np.eye(2), (4, 1, 1)) * 1e-12
    np.testing.assert_allclose(integrated(means[off], tiny, sensor), got[off], atol=1e-12)


def test_at_points_for_particles():
    sensor = np.array([1.0, 1.0])
    pts = sensor + np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 4.1], [4.9, -4.9], [5.1, 0.0]])
    np.testing.assert_array_equal(DiskFov(R, 0.5).at_points(pts, sensor),
                                  [0.5, 0.5, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(SquareFov(2 * R, 0.5).at_points(pts, sensor),
                                  [0.5, 0.5, 0.5, 0.5, 0.0])


def test_models_plug_into_the_gm_phd_estimator():
    from phd_swarm.core.estimators.gm_phd.filter import DetectionProbability  # noqa: F401

    model = DiskFov(R, 0.9)
    means = np.array([[0.0, 0.0, 1.0, 1.0], [20.0, 0.0, 0.0, 0.0]])
    covs = np.tile(np.eye(4), (2, 1, 1))
    got = model(means, covs, np.zeros(2))
    assert got.shape == (2,)
    assert got[0] == pytest.approx(0.9 * (1 - np.exp(-R**2 / 2)), abs=1e-12)
    assert got[1] == 0.0


# ----------------------------------------------------------------- validation

@pytest.mark.parametrize("make,match", [
    (lambda: DiskFov(0.0, 0.9), r"radius must be finite and > 0, got 0\.0"),
    (lambda: DiskFov(-1.0, 0.9), r"radius .* got -1\.0"),
    (lambda: DiskFov(np.inf, 0.9), r"radius .* got inf"),
    (lambda: DiskFov(np.nan, 0.9), r"radius .* got nan"),
    (lambda: DiskFov("big", 0.9), r"radius must be a finite number > 0, got 'big'"),
    (lambda: DiskFov(5.0, 1.5), r"p_inside must lie in \[0, 1\], got 1\.5"),
    (lambda: DiskFov(5.0, -0.1), r"p_inside .* got -0\.1"),
    (lambda: DiskFov(5.0, np.nan), r"p_inside .* got nan"),
    (lambda: SquareFov(0.0, 0.9), r"side must be finite and > 0, got 0\.0"),
    (lambda: SquareFov(10.0, 2.0), r"p_inside must lie in \[0, 1\], got 2\.0"),
])
def test_bad_parameters_are_refused(make, match):
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize("mass", [disk_mass, square_mass])
def test_bad_inputs_are_refused(mass):
    m, p = np.zeros((2, 2)), np.tile(np.eye(2), (2, 1, 1))
    c = np.zeros(2)
    with pytest.raises(ValueError, match=r"means must have shape \(J, d\) with d >= 2"):
        mass(np.zeros((2, 1)), p[:, :1, :1], c, R)
    with pytest.raises(ValueError, match=r"covs must have shape \(2, 2, 2\), got \(3, 2, 2\)"):
        mass(m, np.tile(np.eye(2), (3, 1, 1)), c, R)
    with pytest.raises(ValueError, match=r"means must be finite, row 1"):
        mass(np.array([[0.0, 0.0], [np.nan, 0.0]]), p, c, R)
    bad = p.copy()
    bad[1, 0, 1] = 2.0  # not symmetric
    with pytest.raises(ValueError, match=r"covs\[1\] position block must be symmetric positive"):
        mass(m, bad, c, R)
    bad[1, 1, 0] = 2.0  # symmetric, indefinite
    with pytest.raises(ValueError, match=r"covs\[1\] .* semi-definite, got \[\[1\.0, 2\.0\]"):
        mass(m, bad, c, R)
    bad = p.copy()
    bad[0, 0, 0] = np.inf
    with pytest.raises(ValueError, match=r"covs must be finite, row 0"):
        mass(m, bad, c, R)
    with pytest.raises(ValueError, match=r"centre must be a finite position \(2,\)"):
        mass(m, p, np.zeros(3), R)
    with pytest.raises(ValueError, match=r"centre must be a finite position"):
        mass(m, p, np.array([0.0, np.nan]), R)
    with pytest.raises(ValueError, match=r"(radius|half_width) must be finite and > 0"):
        mass(m, p, c, 0.0)


def test_bad_sensor_and_points_are_refused():
    model = SquareFov(10.0, 0.9)
    with pytest.raises(ValueError, match=r"sensor must be a finite position \(2,\)"):
        model.at_points(np.zeros((3, 2)), np.zeros(3))
    with pytest.raises(ValueError, match=r"points must have shape \(N, 2\), got \(3,\)"):
        model.at_points(np.zeros(3), np.zeros(2))
    with pytest.raises(ValueError, match=r"points must be finite"):
        DiskFov(5.0, 0.9).at_points(np.array([[np.inf, 0.0]]), np.zeros(2))
    with pytest.raises(ValueError, match=r"sensor must be a finite position"):
        DiskFov(5.0, 0.9)(np.zeros((1, 2)), np.eye(2)[None], np.zeros(3))
