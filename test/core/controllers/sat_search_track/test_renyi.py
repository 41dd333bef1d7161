"""Tests of the tracking control of Papaioannou et al. (Sec. V-C a, eq. 8, 17, 18).

The reward of eq. 18 is checked against eq. 17 evaluated directly: the set integral of
``f1^alpha f0^(1-alpha)`` summed over cardinalities, the n-fold integrals done on product
grids, for a predicted Poisson density and its pseudo-update with one measurement; and the
particle version against a fine-grid quadrature of eq. 18 in the paper's range-bearing
setting. The pseudo-update is checked against :func:`smc_phd.update`, one action at a time.
"""

from __future__ import annotations

from functools import reduce
from math import factorial

import numpy as np
import pytest
from scipy.stats import multivariate_normal, norm

from phd_swarm.core.controllers.sat_search_track.agent_moves import (
    action_offsets,
    admissible_positions,
)
from phd_swarm.core.controllers.sat_search_track.renyi import (
    best_action,
    predicted_measurements,
    pseudo_update_weights,
    renyi_reward,
    square_clutter,
)
from phd_swarm.core.controllers.sat_search_track.tracking import RenyiTracking
from phd_swarm.core.estimators.smc_phd.filter import ParticleSet, update
from phd_swarm.core.sensors.fov_detection import SquareFov
from phd_swarm.core.sensors.range_bearing_model import (
    RangeBearingSensor,
    clutter_density_square,
    range_bearing_log_likelihood,
)

PAPER = RangeBearingSensor()
SIDE = 10.0
P_IN = 0.99
RATE = 10.0


def _cloud(rng, centres, n_each, sd=0.7):
    centres = np.asarray(centres, dtype=float)
    return np.concatenate([c + sd * rng.standard_normal((n_each, 2)) for c in centres])


# ---------------------------------------------------------------- predicted measurements


def test_predicted_measurements_are_noise_free_h_of_the_visible_estimates():
    est = np.array([[3.0, 4.0], [-5.0, 0.0], [8.0, 8.0], [0.0, 0.0]])
    acts = np.array([[0.0, 0.0], [4.0, 4.0], [20.0, 20.0]])
    pred = predicted_measurements(est, acts, PAPER, SIDE)
    fov = SquareFov(SIDE, 1.0, integrate=False)
    for u, s in enumerate(acts):
        np.testing.assert_allclose(pred.z[u], PAPER.measure(est, s), rtol=0, atol=1e-15)
        np.testing.assert_array_equal(pred.member[u], fov.at_points(est, s) > 0)
    # (-5, 0) lies on the edge of the square around the origin: closed, so it is seen.
    np.testing.assert_array_equal(pred.member[0], [True, True, False, True])
    np.testing.assert_array_equal(pred.counts, [3, 3, 0])
    np.testing.assert_allclose(pred.for_action(0)[0], [5.0, np.arctan2(4.0, 3.0)])
    assert pred.for_action(2).shape == (0, 2)


def test_literal_union_keeps_every_estimate():
    est = np.array([[3.0, 4.0], [30.0, 0.0]])
    pred = predicted_measurements(est, np.zeros((2, 2)), PAPER, SIDE, only_visible=False)
    assert pred.member.all()
    empty = predicted_measurements(np.empty((0, 2)), np.zeros((3, 2)), PAPER, SIDE)
    assert empty.z.shape == (3, 0, 2) and empty.member.shape == (3, 0)


# ---------------------------------------------------------------- pseudo-update = smc update


