"""Exact meeting times on the DTDS random walk (Shirsat & Berman Sec. IV, eq. 7-8)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from phd_swarm.core.analysis import renewal_exact as renewal
from phd_swarm.core.analysis.renewal_simulation import (
    meeting_events,
    simulate_meetings,
    start_nodes,
    window_averages,
)
from phd_swarm.core.controllers.dtds_walk.grid_graph import GridGraph

#: 3 x 3 nodes with diagonals: degrees 3, 5 and 8, the least uniform stationary law.
SMALL = GridGraph(0.0, 0.0, 2.0, 2.0, 1.0, 8)
#: 3 x 2 nodes, 4 neighbours: small enough for dense Kronecker products.
TINY = GridGraph(0.0, 0.0, 2.0, 1.0, 1.0, 4)


def dense_chain(graph: GridGraph, robots: int, event: str):
    """Brute force: Q = P ⊗ ... ⊗ P dense, the set A, and pi ⊗ ... ⊗ pi, by enumeration."""
    n = renewal.chain_robots(robots, event)
    p = graph.transition_matrix.toarray()
    q = p
    for _ in range(n - 1):
        q = np.kron(q, p)
    states = list(itertools.product(range(graph.size), repeat=n))
    if event == "team":
        in_a = [len(set(s)) < n for s in states]
    else:
        in_a = [any(s[0] == s[j] for j in range(1, n)) for s in states]
    pi = np.array([math.prod(graph.stationary[list(s)]) for s in states])
    return q, np.array(in_a), pi


def dense_mean_hit(q, in_a, mu):
    """E_mu[min{k >= 1: psi_k in A}] by a dense solve of h = 1 + Q_BB h."""
    b = ~in_a
    h = np.zeros(len(in_a))
    h[b] = np.linalg.solve(np.eye(b.sum()) - q[np.ix_(b, b)], np.ones(b.sum()))
    return 1.0 + mu @ (q @ h)


@pytest.mark.parametrize("robots", [2, 3, 4])
def test_stationary_meeting_probabilities_match_enumeration(robots):
    pi = TINY.stationary
    pair = robot = team = 0.0
    for s in itertools.product(range(TINY.size), repeat=robots):
        w = math.prod(pi[list(s)])
        pair += w * (s[0] == s[1])
        robot += w * any(s[0] == s[j] for j in range(1, robots))
        team += w * (len(set(s)) < robots)
    assert renewal.pair_meeting_probability(TINY) == pytest.approx(pair, rel=1e-12)
    assert renewal.pair_meeting_probability(TINY) == pytest.approx(np.sum(pi ** 2))
    assert renewal.robot_meeting_probability(TINY, robots) == pytest.approx(robot, rel=1e-12)
    assert renewal.team_meeting_probability(TINY, robots) == pytest.approx(team, rel=1e-12)
    for event, value in (("pair", pair), ("robot", robot), ("team", team)):
        assert renewal.meeting_probability(TINY, robots, event) == pytest.approx(value)
        assert renewal.mean_interarrival(TINY, robots, event) == pytest.approx(1 / value)


def test_more_robots_than_nodes_always_meet():
    assert renewal.team_meeting_probability(TINY, TINY.size + 1) == 1.0


def test_elementary_symmetric_polynomial():
    x = np.array([0.5, 2.0, 3.0, 0.1])
    for k in range(6):
        brute = sum(math.prod(c) for c in itertools.combinations(x, k))
        assert renewal.elementary_symmetric(x, k) == pytest.approx(brute, rel=1e-12)


@pytest.mark.parametrize("event", renewal.EVENTS)
def test_kac_mean_and_first_meeting_means_match_a_dense_brute_force(event):
    q, in_a, pi = dense_chain(TINY, 3, event)
    pi_a = np.where(in_a, pi, 0.0) / pi[in_a].sum()
    assert dense_mean_hit(q, in_a, pi_a) == pytest.approx(
        renewal.mean_interarrival(TINY, 3, event), rel=1e-10)
    uniform = np.full(len(pi), 1.0 / len(pi))
    for start, mu in (("stationary", pi), ("uniform", uniform), ("meeting", pi_a)):
        exact = dense_mean_hit(q, in_a, mu)
        assert renewal.mean_first_meeting(TINY, 3, event, start) == pytest.approx(
            exact, rel=1e-8)
        assert renewal.first_meeting_distribution(TINY, 3, event, start).mean == \
            pytest.approx(exact, rel=1e-9)


@pytest.mark.parametrize("event", ["pair", "robot"])
def test_entry_probability_matches_a_dense_brute_force(event):
    q, in_a, pi = dense_chain(TINY, 3, event)
    entries = pi[~in_a] @ q[np.ix_(~in_a, in_a)].sum(axis=1)
    assert renewal.entry_probability(TINY, 3, event) == pytest.approx(entries, rel=1e-12)
    assert renewal.mean_time_between_entries(TINY, 3, event) > \
        renewal.mean_interarrival(TINY, 3, event)


def test_entry_probability_of_the_team_is_not_offered():
    with pytest.raises(ValueError, match="pair and robot"):
        renewal.entry_probability(TINY, 3, "team")


@pytest.mark.parametrize("event", renewal.EVENTS)
def test_first_meeting_distribution_sums_to_one_and_kac_holds(event):
    pa = renewal.meeting_probability(SMALL, 3, event)
    ret = renewal.first_meeting_distribution(SMALL, 3, event, "meeting")
    assert ret.pmf[0] == 0.0 and np.all(ret.pmf >= 0)
    assert ret.pmf.sum() + ret.remaining == pytest.approx(1.0, abs=1e-14)
    assert ret.remaining < 1e-12
    assert np.allclose(ret.survival, 1.0 - np.cumsum(ret.pmf), atol=1e-12)
    assert ret.mean == pytest.approx(1.0 / pa, rel=1e-10)  # Kac
    stat = renewal.first_meeting_distribution(SMALL, 3, event, "stationary")
    # Reversibility: P_pi(tau = k) = pi(A) P_{pi_A}(tau >= k) = pi(A) P_{pi_A}(tau > k-1).
    k = min(len(stat.pmf), len(ret.survival) + 1)
    assert np.allclose(stat.pmf[1:k], pa * ret.survival[:k - 1], atol=1e-14)
    # ... so the first meeting from stationarity takes longer than the mean gap.
    assert stat.mean > ret.mean * 1.03


def test_first_meeting_from_given_nodes():
    far = renewal.first_meeting_distribution(SMALL, 2, "pair", start=[0, 8])
    near = renewal.first_meeting_distribution(SMALL, 2, "pair", start=[0, 1])
    # Opposite corners of 3 x 3 with diagonals: both must move to the centre to meet first.
    assert far.pmf[1] == pytest.approx(1 / 16)  # both step to the centre, 1/4 each
    assert near.mean < far.mean
    assert renewal.mean_first_meeting(SMALL, 2, "pair", [0, 8]) == pytest.approx(far.mean)
    # Extra robots are ignored by the pair event.
    assert renewal.mean_first_meeting(SMALL, 5, "pair", [0, 8, 3, 3, 3]) == \
        pytest.approx(far.mean)


def test_composite_starts():
    for start in renewal.STARTS:
        mu = renewal.composite_start(SMALL, 3, "robot", start)
        assert mu.shape == (9, 9, 9) and mu.sum() == pytest.approx(1.0)
    mu = renewal.composite_start(SMALL, 3, "robot", "meeting")
    assert np.all(mu[~renewal.meeting_mask(9, 3, "robot")] == 0)
    with pytest.raises(ValueError, match="start"):
        renewal.composite_start(SMALL, 3, "robot", "somewhere")
    with pytest.raises(ValueError, match="node indices"):
        renewal.composite_start(SMALL, 3, "robot", [0, 9, 1])


def test_meeting_mask_and_events_by_hand():
    mask = renewal.meeting_mask(3, 3, "robot")
    assert mask[0, 0, 2] and mask[0, 2, 0] and not mask[1, 2, 2]
    assert renewal.meeting_mask(3, 3, "team")[1, 2, 2]
    assert renewal.meeting_mask(3, 7, "pair").shape == (3, 3)
    nodes = np.array([[1, 2, 2, 5], [0, 1, 2, 3], [4, 4, 4, 4]])
    pair = meeting_events(nodes, "pair")  # pairs (0,1) (0,2) (0,3) (1,2) (1,3) (2,3)
    assert pair.tolist() == [[False, False, False, True, False, False], [False] * 6,
                             [True] * 6]
    assert meeting_events(nodes, "robot").tolist() == [
        [False, True, True, False], [False] * 4, [True] * 4]
    assert meeting_events(nodes, "team").tolist() == [[True], [False], [True]]


def test_too_large_a_composite_chain_is_refused():
    with pytest.raises(ValueError, match="max_states"):
        renewal.first_meeting_distribution(SMALL, 3, "team", max_states=700)
    with pytest.raises(ValueError, match="max_states"):
        renewal.mean_first_meeting(SMALL, 3, "team", max_states=700)
    with pytest.raises(ValueError, match="robots"):
        renewal.mean_interarrival(SMALL, 1, "robot")
    with pytest.raises(ValueError, match="event"):
        renewal.mean_interarrival(SMALL, 3, "anyone")


@pytest.mark.parametrize("event", renewal.EVENTS)
def test_kac_mean_agrees_with_a_long_seeded_simulation_and_wrong_formulas_do_not(event):
    sim = simulate_meetings(SMALL, np.random.default_rng(2024), 3, 2000, 200, event)
    assert sim.pending == 0 and sim.walked >= 2000
    mean, half = sim.interarrival(z=4.0)  # a 4-sigma interval: no failure by chance
    exact = renewal.mean_interarrival(SMALL, 3, event)
    assert abs(mean - exact) < half
    pi = SMALL.stationary
    wrong = {
        # a uniform stationary law (1 / S per node), the union bound (N - 1) sum pi^2
        # for a robot, C(N, 2) sum pi^2 for the team, and the first meeting from
        # stationarity (not the mean gap)
        "pair": [SMALL.size, renewal.mean_first_meeting(SMALL, 3, "pair")],
        "robot": [1 / (2 * pi @ pi), renewal.mean_first_meeting(SMALL, 3, "robot")],
        "team": [1 / (3 * pi @ pi), renewal.mean_first_meeting(SMALL, 3, "team")],
    }[event]
    for w in wrong:
        assert abs(mean - w) > 2 * half


def test_first_meeting_distribution_and_mean_agree_with_simulation():
    runs = 20_000
    sim = simulate_meetings(SMALL, np.random.default_rng(99), 2, 1, runs, "pair",
                                    "uniform")
    assert sim.censored == 0
    exact = renewal.first_meeting_distribution(SMALL, 2, "pair", "uniform")
    mean, half = sim.first_meeting(z=4.0)
    assert abs(mean - exact.mean) < half
    assert abs(mean - renewal.mean_interarrival(SMALL, 2, "pair")) > half
    first = sim.first.ravel()
    for k in (1, 2, 3, 5, 8, 13, 21):
        p = 1.0 - exact.survival[k]  # P(tau <= k)
        sd = np.sqrt(p * (1 - p) / runs)
        assert abs(np.mean(first <= k) - p) < 5 * sd


def test_simulation_is_reproducible_and_vectorised_over_runs():
    a = simulate_meetings(SMALL, np.random.default_rng(5), 4, 300, 7, "robot")
    b = simulate_meetings(SMALL, np.random.default_rng(5), 4, 300, 7, "robot")
    assert np.array_equal(a.interval_sums, b.interval_sums)
    assert np.array_equal(a.first, b.first) and a.first.shape == (7, 4)
    assert a.interval_counts.shape == (7,)
    c = simulate_meetings(SMALL, np.random.default_rng(5), 4, 300, 7, "pair")
    assert c.first.shape == (7, 6)
    nodes = start_nodes(SMALL, np.random.default_rng(0), (3, 2), [1, 7])
    assert nodes.tolist() == [[1, 7]] * 3


def test_window_averages():
    long = window_averages(SMALL, np.random.default_rng(1), 3, 4000, 30, "pair")
    assert long.shape == (30,)
    assert np.mean(long) == pytest.approx(renewal.mean_interarrival(SMALL, 3, "pair"),
                                          rel=0.05)
    big = GridGraph(0.0, 0.0, 20.0, 20.0, 1.0)
    far = window_averages(big, np.random.default_rng(1), 2, 2, 4, "pair",
                                  start=[0, big.size - 1])
    assert np.all(np.isnan(far))  # no meeting in 2 steps from opposite corners
