"""Tests for the grid PHD filter functions (Dames 2020 eq. 3-6, Sec. III)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from phd_swarm.core.estimators.grid_phd import filter as phd_grid
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.geometry.polygons import positions_in_sorted
from phd_swarm.core.models import (
    DiskDetection,
    RandomWalkMotion,
    chen_clustered,
    dames_moving,
    dames_static,
)
from phd_swarm.core.scan import Scan

GRID = Grid(Environment(0.0, 0.0, 20.0, 16.0), 0.5)  # nx = 40, ny = 32
MODELS = replace(dames_static(), detection=DiskDetection(p_d=0.8, radius=3.0))
ALL = np.arange(GRID.size)
PROPS = settings(max_examples=25, deadline=None)


def _random_weights(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(0.0, 0.05, GRID.size)


def _scan(sensor, z, robot_id=0) -> Scan:
    return Scan(robot_id=robot_id, step=0, sensor=np.asarray(sensor, float),
                z=np.asarray(z, float).reshape(-1, 2))


def _update(w: np.ndarray, scan: Scan, grid: Grid = GRID, models=MODELS) -> np.ndarray:
    """One scan on a whole-map image, as the central filter does.

    The field of view's bins go through :func:`phd_grid.update_bins`; the others stay.
    """
    out = w.copy()
    fov = grid.disk_bins(scan.sensor, models.detection.radius)
    if fov.size:
        out[fov] = phd_grid.update_bins(grid, models, fov, w[fov], scan)
    return out


def _full_eta(w: np.ndarray, scan: Scan) -> tuple[np.ndarray, np.ndarray]:
    """Return eta over all bins and the clutter, by brute force over the whole map."""
    ps = phd_grid.psi(MODELS, GRID.centres, scan.z, scan.sensor)
    clutter = MODELS.clutter.intensity(scan.z)
    return clutter + ps @ w, clutter


# ---------------------------------------------------------------- update (eq. 4-6)

def test_hand_computed_one_bin_one_measurement():
    grid = Grid(Environment(0.0, 0.0, 3.0, 3.0), 1.0)
    models = replace(MODELS, detection=DiskDetection(p_d=0.8, radius=0.5))
    w = np.full(9, 0.2)
    scan = _scan([1.5, 1.5], [[1.5, 2.0]])
    # Only the centre bin (flat 4, centre (1.5, 1.5)) is in the 0.5 m disk.
    g = math.exp(-0.5 * 0.5 ** 2 / 0.25) / (2.0 * math.pi * 0.25)   # [1/m^2]
    psi = 0.8 * g
    eta = 3.66e-3 + psi * 0.2
    expected_centre = (1.0 - 0.8) * 0.2 + psi * 0.2 / eta
    out = _update(w, scan, grid, models)
    assert out[4] == pytest.approx(expected_centre, rel=1e-14)
    np.testing.assert_array_equal(np.delete(out, 4), np.delete(w, 4))
    # By hand: g = e^-0.5 / (pi / 2) = 0.386132, psi = 0.308906, eta = 0.065441,
    # w' = 0.04 + 0.061781 / 0.065441 = 0.984072.
    assert out[4] == pytest.approx(0.984072, abs=1e-6)


@PROPS
@given(seed=st.integers(0, 2 ** 32 - 1), sx=st.floats(-2.0, 22.0), sy=st.floats(-2.0, 18.0))
def test_empty_scan_scales_fov_by_missed_detection(seed, sx, sy):
    w = _random_weights(seed)
    scan = _scan([sx, sy], np.empty((0, 2)))
    out = _update(w, scan)
    fov = GRID.disk_bins(scan.sensor, MODELS.detection.radius)
    rest = np.setdiff1d(ALL, fov)
    np.testing.assert_array_equal(out[fov], (1.0 - 0.8) * w[fov])
    assert out[rest].tobytes() == w[rest].tobytes()


@PROPS
@given(seed=st.integers(0, 2 ** 32 - 1), m=st.integers(1, 6))
def test_update_mass_accounting(seed, m):
    # Total after = sum (1 - p_d) w + sum_z (eta_z - c_z) / eta_z: each measurement adds
    # exactly the fraction of it that the PHD (not clutter) explains.
    rng = np.random.default_rng(seed)
    w = _random_weights(seed)
    sensor = rng.uniform([0.0, 0.0], [20.0, 16.0])
    z = sensor + rng.uniform(-3.5, 3.5, (m, 2))
    scan = _scan(sensor, z)
    out = _update(w, scan)
    pd = MODELS.detection.probability(GRID.centres, sensor)
    eta, clutter = _full_eta(w, scan)
    expected = np.sum((1.0 - pd) * w) + np.sum((eta - clutter) / eta)
    assert out.sum() == pytest.approx(expected, rel=1e-12)
    # Per measurement, the mass added is sum_j psi_z w_j / eta_z.
    ps = phd_grid.psi(MODELS, GRID.centres, z, sensor)
    added = np.sum(ps * w, axis=1) / eta
    np.testing.assert_allclose(added, (eta - clutter) / eta, rtol=1e-9, atol=1e-15)


def test_update_matches_dense_eq4():
    rng = np.random.default_rng(7)
    w = _random_weights(7)
    scan = _scan([10.0, 8.0], [[10.3, 8.1], [11.0, 6.0], [9.0, 9.5]])
    ps = phd_grid.psi(MODELS, GRID.centres, scan.z, scan.sensor)
    pd = MODELS.detection.probability(GRID.centres, scan.sensor)
    eta, _ = _full_eta(w, scan)
    dense = (1.0 - pd) * w + sum(ps[i] * w / eta[i] for i in range(3))
    out = _update(w, scan)
    np.testing.assert_allclose(out, dense, rtol=1e-13, atol=0.0)
    # Any order of the field of view's bins gives the same update, bin for bin, up to the
    # order of eta's sum.
    fov = GRID.disk_bins(scan.sensor, MODELS.detection.radius)
    perm = rng.permutation(fov)
    out_perm = phd_grid.update_bins(GRID, MODELS, perm, w[perm], scan)
    np.testing.assert_allclose(out_perm, out[perm], rtol=1e-14, atol=0.0)


def test_psi_shape_and_zero_outside_fov():
    centres = np.array([[10.0, 8.0], [12.9, 8.0], [13.1, 8.0]])
    z = np.array([[10.0, 8.0], [12.0, 8.0]])
    ps = phd_grid.psi(MODELS, centres, z, np.array([10.0, 8.0]))
    assert ps.shape == (2, 3)
    assert np.all(ps[:, 2] == 0.0) and np.all(ps[:, :2] > 0.0)
    assert ps[0, 0] == pytest.approx(0.8 / (2.0 * math.pi * 0.25), rel=1e-15)
    assert phd_grid.psi(MODELS, centres, np.empty((0, 2)), np.zeros(2)).shape == (0, 3)


def test_update_weights_zero_eta_contributes_nothing():
    w = np.array([0.0, 0.3])
    pd = np.array([0.8, 0.0])
    ps = np.array([[2.0, 0.0]])
    out = phd_grid.update_weights(w, pd, ps, np.array([0.0]))
    np.testing.assert_array_equal(out, [0.0, 0.3])
    out = phd_grid.update_weights(w, pd, np.empty((0, 2)), np.empty(0))
    np.testing.assert_array_equal(out, (1.0 - pd) * w)


@PROPS
@given(seed=st.integers(0, 2 ** 32 - 1), parts=st.integers(1, 6))
def test_eta_partials_over_a_partition_sum_to_eta(seed, parts):
    rng = np.random.default_rng(seed)
    w = _random_weights(seed)
    sensor = rng.uniform([2.0, 2.0], [18.0, 14.0])
    scan = _scan(sensor, sensor + rng.uniform(-3.0, 3.0, (4, 2)))
    owner = rng.integers(0, parts, GRID.size)
    partials = []
    for r in range(parts):
        flat = np.nonzero(owner == r)[0]
        pos = positions_in_sorted(flat, GRID.disk_bins(sensor, MODELS.detection.radius))
        ps = phd_grid.psi(MODELS, GRID.centres_of(flat[pos]), scan.z, sensor)
        partials.append(phd_grid.eta_partial(ps, w[flat[pos]]))
    clutter = MODELS.clutter.intensity(scan.z)
    eta, _ = _full_eta(w, scan)
    np.testing.assert_allclose(phd_grid.eta_total(partials, clutter), eta, rtol=1e-13)


def test_eta_total_adds_in_the_given_order():
    parts = [np.array([1e16]), np.array([1.0]), np.array([-1e16])]
    assert phd_grid.eta_total(parts, np.array([0.5]))[0] == 0.5 + ((1e16 + 1.0) - 1e16)
    assert phd_grid.eta_total([], np.array([0.25, 0.5])).tolist() == [0.25, 0.5]


def _disjoint_sensors(draw_seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(draw_seed)
    a = rng.uniform([0.0, 0.0], [20.0, 16.0])
    while True:
        b = rng.uniform([0.0, 0.0], [20.0, 16.0])
        if np.hypot(*(a - b)) > 2 * MODELS.detection.radius:
            return a, b


@PROPS
@given(seed=st.integers(0, 2 ** 32 - 1))
def test_updates_commute_when_fields_of_view_are_disjoint(seed):
    rng = np.random.default_rng(seed)
    w = _random_weights(seed)
    a, b = _disjoint_sensors(seed)
    sa = _scan(a, a + rng.uniform(-3.0, 3.0, (rng.integers(0, 4), 2)), robot_id=1)
    sb = _scan(b, b + rng.uniform(-3.0, 3.0, (rng.integers(0, 4), 2)), robot_id=2)
    ab = _update(_update(w, sa), sb)
    ba = _update(_update(w, sb), sa)
    assert ab.tobytes() == ba.tobytes()


def test_updates_do_not_commute_when_fields_of_view_overlap():
    # Two sensors 3 m apart, both detecting one target between them, plus a miss-only scan
    # over part of the first one's field of view: the order changes the result.
    w = np.full(GRID.size, 0.01)
    sa = _scan([8.0, 8.0], [[9.5, 8.0]], robot_id=1)
    sb = _scan([11.0, 8.0], [[9.6, 8.1], [12.0, 9.0]], robot_id=2)
    ab = _update(_update(w, sa), sb)
    ba = _update(_update(w, sb), sa)
    assert np.max(np.abs(ab - ba)) > 1e-6


# ---------------------------------------------------------------- prediction (eq. 3)

def _kernels():
    return {
        "dames_1m": dames_moving().motion.kernel(1.0),          # 5x5, direct
        "dames_0.25m": dames_moving().motion.kernel(0.25),      # 17x17, FFT
        "chen_0.5m": chen_clustered().motion.kernel(0.5),       # 5x5
        "wide": RandomWalkMotion(sd=1.0, truncation=3.0).kernel(0.5),  # 13x13, FFT
    }


@pytest.mark.parametrize("name", list(_kernels()))
@pytest.mark.parametrize("method", ["direct", "fft", "auto"])
def test_prediction_conserves_mass_away_from_the_boundary(name, method):
    ker = _kernels()[name]
    k = ker.shape[0] // 2
    w = np.zeros(GRID.shape)
    rng = np.random.default_rng(3)
    w[k:-k, k:-k] = rng.uniform(0.0, 0.1, (GRID.ny - 2 * k, GRID.nx - 2 * k))
    out = phd_grid.predict_image(w, ker, 1.0, 0.0, method=method)
    fft = method == "fft" or (method == "auto" and ker.size > phd_grid.DIRECT_MAX_TAPS)
    # By FFT, outputs below FFT_REL_FLOOR of the largest are dropped as round-off: what
    # the kernel's far tail moves into empty bins (here ~1e-12 of the mass).
    lost = phd_grid.FFT_REL_FLOOR * out.max() * np.count_nonzero(out == 0) if fft else 0.0
    assert abs(out.sum() - w.sum()) <= 1e-12 * w.sum() + lost
    assert np.all(out >= 0.0)


@pytest.mark.parametrize("method", ["direct", "fft"])
def test_prediction_loses_mass_crossing_the_boundary(method):
    ker = dames_moving().motion.kernel(1.0)   # 5x5, offsets -2..2 bins
    grid = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
    w = np.zeros(grid.shape)
    w[0, 0] = 1.0         # corner: only offsets >= 0 in both axes stay inside
    w[5, 1] = 2.0         # one from the left edge: offsets of -2 in x leave
    out = phd_grid.predict_image(w, ker, 1.0, 0.0, method=method)
    expected = ker[2:, 2:].sum() + 2.0 * ker[:, 1:].sum()
    assert out.sum() == pytest.approx(expected, rel=1e-13)
    assert out.sum() < 3.0 - 0.1


def test_identity_prediction_is_exact():
    rng = np.random.default_rng(4)
    w = rng.uniform(0.0, 1.0, GRID.shape)
    ps = rng.choice([0.5, 1.0], GRID.shape)
    birth = rng.uniform(0.0, 1e-3, GRID.shape)
    out = phd_grid.predict_image(w, dames_static().motion.kernel(0.5), ps, birth)
    assert out.tobytes() == (ps * w + birth).tobytes()


def test_birth_adds_exactly_the_birth_mass():
    models = dames_moving()
    grid = Grid(Environment(0.0, 0.0, 30.0, 20.0), 1.0)
    ker = models.motion.kernel(1.0)
    ps = models.survival.probability(grid).reshape(grid.shape)
    birth = models.birth.mass(grid).reshape(grid.shape)
    out = phd_grid.predict_image(np.zeros(grid.shape), ker, ps, birth)
    np.testing.assert_array_equal(out, birth)
    w = np.random.default_rng(5).uniform(0.0, 0.01, grid.shape)
    diff = (phd_grid.predict_image(w, ker, ps, birth)
            - phd_grid.predict_image(w, ker, ps, 0.0))
    np.testing.assert_allclose(diff, birth, rtol=0.0, atol=1e-17)
    # Survival acts before motion: p_s = 0.5 on a mass in the 2 m ring halves it.
    w = np.zeros(grid.shape)
    w[1, 10] = 1.0
    moved = phd_grid.predict_image(w, ker, ps, 0.0)
    assert moved.sum() == pytest.approx(0.5 * ker[1:, :].sum(), rel=1e-13)


@pytest.mark.parametrize("shape", [(5, 5), (7, 3), (9, 13), (1, 5)])
def test_direct_and_fft_convolution_agree_with_brute_force(shape):
    rng = np.random.default_rng(6)
    ker = rng.uniform(0.0, 1.0, shape)       # asymmetric on purpose
    ker /= ker.sum()
    mass = rng.uniform(0.0, 1.0, (11, 14))
    mass[rng.uniform(size=mass.shape) < 0.5] = 0.0
    # out[y, x] = sum_o ker[K + o] mass[(y, x) - o]: mass moves by the offset o.
    ky, kx = shape[0] // 2, shape[1] // 2
    brute = np.zeros_like(mass)
    for oy in range(-ky, ky + 1):
        for ox in range(-kx, kx + 1):
            src = np.zeros_like(mass)
            ys, xs = slice(max(oy, 0), mass.shape[0] + min(oy, 0)), \
                slice(max(ox, 0), mass.shape[1] + min(ox, 0))
            yd, xd = slice(max(-oy, 0), mass.shape[0] + min(-oy, 0)), \
                slice(max(-ox, 0), mass.shape[1] + min(-ox, 0))
            src[ys, xs] = mass[yd, xd]
            brute += ker[ky + oy, kx + ox] * src
    direct = phd_grid.convolve_mass(mass, ker, "direct")
    fft = phd_grid.convolve_mass(mass, ker, "fft")
    np.testing.assert_allclose(direct, brute, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(fft, brute, rtol=0.0, atol=1e-14)
    assert np.all(fft >= 0.0)


@pytest.mark.parametrize("tiny", [1e-8, 1e-14, 1e-25])
def test_fft_outputs_are_accurate_or_zero(tiny):
    # A searched-out region (masses `tiny` times the rest) next to an unsearched one: the
    # FFT's round-off (~1e-15 of the largest output) would swamp the searched region's
    # masses; the floor sets those outputs to 0 and keeps the others accurate.
    ker = chen_clustered().motion.kernel(0.1)                      # 29 x 29
    rng = np.random.default_rng(3)
    mass = 1e-3 * rng.uniform(0.5, 1.0, (150, 150))
    mass[:, 50:] *= tiny * rng.uniform(0.5, 1.0, (150, 100))
    direct = phd_grid.convolve_mass(mass, ker, "direct")
    fft = phd_grid.convolve_mass(mass, ker, "fft")
    kept = fft > 0
    np.testing.assert_allclose(fft[kept], direct[kept], rtol=1e-5)
    assert direct[~kept].max(initial=0.0) < 1e-8 * direct.max()
    assert kept[:, :40].all(), "unsearched masses are kept"
    if tiny < 1e-9:
        assert not kept[:, 80:].any(), "round-off is not kept as mass"


def test_one_hot_moves_by_the_kernel_offset():
    ker = np.zeros((3, 3))
    ker[2, 1] = 1.0                      # always move by +1 bin in y
    mass = np.zeros((4, 4))
    mass[1, 2] = 1.0
    for method in ("direct", "fft"):
        out = phd_grid.convolve_mass(mass, ker, method)
        assert out[2, 2] == pytest.approx(1.0, abs=1e-15)
        assert out.sum() == pytest.approx(1.0, abs=1e-14)


def test_convolve_mass_rejects_bad_input():
    with pytest.raises(ValueError, match="odd"):
        phd_grid.convolve_mass(np.zeros((3, 3)), np.ones((2, 2)))
    with pytest.raises(ValueError, match="method"):
        phd_grid.convolve_mass(np.zeros((3, 3)), np.ones((3, 3)), method="fast")


# ---------------------------------------------------------------- spread (Sec. III-B)

@PROPS
@given(seed=st.integers(0, 2 ** 32 - 1), parts=st.integers(1, 5),
       name=st.sampled_from(sorted(_kernels())))
def test_spread_over_a_partition_sums_to_the_full_prediction(seed, parts, name):
    ker = _kernels()[name]
    rng = np.random.default_rng(seed)
    w = rng.uniform(0.0, 0.05, GRID.size)
    w[rng.uniform(size=GRID.size) < 0.3] = 0.0
    full = phd_grid.predict_image(w.reshape(GRID.shape), ker, 1.0, 0.0).ravel()
    # Contiguous-ish cells (like Voronoi cells): owners by the nearest of a few seeds.
    seeds = rng.uniform([0.0, 0.0], [20.0, 16.0], (parts, 2))
    owner = np.argmin(np.linalg.norm(GRID.centres[:, None] - seeds[None], axis=-1), axis=1)
    total = np.zeros(GRID.size)
    for r in range(parts):
        flat = np.nonzero(owner == r)[0]
        flat_out, w_out = phd_grid.spread(GRID, flat, w[flat], ker)
        assert np.all(np.diff(flat_out) > 0)
        assert flat_out.min() >= 0 and flat_out.max() < GRID.size
        assert np.isin(flat, flat_out).all()
        total[flat_out] += w_out
    # By FFT, each part drops its outputs below FFT_REL_FLOOR of its largest output.
    floor = parts * phd_grid.FFT_REL_FLOOR * full.max() \
        if ker.size > phd_grid.DIRECT_MAX_TAPS else 0.0
    np.testing.assert_allclose(total, full, rtol=0.0,
                               atol=1e-15 * max(w.max(), 1e-300) + floor)


def test_spread_returns_the_kernel_reach_of_the_bins():
    grid = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
    ker = dames_moving().motion.kernel(1.0)    # 13 non-zero taps: offsets within 2 m
    assert np.count_nonzero(ker) == 13
    flat_out, w_out = phd_grid.spread(grid, np.array([grid.flat_index(5, 5)]),
                                      np.array([0.0]), ker)
    assert flat_out.size == 13 and np.all(w_out == 0.0)
    # Near the corner, the reach is clipped to E and the mass leaving E is lost.
    flat_out, w_out = phd_grid.spread(grid, np.array([0]), np.array([1.0]), ker)
    iy, ix = grid.unravel(flat_out)
    assert iy.max() == 2 and ix.max() == 2 and flat_out.size == 6
    assert w_out.sum() == pytest.approx(ker[2:, 2:].sum(), rel=1e-14)
    # Identity kernel: the same bins, the same masses.
    flat = np.array([3, 17, 42])
    out = phd_grid.spread(grid, flat, np.array([0.1, 0.2, 0.3]), np.ones((1, 1)))
    np.testing.assert_array_equal(out[0], flat)
    np.testing.assert_array_equal(out[1], [0.1, 0.2, 0.3])
    empty = phd_grid.spread(grid, np.empty(0, int), np.empty(0), ker)
    assert empty[0].size == 0 and empty[1].size == 0