@pytest.mark.parametrize("clutter", ["square", "constant", "zero"])
@pytest.mark.parametrize("with_newborn", [False, True])
def test_pseudo_update_equals_smc_phd_update_for_each_action(clutter, with_newborn):
    rng = np.random.default_rng(11)
    targets = np.array([[2.0, 1.0], [4.5, -3.0], [-6.0, 2.0]])
    pos = _cloud(rng, targets, 400)
    states = np.concatenate([pos, rng.standard_normal((pos.shape[0], 2))], axis=1)
    n = states.shape[0]
    weights = rng.uniform(0.5, 1.5, n) * 3.0 / n
    newborn = rng.random(n) < 0.2 if with_newborn else np.zeros(n, dtype=bool)
    acts, _ = admissible_positions(np.array([0.5, 0.0]), action_offsets(2.0, 2, 8),
                                   (-50.0, -50.0, 50.0, 50.0))
    pred = predicted_measurements(targets, acts, PAPER, SIDE)
    kappa = {"square": square_clutter(pred.z, SIDE, RATE), "constant": 0.05,
             "zero": 0.0}[clutter]
    got = pseudo_update_weights(states, weights, acts, pred.z, pred.member, P_IN, SIDE,
                                PAPER, kappa, newborn=newborn if with_newborn else None)
    loglik = range_bearing_log_likelihood(PAPER)
    fov = SquareFov(SIDE, P_IN, integrate=False)
    particles = ParticleSet(weights, states, newborn)
    assert pred.counts.min() < pred.counts.max()          # some actions see fewer targets
    for u, s in enumerate(acts):
        zu = pred.for_action(u)
        ku = (clutter_density_square(zu, s, SIDE, RATE) if clutter == "square"
              else kappa)
        ref = update(particles, zu, lambda z, x, s=s: loglik(z, x, s),
                     fov.at_points(states[:, :2], s), ku).particles.weights
        # smc_phd.update may leave ~1e-304 of a row's largest on a particle it cannot detect.
        np.testing.assert_allclose(got[u], ref, rtol=1e-11, atol=1e-300)


def test_position_index_picks_the_position_out_of_a_4d_state():
    rng = np.random.default_rng(3)
    pos = _cloud(rng, [[2.0, 2.0]], 300)
    vel = rng.standard_normal(pos.shape)
    paper_order = np.stack([pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]], axis=1)
    w = np.full(300, 1.0 / 300)
    acts = np.array([[0.0, 0.0], [2.0, 0.0]])
    pred = predicted_measurements([[2.0, 2.0]], acts, PAPER, SIDE)
    a = pseudo_update_weights(pos, w, acts, pred.z, pred.member, P_IN, SIDE, PAPER, 0.01)
    b = pseudo_update_weights(paper_order, w, acts, pred.z, pred.member, P_IN, SIDE, PAPER,
                              0.01, position_index=(0, 2))
    np.testing.assert_array_equal(a, b)


# ---------------------------------------------------------------- eq. 17 -> eq. 18


def _renyi_by_set_integral(v1, v0, dx, alpha, n_explicit=3, n_max=40):
    """Eq. 17 for Poisson f1, f0 with intensities v1, v0 tabulated on a 1-D grid.

    ``1/(alpha-1) log sum_n 1/n! int_{X^n} f1^alpha f0^(1-alpha)``, with
    ``f(x_1..x_n) = e^-lambda prod_i v(x_i)`` and lambda the quadrature mass of v. For
    n <= n_explicit the n-fold integral is a sum over the n-dimensional product grid of the
    multi-object densities themselves (their product form is not used); beyond, the product
    form ``e^-(alpha lambda1 + (1-alpha) lambda0) I^n`` (Fubini), whose first terms the
    explicit ones check. Terms beyond n_max are below 1e-30 for the masses used here.
    """
    lam1, lam0 = v1.sum() * dx, v0.sum() * dx
    single = np.sum(v1**alpha * v0 ** (1.0 - alpha)) * dx
    total = 0.0
    for n in range(n_max + 1):
        factored = np.exp(-alpha * lam1 - (1.0 - alpha) * lam0) * single**n
        if n <= n_explicit:
            f1 = np.exp(-lam1) * (reduce(np.multiply.outer, [v1] * n) if n else 1.0)
            f0 = np.exp(-lam0) * (reduce(np.multiply.outer, [v0] * n) if n else 1.0)
            explicit = np.sum(f1**alpha * f0 ** (1.0 - alpha)) * dx**n
            assert explicit == pytest.approx(factored, rel=1e-10)
            total += explicit / factorial(n)
        else:
            total += factored / factorial(n)
    return np.log(total) / (alpha - 1.0)


