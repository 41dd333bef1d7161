"""Tests of Chen's cumulative density (eq. 8-11), power weights (eq. 13-14) and Alg. 1."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from phd_swarm.core.controllers.power_lloyd.cumulative import (
    chen_lloyd_weights,
    cumulative_update_counts,
    cumulative_weight,
    nearest_robot_cap,
    observe_scans,
    power_weight,
)
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.geometry.ownership import bin_owners
from phd_swarm.core.geometry.partition import cells
from phd_swarm.core.geometry.polygons import points_in_polygon, polygon_area


def fresh(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Chen Alg. 1 line 3: alpha = 0, n = 0 (beta = inf)."""
    return np.zeros(size), np.zeros(size, dtype=np.int64)


def scan(alpha, n, fov: np.ndarray, has_measurement: bool):
    """One scan's eq. 9-10 on the bins of mask ``fov``: one observation, a reward if any."""
    obs = fov.astype(np.int64)
    return cumulative_update_counts(alpha, n, obs, obs * int(has_measurement))


def observe(rewards: list[bool], size: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Apply one scan per reward to a fresh state, every bin in view."""
    alpha, n = fresh(size)
    for r in rewards:
        alpha, n = scan(alpha, n, np.ones(size, dtype=bool), r)
    return alpha, n


# ---------------------------------------------------------------- eq. 9-11 by hand

def test_initial_state() -> None:
    alpha, n = fresh(4)
    for mode in ("rate", "literal"):
        np.testing.assert_array_equal(cumulative_weight(alpha, n, mode), np.zeros(4))


def test_three_observations_rewards_1_0_1() -> None:
    alpha, n = observe([True, False, True])
    assert alpha[0] == 2.0
    assert n[0] == 3
    assert cumulative_weight(alpha, n, "rate")[0] == pytest.approx(1.0 / 3.0)
    assert cumulative_weight(alpha, n, "literal")[0] == pytest.approx(3.0)
    assert cumulative_weight(alpha, n)[0] == pytest.approx(1.0 / 3.0)  # rate is default


def test_beta_is_inverse_count() -> None:
    # Eq. 9 from beta = inf: (inf^-1 + 1)^-1 = 1, then 1/2, 1/3, ...
    beta = np.inf
    alpha, n = fresh(1)
    for _ in range(5):
        beta = 1.0 / (1.0 / beta + 1.0)
        alpha, n = scan(alpha, n, np.array([True]), False)
        assert beta == pytest.approx(1.0 / n[0])


def test_literal_matches_paper_formula() -> None:
    # wc = (alpha - 1) / beta with beta = 1/n.
    alpha, n = observe([True, True, False, True, True])
    beta = 1.0 / n[0]
    assert cumulative_weight(alpha, n, "literal")[0] == pytest.approx((alpha[0] - 1) / beta)
    assert cumulative_weight(alpha, n, "rate")[0] == pytest.approx((4 - 1) / 5)


@pytest.mark.parametrize("mode", ["rate", "literal"])
def test_alpha_below_one_gives_zero(mode: str) -> None:
    alpha = np.array([0.0, 0.5, 0.999, 1.0, 2.0])
    n = np.array([0, 3, 7, 4, 4])
    wc = cumulative_weight(alpha, n, mode)
    np.testing.assert_array_equal(wc[:4], 0.0)
    assert wc[4] == pytest.approx(0.25 if mode == "rate" else 4.0)


def test_laplace_is_the_rule_of_succession() -> None:
    # Unobserved: 1/2; rewards 1, 0, 1: (2 + 1) / (3 + 2); ten empty scans: 1/12.
    alpha, n = fresh(1)
    assert cumulative_weight(alpha, n, "laplace")[0] == 0.5
    alpha, n = observe([True, False, True])
    assert cumulative_weight(alpha, n, "laplace")[0] == pytest.approx(3.0 / 5.0)
    alpha, n = observe([False] * 10)
    assert cumulative_weight(alpha, n, "laplace")[0] == pytest.approx(1.0 / 12.0)
    # Unexplored space ranks between searched-and-empty and always-rewarding space.
    alpha, n = observe([True] * 10)
    assert 1.0 / 12.0 < 0.5 < cumulative_weight(alpha, n, "laplace")[0] < 1.0


def test_only_empty_scans_give_zero() -> None:
    alpha, n = observe([False] * 10)
    assert alpha[0] == 0.0 and n[0] == 10
    assert cumulative_weight(alpha, n, "rate")[0] == 0.0
    assert cumulative_weight(alpha, n, "literal")[0] == 0.0


def test_one_reward_gives_zero_mode() -> None:
    # Gamma with shape 1 is an exponential: its mode is 0.
    alpha, n = observe([True])
    assert cumulative_weight(alpha, n, "rate")[0] == 0.0
    assert cumulative_weight(alpha, n, "literal")[0] == 0.0


def test_bins_outside_fov_unchanged() -> None:
    alpha = np.array([0.0, 2.0, 5.0, 1.0])
    n = np.array([0, 3, 9, 1])
    fov = np.array([False, True, False, True])
    new_alpha, new_n = scan(alpha, n, fov, True)
    np.testing.assert_array_equal(new_alpha, [0.0, 3.0, 5.0, 2.0])
    np.testing.assert_array_equal(new_n, [0, 4, 9, 2])
    new_alpha, new_n = scan(alpha, n, fov, False)
    np.testing.assert_array_equal(new_alpha, alpha)
    np.testing.assert_array_equal(new_n, [0, 4, 9, 2])


def test_counts_are_pure_and_checked() -> None:
    alpha, n = np.array([1.0, 2.0]), np.array([3, 4])
    a0, n0 = alpha.copy(), n.copy()
    new_alpha, new_n = cumulative_update_counts(alpha, n, np.array([2, 1]), np.array([1, 0]))
    np.testing.assert_array_equal(alpha, a0)
    np.testing.assert_array_equal(n, n0)
    np.testing.assert_array_equal(new_alpha, [2.0, 2.0])
    np.testing.assert_array_equal(new_n, [5, 5])
    assert new_n.dtype == np.int64
    for obs, rew in ((np.array([1, 1]), np.array([2, 0])), (np.array([1, 1]), [-1, 0]),
                     (np.array([1.0, 1.0]), np.array([0, 0]))):
        with pytest.raises(ValueError):
            cumulative_update_counts(alpha, n, obs, np.asarray(rew))


def test_observe_scans_counts_every_scan_of_the_step_in_place() -> None:
    grid = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
    alpha, n = fresh(grid.size)
    z = np.array([[2.0, 2.0]])
    scans = [(np.array([2.5, 2.5]), z), (np.array([3.5, 2.5]), np.empty((0, 2)))]
    observe_scans(grid, 1.0, alpha, n, scans)
    a = grid.disk_bins(scans[0][0], 1.0)
    b = grid.disk_bins(scans[1][0], 1.0)
    expect_n = np.zeros(grid.size, dtype=np.int64)
    expect_n[a] += 1
    expect_n[b] += 1
    expect_alpha = np.zeros(grid.size)
    expect_alpha[a] += 1.0
    np.testing.assert_array_equal(n, expect_n)
    np.testing.assert_array_equal(alpha, expect_alpha)
    assert n.max() == 2, "a bin in both fields of view is observed twice"


# ---------------------------------------------------------------- rate vs literal

def test_literal_grows_without_bound_rate_does_not() -> None:
    # Every other scan has a measurement: literal ~ n^2 / 2, rate -> 1/2.
    rewards = [i % 2 == 0 for i in range(1000)]
    alpha, n = observe(rewards)
    assert cumulative_weight(alpha, n, "literal")[0] == pytest.approx((500 - 1) * 1000)
    assert cumulative_weight(alpha, n, "rate")[0] == pytest.approx(499 / 1000)
    lit = [cumulative_weight(*observe(rewards[:k]), "literal")[0] for k in (10, 100, 1000)]
    assert lit[0] < lit[1] < lit[2]


def test_literal_ranks_often_watched_empty_bin_above_rarely_watched_busy_bin() -> None:
    # The paper's formula: 2 rewards in 100 looks beats 3 in 3; the rate ranks them right.
    a_often, n_often = observe([True, True] + [False] * 98)
    a_rare, n_rare = observe([True, True, True])
    lit = (cumulative_weight(a_often, n_often, "literal")[0],
           cumulative_weight(a_rare, n_rare, "literal")[0])
    rate = (cumulative_weight(a_often, n_often, "rate")[0],
            cumulative_weight(a_rare, n_rare, "rate")[0])
    assert lit[0] > lit[1]
    assert rate[0] < rate[1]


@settings(max_examples=80, deadline=None, derandomize=True)
@given(rewards=st.lists(st.booleans(), min_size=0, max_size=60))
def test_rate_in_unit_interval(rewards: list[bool]) -> None:
    alpha, n = observe(rewards)
    rate = cumulative_weight(alpha, n, "rate")[0]
    literal = cumulative_weight(alpha, n, "literal")[0]
    assert 0.0 <= rate <= 1.0
    assert rate < 1.0
    assert alpha[0] == sum(rewards) and n[0] == len(rewards)
    assert literal == pytest.approx(rate * n[0] ** 2)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1))
def test_random_fov_sequences(seed: int) -> None:
    rng = np.random.default_rng(seed)
    size, steps = 12, 25
    masks = rng.random((steps, size)) < 0.4
    rewards = rng.random(steps) < 0.5
    alpha, n = fresh(size)
    for mask, r in zip(masks, rewards, strict=True):
        alpha, n = scan(alpha, n, mask, bool(r))
    np.testing.assert_array_equal(n, masks.sum(axis=0))
    np.testing.assert_array_equal(alpha, (masks & rewards[:, None]).sum(axis=0))
    rate = cumulative_weight(alpha, n, "rate")
    assert np.all((rate >= 0) & (rate < 1))


# ---------------------------------------------------------------- power weights

def test_power_weight_values() -> None:
    assert power_weight(4.0, 100.0) == pytest.approx(0.5)
    assert power_weight(1.0, 100.0) == pytest.approx(1.0)
    assert power_weight(0.25, 100.0) == pytest.approx(2.0)
    assert isinstance(power_weight(4.0, 100.0), float)


@pytest.mark.parametrize("mass", [0.0, -0.0, -1e-12, -3.0, 1e-300, 5e-324, 1e-30])
def test_power_weight_finite_and_capped_for_zero_or_tiny_mass(mass: float) -> None:
    with np.errstate(all="raise"):
        rho = power_weight(mass, 50.0)
    assert np.isfinite(rho)
    assert rho == 50.0


def test_power_weight_infinite_mass_is_zero() -> None:
    assert power_weight(np.inf, 50.0) == 0.0


def test_power_weight_array_and_cap() -> None:
    mass = np.array([[0.0, 1e-6], [0.01, 100.0]])
    with np.errstate(all="raise"):
        rho = power_weight(mass, 20.0)
    assert rho.shape == (2, 2)
    np.testing.assert_allclose(rho, [[20.0, 20.0], [10.0, 0.1]])


def test_power_weight_monotone_decreasing() -> None:
    mass = np.concatenate([[0.0], np.logspace(-12, 6, 200)])
    rho = power_weight(mass, 1e3)
    assert np.all(np.diff(rho) <= 0)
    assert np.all(np.diff(rho[rho < 1e3]) < 0)
    assert np.all(np.isfinite(rho)) and np.all(rho <= 1e3)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(a=st.floats(0.0, 1e300), b=st.floats(0.0, 1e300),
       rho_max=st.floats(1e-3, 1e6))
def test_power_weight_monotone_and_bounded_hypothesis(a: float, b: float,
                                                      rho_max: float) -> None:
    lo, hi = min(a, b), max(a, b)
    r_lo, r_hi = power_weight(lo, rho_max), power_weight(hi, rho_max)
    assert 0.0 <= r_hi <= r_lo <= rho_max


@pytest.mark.parametrize("rho_max", [0.0, -1.0, np.inf, np.nan])
def test_power_weight_invalid_cap(rho_max: float) -> None:
    with pytest.raises(ValueError, match="rho_max"):
        power_weight(1.0, rho_max)


def test_power_weight_nan_mass() -> None:
    with pytest.raises(ValueError, match="mass"):
        power_weight(np.array([1.0, np.nan]), 10.0)


def test_power_weight_from_cell_sums_eq13_eq14() -> None:
    # Eq. 13 sums wc over the cell, eq. 14 sums the PHD; the same function serves both.
    wc = np.array([0.0, 0.5, 0.5, 0.25, 0.75])
    phd = np.array([0.0, 0.0, 0.01, 0.0, 0.0])
    assert power_weight(wc.sum(), 141.0) == pytest.approx(2.0 ** -0.5)
    assert power_weight(phd.sum(), 141.0) == pytest.approx(10.0)
    assert power_weight(np.zeros(5).sum(), 141.0) == 141.0


# ---------------------------------------------------------------- Alg. 1

def test_chen_lloyd_weights_idle_and_busy() -> None:
    phd = np.array([0.1, 0.7, 0.0])
    wc = np.array([0.3, 0.0, 0.2])
    idle = chen_lloyd_weights(False, phd, wc)
    busy = chen_lloyd_weights(True, phd, wc)
    np.testing.assert_array_equal(idle, wc)
    np.testing.assert_array_equal(busy, phd)
    idle[0] = 99.0
    busy[0] = 99.0
    assert wc[0] == 0.3 and phd[0] == 0.1  # new arrays, inputs untouched
    np.testing.assert_array_equal(chen_lloyd_weights(np.bool_(True), phd, wc), phd)


def test_chen_lloyd_weights_validation() -> None:
    with pytest.raises(ValueError, match="shape"):
        chen_lloyd_weights(True, np.zeros(3), np.zeros(4))
    with pytest.raises(ValueError, match="has_measurement"):
        chen_lloyd_weights(np.zeros(2), np.zeros(3), np.zeros(3))  # type: ignore[arg-type]


# ---------------------------------------------------------------- input validation

@pytest.mark.parametrize("alpha,n,match", [
    (np.zeros((2, 2)), np.zeros((2, 2)), "alpha"),
    (np.zeros(3), np.zeros(4), "n "),
    (np.array([-1.0, 0.0]), np.zeros(2), "alpha"),
    (np.array([np.nan, 0.0]), np.zeros(2), "alpha"),
    (np.zeros(2), np.array([1.5, 0.0]), "n "),
    (np.zeros(2), np.array([-1, 0]), "n "),
    (np.zeros(2), np.array([True, False]), "n "),
])
def test_state_validation(alpha, n, match: str) -> None:
    counts = np.zeros(np.shape(alpha), dtype=np.int64)
    with pytest.raises(ValueError, match=match):
        cumulative_update_counts(alpha, n, counts, counts)
    with pytest.raises(ValueError, match=match):
        cumulative_weight(alpha, n)


def test_weight_mode_validation() -> None:
    with pytest.raises(ValueError, match="mode"):
        cumulative_weight(np.zeros(2), np.zeros(2), "mean")


def test_cell_mass_scales_cumulative_weights_by_bin_area_but_not_phd():
    from phd_swarm.core.controllers.power_lloyd.cumulative import cell_mass

    wc = np.full(100, 0.5)  # 100 bins of 0.1 m: 1 m^2 at rate 0.5
    assert cell_mass(wc, 0.01, "cumulative") == pytest.approx(0.5)
    assert cell_mass(np.full(1, 0.5), 1.0, "cumulative") == pytest.approx(0.5)
    assert cell_mass(wc, 0.01, "phd") == pytest.approx(50.0)
    with pytest.raises(ValueError, match="kind"):
        cell_mass(wc, 0.01, "mass")


# ------------------------------------------------------- the nearest-robot guard (eq. 13)

ENV = Environment(0.0, 0.0, 100.0, 100.0)
GRID_1M = Grid(ENV, 1.0)
#: A busy robot (rho 0.5 m: 4 expected targets) between two idle ones 10 m away whose
#: uncapped rho = mass^(-1/2) is 30 m (mass 1/900).
LINE = np.array([[40.0, 50.0], [50.0, 50.0], [60.0, 50.0]])
LINE_RHO = np.array([30.0, 0.5, 30.0])


def test_an_uncapped_weight_empties_the_cell_between_two_idle_robots():
    # h = (D^2 + rho_r^2 - rho_k^2) / (2 D) = (100 + 0.25 - 900) / 20 < 0 on both sides.
    assert cells(ENV, LINE, LINE_RHO)[1].shape == (0, 2)
    assert not np.any(bin_owners(GRID_1M, LINE, LINE_RHO) == 1)


def test_the_guard_without_margin_keeps_the_robot_in_a_cell_a_bin_may_miss():
    rho = nearest_robot_cap(LINE, LINE_RHO)
    np.testing.assert_allclose(rho, [10.0, 0.5, 10.0])  # D = 10 m for every robot
    # h = (100 + 0.25 - 100) / 20 = 0.0125 m: a 0.025 m strip around x = 50, no bin centre.
    cell = cells(ENV, LINE, rho)[1]
    assert polygon_area(cell) == pytest.approx(0.025 * 100.0)
    assert points_in_polygon(LINE[1:2], cell).all()
    assert not np.any(bin_owners(GRID_1M, LINE, rho) == 1)


def test_the_guard_with_a_one_bin_margin_gives_the_robot_its_bins():
    rho = nearest_robot_cap(LINE, LINE_RHO, margin=1.0)
    # sqrt(D^2 - 2 m D) = sqrt(100 - 20) for the idle robots; 0.5 stays below it.
    np.testing.assert_allclose(rho, [np.sqrt(80.0), 0.5, np.sqrt(80.0)])
    # h = (100 + 0.25 - 80) / 20 = 1.0125 m >= m: the strip 48.99..51.01 holds x = 49.5, 50.5.
    owned = GRID_1M.centres_of(np.flatnonzero(bin_owners(GRID_1M, LINE, rho) == 1))
    assert set(np.unique(owned[:, 0])) == {49.5, 50.5} and len(owned) == 200


def test_four_robots_a_heavy_neighbour_on_each_side():
    # Robot 0 at the centre, three idle robots around it at 8, 10 and 12 m (their nearest
    # robot is robot 0); uncapped, their rho (40 m) takes all of robot 0's cell. Robot 0's
    # nearest is 8 m away, so with a 1 m margin every point within min(1, 8/2) = 1 m of it
    # is its own.
    q = np.array([[50.0, 50.0], [58.0, 50.0], [50.0, 60.0], [38.0, 50.0]])
    rho = np.array([0.2, 40.0, 40.0, 40.0])
    assert cells(ENV, q, rho)[0].shape == (0, 2)
    guarded = nearest_robot_cap(q, rho, margin=1.0)
    np.testing.assert_allclose(guarded, [0.2, np.sqrt(64 - 16), np.sqrt(100 - 20),
                                         np.sqrt(144 - 24)])
    ring = q[0] + 0.999 * np.stack([np.cos(np.linspace(0, 6.28, 32)),
                                    np.sin(np.linspace(0, 6.28, 32))], axis=1)
    assert points_in_polygon(ring, cells(ENV, q, guarded)[0]).all()


@settings(max_examples=200, deadline=None)
@given(st.integers(2, 8), st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.5, 1.0]))
def test_every_robot_stays_in_its_own_cell_under_the_guard(n, seed, margin):
    rng = np.random.default_rng(seed)
    q = rng.uniform(0.0, 100.0, (n, 2))
    rho = np.exp(rng.uniform(np.log(0.01), np.log(150.0), n))  # up to the diagonal
    guarded = nearest_robot_cap(q, rho, margin=margin)
    assert np.all(guarded <= rho)
    polys = cells(ENV, q, guarded)
    d2 = np.sum((q[:, None] - q[None]) ** 2, axis=-1) + np.diag(np.full(n, np.inf))
    nearest = np.sqrt(d2.min(axis=1))
    for r in range(n):
        assert polys[r].shape[0] >= 3 and polygon_area(polys[r]) > 0.0
        # Point 2 of the docstring: the disk of radius min(m, D_r / 2) is r's (a bit inside).
        reach = 0.999 * min(margin, nearest[r] / 2) if margin > 0 else 0.0
        ring = q[r] + reach * np.stack([np.cos(np.arange(16) * np.pi / 8),
                                        np.sin(np.arange(16) * np.pi / 8)], axis=1)
        inside = ring[np.all((ring >= 0.0) & (ring <= 100.0), axis=1)]
        assert points_in_polygon(np.vstack([q[r:r + 1], inside]), polys[r]).all()
    if margin == 1.0:
        owners = bin_owners(GRID_1M, q, guarded)
        own_bin = GRID_1M.flat_index(*np.floor(q[:, ::-1]).astype(int).T)
        far = nearest > np.sqrt(2.0)
        assert np.array_equal(owners[own_bin[far]], np.flatnonzero(far))


def test_the_guard_leaves_a_lone_robot_and_zeroes_coincident_ones():
    np.testing.assert_array_equal(nearest_robot_cap(np.array([[1.0, 2.0]]), [7.0]), [7.0])
    q = np.array([[5.0, 5.0], [5.0, 5.0], [9.0, 5.0]])
    np.testing.assert_allclose(nearest_robot_cap(q, [3.0, 3.0, 3.0]), [0.0, 0.0, 3.0])
    with pytest.raises(ValueError, match="shape"):
        nearest_robot_cap(q, [1.0, 2.0])
    with pytest.raises(ValueError, match="margin"):
        nearest_robot_cap(q, [1.0, 2.0, 3.0], margin=-1.0)
