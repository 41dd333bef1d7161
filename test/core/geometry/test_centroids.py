"""Tests of core.geometry.centroids: weighted centroids (Dames eq. 8) and the step (Chen eq. 3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from phd_swarm.core.geometry.centroids import (
    centroid_goal,
    control_step,
    next_position,
    step_length,
    weighted_centroid,
)
from phd_swarm.core.geometry.grid import Environment, Grid
from phd_swarm.core.geometry.ownership import bin_owners
from phd_swarm.core.geometry.partition import partition

GRID = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
SQUARE = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])


def _rectangle_of_bins(ix0: int, ix1: int, iy0: int, iy1: int) -> np.ndarray:
    iy, ix = np.meshgrid(np.arange(iy0, iy1 + 1), np.arange(ix0, ix1 + 1), indexing="ij")
    return GRID.flat_index(iy.ravel(), ix.ravel())


def test_uniform_weights_give_the_centre_of_a_rectangle_of_bins():
    idx = _rectangle_of_bins(2, 5, 3, 8)  # centres x 2.5..5.5, y 3.5..8.5
    w = np.ones(idx.size)
    goal = centroid_goal(GRID, idx, w, SQUARE, np.array([9.0, 9.0]))
    np.testing.assert_allclose(goal, [4.0, 6.0], rtol=0, atol=1e-12)


def test_a_single_weighted_bin_is_the_goal():
    idx = _rectangle_of_bins(0, 9, 0, 9)
    w = np.zeros(idx.size)
    w[GRID.flat_index(7, 2)] = 0.3
    goal = centroid_goal(GRID, idx, w, SQUARE, np.array([1.0, 1.0]))
    np.testing.assert_array_equal(goal, [2.5, 7.5])
    # A heavy bin among light ones pulls the centroid most of the way.
    w = np.full(idx.size, 1e-4) + w * 1e3
    goal = centroid_goal(GRID, idx, w, SQUARE, np.array([1.0, 1.0]))
    assert np.linalg.norm(goal - [2.5, 7.5]) < 0.01


def test_zero_weights_fall_back_to_the_cell_then_to_the_robot():
    idx = _rectangle_of_bins(0, 1, 0, 1)
    q = np.array([8.0, 8.0])
    np.testing.assert_allclose(centroid_goal(GRID, idx, np.zeros(4), SQUARE, q), [2.0, 2.0])
    empty_idx = np.empty(0, dtype=np.int64)
    np.testing.assert_allclose(centroid_goal(GRID, empty_idx, np.zeros(0), SQUARE, q),
                               [2.0, 2.0])
    np.testing.assert_array_equal(
        centroid_goal(GRID, empty_idx, np.zeros(0), np.empty((0, 2)), q), q)
    fb = np.array([1.0, 2.0])
    out = weighted_centroid(np.empty((0, 2)), np.empty(0), fb)
    np.testing.assert_array_equal(out, fb)
    out[0] = 5.0
    assert fb[0] == 1.0  # the fallback is copied, not aliased


def test_tiny_and_huge_weights_keep_their_centroid():
    x = np.array([[0.5, 0.5], [2.5, 4.5]])
    for scale in (5e-324, 1e-310, 1e300):
        np.testing.assert_allclose(weighted_centroid(x, np.array([scale, scale]), np.zeros(2)),
                                   [1.5, 2.5])
    np.testing.assert_array_equal(weighted_centroid(x, np.array([5e-324, 0.0]), np.zeros(2)),
                                  [0.5, 0.5])


def test_weight_errors_name_the_problem():
    x = np.array([[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(ValueError, match="non-negative"):
        weighted_centroid(x, np.array([1.0, -0.1]), np.zeros(2))
    with pytest.raises(ValueError, match="2 bin centres"):
        weighted_centroid(x, np.ones(3), np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        weighted_centroid(x, np.array([1.0, np.nan]), np.zeros(2))
    with pytest.raises(ValueError, match="fallback"):
        weighted_centroid(x, np.ones(2), np.zeros(3))


def test_step_length():
    assert step_length(2.0, 0.5) == 1.0
    for bad in ((0.0, 1.0), (1.0, -1.0), (np.inf, 1.0)):
        with pytest.raises(ValueError):
            step_length(*bad)


def test_control_step_saturates_and_stops_at_the_goal():
    q = np.array([1.0, 1.0])
    np.testing.assert_allclose(control_step(q, np.array([11.0, 1.0]), 2.0), [2.0, 0.0])
    np.testing.assert_allclose(control_step(q, np.array([4.0, 5.0]), 10.0), [3.0, 4.0])
    np.testing.assert_allclose(control_step(q, np.array([4.0, 5.0]), 5.0), [3.0, 4.0])
    np.testing.assert_array_equal(control_step(q, q, 1.0), [0.0, 0.0])
    np.testing.assert_array_equal(next_position(q, q, 1.0), q)
    # 0.8 + (0.2 - 0.8) is not 0.2 in float64; next_position lands on the goal anyway.
    q, g = np.array([0.8, 0.8]), np.array([0.2, 0.2])
    assert (q + control_step(q, g, 1.0) != g).any()
    np.testing.assert_array_equal(next_position(q, g, 1.0), g)
    with pytest.raises(ValueError, match="d_step"):
        control_step(q, g, 0.0)


finite = st.floats(-1e3, 1e3)


@settings(max_examples=200, deadline=None)
@given(finite, finite, finite, finite, st.floats(1e-3, 50.0))
def test_control_step_properties(qx, qy, gx, gy, d_step):
    q, g = np.array([qx, qy]), np.array([gx, gy])
    u = control_step(q, g, d_step)
    dist = np.hypot(gx - qx, gy - qy)
    assert np.linalg.norm(u) <= d_step * (1 + 1e-12)
    assert np.linalg.norm(u) == pytest.approx(min(d_step, dist), rel=1e-9, abs=1e-12)
    if dist > 0:
        # Parallel to g - q and pointing at the goal.
        assert abs(u[0] * (gy - qy) - u[1] * (gx - qx)) <= 1e-9 * d_step * dist
        assert u @ (g - q) >= 0 and np.any(u != 0)
    nxt = next_position(q, g, d_step)
    if dist <= d_step:
        np.testing.assert_array_equal(nxt, g)
    else:
        np.testing.assert_allclose(nxt, q + u)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 99), st.floats(0.0, 10.0)), min_size=1, max_size=30))
def test_weighted_centroid_is_in_the_hull_of_the_weighted_bins(entries):
    idx = np.array([e[0] for e in entries])
    w = np.array([e[1] for e in entries])
    x = GRID.centres_of(idx)
    c = weighted_centroid(x, w, np.array([-1.0, -1.0]))
    if w.sum() > 0:
        used = x[w > 0]
        assert np.all(c >= used.min(axis=0) - 1e-9) and np.all(c <= used.max(axis=0) + 1e-9)
    else:
        np.testing.assert_array_equal(c, [-1.0, -1.0])


def test_lloyd_iterations_do_not_increase_the_discrete_cost():
    # Dames eq. 7 on bins: H = sum_k phi_k |x_k - q_owner(k)|^2. Full steps of Lloyd's
    # algorithm (assign, then move to the centroid) can only decrease it.
    env = Environment(0.0, 0.0, 40.0, 40.0)
    grid = Grid(env, 1.0)
    rng = np.random.default_rng(5)
    phi = rng.uniform(0.0, 1.0, grid.size) * (grid.centres[:, 0] > 10.0)
    q = rng.uniform(0.0, 10.0, (6, 2))
    costs = []
    for _ in range(25):
        p = partition(env, q)
        owners = bin_owners(grid, q)
        costs.append(float(np.sum(phi * np.sum((grid.centres - q[owners]) ** 2, axis=1))))
        q = np.array([
            next_position(q[r], centroid_goal(grid, np.flatnonzero(owners == r),
                                              phi[owners == r], p.cells[r], q[r]), 1e3)
            for r in range(len(q))])
    assert all(b <= a * (1 + 1e-12) for a, b in zip(costs, costs[1:], strict=False))
    assert costs[-1] < 0.5 * costs[0]


def test_a_lazy_cell_is_computed_only_for_the_fallback():
    calls = []

    def cell():
        calls.append(1)
        return SQUARE

    q = np.array([1.0, 1.0])
    idx = np.arange(4)
    assert np.array_equal(centroid_goal(GRID, idx, np.ones(4), cell, q),
                          centroid_goal(GRID, idx, np.ones(4), SQUARE, q))
    assert calls == []
    np.testing.assert_array_equal(centroid_goal(GRID, idx, np.zeros(4), cell, q),
                                  centroid_goal(GRID, idx, np.zeros(4), SQUARE, q))
    assert calls == [1]