@pytest.mark.parametrize("alpha", [0.25, 0.5, 0.8])
def test_eq18_equals_eq17_set_integral_on_a_grid(alpha):
    # 1-D predicted intensity (mass 1.7) and its pseudo-update (eq. 8) with one predicted
    # measurement at the estimate, p_D = 0.9 on [-1, 2], linear-Gaussian likelihood.
    dx = 0.1
    x = np.arange(-5.0, 6.0 + dx / 2, dx)
    v0 = 1.7 * norm.pdf(x, 0.5, 1.2)
    p_d = np.where((x >= -1.0) & (x <= 2.0), 0.9, 0.0)
    g = norm.pdf(0.5, x, 0.6)
    kappa = 0.15
    tau = np.sum(p_d * g * v0) * dx
    v1 = ((1.0 - p_d) + p_d * g / (kappa + tau)) * v0
    direct = _renyi_by_set_integral(v1, v0, dx, alpha)
    assert direct > 0.05
    assert renyi_reward(v0 * dx, v1 * dx, alpha) == pytest.approx(direct, rel=1e-10)


def test_particle_reward_matches_a_fine_grid_quadrature_of_eq18():
    # The paper's sensor (1 m, 1 degree), target 3.6 m from the agent, 3% of its mass
    # outside the sensing square; plane-uniform clutter lambda_c = 10.
    s = np.array([0.0, 0.0])
    mu = np.array([3.5, 1.0])
    cov = np.array([[0.8**2, 0.15], [0.15, 0.6**2]])
    lam0, alpha = 1.3, 0.5
    pred = predicted_measurements(mu[None], s[None], PAPER, SIDE)
    z = pred.z[0]
    kappa = clutter_density_square(z, s, SIDE, RATE)[0]

    h = 0.012                          # 5 grid points per cross-range sd (0.064 m)
    xs = np.arange(mu[0] - 5 * 0.8, mu[0] + 5 * 0.8, h)
    ys = np.arange(mu[1] - 5 * 0.6, mu[1] + 5 * 0.6, h)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    da = h * h
    v0 = lam0 * multivariate_normal(mu, cov).pdf(pts)
    p_d = SquareFov(SIDE, P_IN, integrate=False).at_points(pts, s)
    g = np.exp(PAPER.log_likelihood(z, pts, s)[0])
    tau = np.sum(p_d * g * v0) * da
    v1 = ((1.0 - p_d) + p_d * g / (kappa + tau)) * v0
    grid = (v0.sum() * da + alpha / (1 - alpha) * v1.sum() * da
            - 1 / (1 - alpha) * np.sum(v1**alpha * v0 ** (1 - alpha)) * da)
    assert 0.3 < grid < 3.0

    # The grid points as particles of weight v0 dA: the pseudo-update is v1 dA (tight).
    w_grid = pseudo_update_weights(pts, v0 * da, s[None], pred.z, pred.member, P_IN, SIDE,
                                   PAPER, kappa)[0]
    np.testing.assert_allclose(w_grid, v1 * da, rtol=1e-9, atol=1e-300)
    assert renyi_reward(v0 * da, w_grid, alpha) == pytest.approx(grid, rel=1e-9)

    # Particles drawn from the predicted intensity (loose: Monte Carlo sd 0.3% over seeds).
    rng = np.random.default_rng(2024)
    n = 40_000
    states = rng.multivariate_normal(mu, cov, size=n)
    tracker = RenyiTracking(alpha=alpha, side=SIDE, p_d_inside=P_IN, clutter_rate=RATE)
    reward = tracker.rewards(states, np.full(n, lam0 / n), mu[None], s[None])
    assert reward.shape == (1,)
    assert reward[0] == pytest.approx(grid, rel=0.02)


# ---------------------------------------------------------------- zero and positive


def test_reward_is_zero_when_nothing_changes():
    rng = np.random.default_rng(5)
    states = _cloud(rng, [[60.0, 60.0]], 500)                 # far from every square
    w = np.full(500, 1.0 / 500)
    acts, _ = admissible_positions(np.zeros(2), action_offsets(2.0, 2, 8),
                                   (-100.0, -100.0, 100.0, 100.0))
    tracker = RenyiTracking()
    rewards = tracker.rewards(states, w, np.empty((0, 2)), acts)
    np.testing.assert_array_equal(rewards, np.zeros(len(acts)))
    updated = pseudo_update_weights(states, w, acts, np.zeros((len(acts), 0, 2)), None,
                                    P_IN, SIDE, PAPER, 0.1)
    np.testing.assert_array_equal(updated, np.broadcast_to(w, updated.shape))
    w2 = rng.uniform(0.0, 2.0, 1000)
    assert renyi_reward(w2, w2, 0.5) == 0.0
    np.testing.assert_array_equal(renyi_reward(w2, np.stack([w2, w2]), 0.3), [0.0, 0.0])


@pytest.mark.parametrize("alpha", [0.1, 0.5, 0.9])
def test_reward_is_positive_and_equals_eq18_as_printed(alpha):
    rng = np.random.default_rng(int(alpha * 100))
    for _ in range(50):
        n = int(rng.integers(1, 200))
        w = rng.exponential(1.0, n) * (rng.random(n) < 0.9)
        wp = w * rng.uniform(0.0, 3.0, n) + rng.exponential(0.1, n) * (rng.random(n) < 0.1)
        r = renyi_reward(w, wp, alpha)
        printed = (w.sum() + alpha / (1 - alpha) * wp.sum()
                   - 1 / (1 - alpha) * np.sum(wp**alpha * w ** (1 - alpha)))
        assert r > 0.0
        assert r == pytest.approx(printed, rel=1e-9, abs=1e-12)


def test_a_missed_detection_alone_is_information():
    # No predicted measurement but particles in the square: w' = (1 - p_D) w, and with
    # alpha = 1/2 R = 2 sum (w/2 + w'/2 - sqrt(w w')) = 2 (0.5 + 0.005 - 0.1) = 0.81.
    w = np.array([0.5, 0.5])
    assert renyi_reward(w, (1.0 - P_IN) * w, 0.5) == pytest.approx(0.81, rel=1e-12)


# ---------------------------------------------------------------- choosing the action


def test_an_action_whose_square_covers_the_targets_wins():
    rng = np.random.default_rng(9)
    targets = np.array([[50.0, 50.0], [51.0, 49.0]])
    states = _cloud(rng, targets, 1000, sd=0.4)
    w = np.full(len(states), 2.0 / len(states))
    acts, ok = admissible_positions(np.array([42.0, 50.0]), action_offsets(2.0, 2, 8),
                                    (0.0, 0.0, 100.0, 100.0))
    action, rewards = RenyiTracking().choose(states, w, targets, acts, ok)
    half = SIDE / 2
    covers = np.array([np.all(np.abs(targets - s) <= half) for s in acts])
    assert rewards[0] == 0.0 and not covers[0]          # staying sees nothing
    assert covers[action]
    assert rewards[action] > 0.5 and rewards[action] == rewards.max()
    assert np.all(rewards[covers] > rewards[~covers].max())


def test_ties_go_to_the_lowest_index():
    assert best_action(np.array([0.5, 1.0, 1.0, 0.2])) == 1
    assert best_action(np.array([0.5, 1.0, 1.0, 0.2]),
                       np.array([True, False, True, True])) == 2
    assert best_action(np.zeros(17)) == 0
    # Equal up to rounding counts as a tie; exact comparison with tie_rtol = 0.
    assert best_action(np.array([1.0, 1.0 + 1e-13, 0.5])) == 0
    assert best_action(np.array([1.0, 1.0 + 1e-13, 0.5]), tie_rtol=0.0) == 1
    # Every action sees nothing: staying (0), or the first admissible one.
    states = np.array([[90.0, 90.0]])
    acts = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    tracker = RenyiTracking()
    assert tracker.choose(states, [1.0], [[90.0, 90.0]], acts)[0] == 0
    assert tracker.choose(states, [1.0], [[90.0, 90.0]], acts,
                          np.array([False, True, True]))[0] == 1


def test_literal_union_credits_an_action_for_a_target_it_cannot_see():
    # Target A inside the square, target B outside it: with the plane-uniform clutter
    # (kappa = 0 outside the square) B's measurement is handed to A's particles.
    rng = np.random.default_rng(1)
    targets = np.array([[2.0, 0.0], [12.0, 0.0]])
    states = _cloud(rng, targets, 1000, sd=0.5)
    w = np.full(2000, 1.0 / 1000)
    s = np.zeros((1, 2))
    sound = RenyiTracking().rewards(states, w, targets, s)[0]
    literal = RenyiTracking(only_visible=False).rewards(states, w, targets, s)[0]
    assert literal > sound + 0.5


# ---------------------------------------------------------------- bad inputs


def _args(**over):
    args = dict(states=np.zeros((3, 2)), weights=np.ones(3), action_positions=np.zeros((2, 2)),
                z=np.ones((2, 1, 2)), member=None, p_d_inside=0.9, side=10.0,
                sensor_model=PAPER, clutter=0.1)
    args.update(over)
    return args


@pytest.mark.parametrize("over, match", [
    (dict(states=np.zeros(3)), "states must have shape"),
    (dict(weights=np.ones(4)), "weights must have shape"),
    (dict(weights=-np.ones(3)), "weights must be >= 0"),
    (dict(weights=np.array([1.0, np.nan, 1.0])), "weights must be finite"),
    (dict(action_positions=np.zeros((2, 3))), "action_positions must have shape"),
    (dict(action_positions=np.zeros((0, 2))), "action_positions must have shape"),
    (dict(z=np.ones((3, 1, 2))), "z must have shape"),
    (dict(z=np.full((2, 1, 2), np.inf)), "z .* must be finite"),
    (dict(member=np.ones((2, 2), bool)), "member must be a boolean array"),
    (dict(member=np.ones((2, 1))), "member must be a boolean array"),
    (dict(p_d_inside=1.5), "p_d_inside must lie in"),
    (dict(side=0.0), "side"),
    (dict(clutter=-1.0), "clutter must be >= 0"),
    (dict(clutter=np.ones(3)), "clutter must be a number or broadcast"),
    (dict(sensor_model="paper"), "sensor_model must be a RangeBearingSensor"),
    (dict(position_index=(0, 0)), "position_index"),
    (dict(newborn=np.zeros(3)), "newborn must be a boolean array"),
])
def test_pseudo_update_refuses_bad_input(over, match):
    with pytest.raises(ValueError, match=match):
        pseudo_update_weights(**_args(**over))


def test_other_functions_refuse_bad_input():
    with pytest.raises(ValueError, match="alpha"):
        renyi_reward(np.ones(2), np.ones(2), 1.0)
    with pytest.raises(ValueError, match="alpha"):
        RenyiTracking(alpha=0.0)
    with pytest.raises(ValueError, match="updated must have shape"):
        renyi_reward(np.ones(2), np.ones(3))
    with pytest.raises(ValueError, match="updated must be >= 0"):
        renyi_reward(np.ones(2), -np.ones(2))
    with pytest.raises(ValueError, match="estimates must have shape"):
        predicted_measurements(np.zeros((2, 3)), np.zeros((1, 2)), PAPER, SIDE)
    with pytest.raises(ValueError, match="side"):
        predicted_measurements(np.zeros((2, 2)), np.zeros((1, 2)), PAPER, -1.0)
    with pytest.raises(ValueError, match="no admissible action"):
        best_action(np.ones(3), np.zeros(3, bool))
    with pytest.raises(ValueError, match="rewards must be finite"):
        best_action(np.array([1.0, np.nan]))
    with pytest.raises(ValueError, match="admissible must be a boolean"):
        best_action(np.ones(3), np.ones(3))
    with pytest.raises(ValueError, match="p_d_inside"):
        RenyiTracking(p_d_inside=-0.1)
    with pytest.raises(ValueError, match="clutter_rate"):
        RenyiTracking(clutter_rate=-1.0)
    with pytest.raises(ValueError, match="clutter_density"):
        RenyiTracking(clutter_density=float("nan"))
    with pytest.raises(ValueError, match="z must have shape"):
        square_clutter(np.zeros((2, 2)), SIDE, RATE)

