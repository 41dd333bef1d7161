"""The spatial grid graph of Shirsat & Berman Sec. II-III and its random walk (eq. 4)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp

from phd_swarm.core.controllers.dtds_walk.grid_graph import GridGraph, lattice_count, lattice_range


def brute_degrees(nx: int, ny: int, neighbours: int) -> np.ndarray:
    """d_i by looking at every pair of nodes: neighbours are 1 (or sqrt 2) spacing apart."""
    ij = np.array([(i, j) for j in range(ny) for i in range(nx)])
    d = np.abs(ij[:, None, :] - ij[None, :, :])
    if neighbours == 4:
        adjacent = d.sum(axis=2) == 1
    else:
        adjacent = (d.max(axis=2) == 1)
    return adjacent.sum(axis=1)


def test_nodes_cover_the_rectangle_edges_included():
    g = GridGraph(0.0, 0.0, 5.0, 5.0, 1.0)
    assert (g.nx, g.ny, g.size) == (6, 6, 36)
    assert np.array_equal(g.positions[0], [0.0, 0.0])
    assert np.array_equal(g.positions[-1], [5.0, 5.0])
    assert np.array_equal(g.positions[1], [1.0, 0.0])  # x fastest
    assert np.array_equal(g.positions[6], [0.0, 1.0])


def test_a_side_that_is_not_a_whole_number_of_spacings_ends_at_its_last_whole_spacing():
    g = GridGraph(1.0, 2.0, 6.7, 4.0, 1.0)
    assert (g.nx, g.ny) == (6, 3)
    assert g.positions[:, 0].max() == 6.0 and g.positions[:, 1].max() == 4.0
    # 5 / 0.1 is 49.999... in floating point; the last node is still on the edge.
    g = GridGraph(0.0, 0.0, 5.0, 5.0, 0.1)
    assert g.nx == 51 and g.positions[:, 0].max() == pytest.approx(5.0)
    assert lattice_count(0.0, 0.0, 1.0) == 1  # a degenerate side: one node


def test_lattice_range_keeps_the_nodes_inside_an_interval():
    assert lattice_range(0.0, 1.0, 11, 2.5, 6.0) == (3, 6)
    assert lattice_range(0.0, 0.1, 51, 0.3, 0.3) == (3, 3)  # 0.3 / 0.1 = 2.9999...
    first, last = lattice_range(0.0, 1.0, 11, 2.2, 2.8)
    assert first > last


@pytest.mark.parametrize("neighbours", [4, 8])
@pytest.mark.parametrize("shape", [(3, 3), (4, 3), (1, 5), (6, 6)])
def test_degrees_match_a_brute_force_count(neighbours, shape):
    nx, ny = shape
    g = GridGraph(0.0, 0.0, nx - 1.0, ny - 1.0, 1.0, neighbours)
    assert np.array_equal(g.degrees, brute_degrees(nx, ny, neighbours))


def test_degrees_of_corner_edge_and_inner_nodes():
    four = GridGraph(0.0, 0.0, 2.0, 2.0, 1.0, 4)
    eight = GridGraph(0.0, 0.0, 2.0, 2.0, 1.0, 8)
    corner, edge, inner = 0, 1, 4
    assert [four.degrees[i] for i in (corner, edge, inner)] == [2, 3, 4]
    assert [eight.degrees[i] for i in (corner, edge, inner)] == [3, 5, 8]
    assert sorted(four.neighbours_of(inner)) == [1, 3, 5, 7]
    assert sorted(eight.neighbours_of(inner)) == [0, 1, 2, 3, 5, 6, 7, 8]
    assert sorted(eight.neighbours_of(corner)) == [1, 3, 4]
    assert four.longest_move == 1.0 and eight.longest_move == pytest.approx(np.sqrt(2))


@pytest.mark.parametrize("neighbours", [4, 8])
def test_transition_matrix_is_eq4_row_stochastic_with_the_stated_stationary_law(neighbours):
    g = GridGraph(0.0, 0.0, 4.0, 3.0, 1.0, neighbours)
    p = g.transition_matrix
    assert sp.issparse(p) and p.format == "csr" and p.shape == (g.size, g.size)
    dense = p.toarray()
    assert np.allclose(dense.sum(axis=1), 1.0)
    for i in range(g.size):
        allowed = set(g.neighbours_of(i)) | {i}
        assert set(np.flatnonzero(dense[i])) == allowed
        assert np.allclose(dense[i, sorted(allowed)], 1.0 / (g.degrees[i] + 1))
    pi = g.stationary
    assert pi.sum() == pytest.approx(1.0)
    assert np.allclose(pi, (g.degrees + 1) / np.sum(g.degrees + 1))
    assert np.allclose(pi @ dense, pi)
    flow = pi[:, None] * dense  # detailed balance: pi_i p_ij = pi_j p_ji
    assert np.allclose(flow, flow.T)
    # The only stationary law: the eigenvalue 1 of P^T is simple.
    w = np.linalg.eigvals(dense.T)
    assert np.sum(np.isclose(w, 1.0)) == 1


def test_the_stationary_law_is_not_uniform_a_uniform_one_is_not_stationary():
    g = GridGraph(0.0, 0.0, 2.0, 2.0, 1.0, 8)
    u = np.full(g.size, 1.0 / g.size)
    assert not np.allclose(u @ g.transition_matrix.toarray(), u)


def test_edges_are_undirected_with_a_self_loop_at_every_node():
    g = GridGraph(0.0, 0.0, 3.0, 2.0, 1.0, 8)
    e = g.edges
    assert len(e) == g.size + g.degrees.sum()
    assert np.array_equal(e[:g.size], np.column_stack([np.arange(g.size)] * 2))
    pairs = {tuple(x) for x in e}
    assert all((j, i) in pairs for i, j in pairs)


def test_node_of_is_the_nearest_node():
    g = GridGraph(-1.0, 2.0, 4.0, 5.5, 0.5, 4)
    assert np.array_equal(g.node_of(g.positions), np.arange(g.size))
    rng = np.random.default_rng(3)
    pts = rng.uniform([-3.0, 0.0], [6.0, 8.0], size=(500, 2))
    brute = np.argmin(np.sum((pts[:, None, :] - g.positions[None]) ** 2, axis=2), axis=1)
    got = g.node_of(pts)
    d_got = np.hypot(*(g.positions[got] - pts).T)
    d_brute = np.hypot(*(g.positions[brute] - pts).T)
    assert np.allclose(d_got, d_brute)
    assert g.node_of(np.zeros((4, 3, 2))).shape == (4, 3)
    assert g.node_of([4.0, 5.5]) == g.size - 1


def test_node_of_point_is_node_of_for_one_point():
    g = GridGraph(-1.0, 2.0, 4.0, 5.5, 0.5, 4)
    pts = np.random.default_rng(4).uniform([-3.0, 0.0], [6.0, 8.0], size=(300, 2))
    pts = np.vstack([pts, g.positions, g.positions + 0.25])          # half-way points too
    assert [g.node_of_point(x, y) for x, y in pts.tolist()] == g.node_of(pts).tolist()


@pytest.mark.parametrize("neighbours", [4, 8])
def test_step_draws_each_allowed_move_with_probability_one_over_d_plus_one(neighbours):
    g = GridGraph(0.0, 0.0, 3.0, 3.0, 1.0, neighbours)
    rng = np.random.default_rng(12345)
    draws = 40_000
    for node in (0, 1, 5):  # corner, edge, inner
        nxt = g.step(rng, np.full(draws, node))
        allowed = np.sort(np.append(g.neighbours_of(node), node))
        assert set(np.unique(nxt)) == set(allowed)
        counts = np.array([np.sum(nxt == j) for j in allowed])
        p = 1.0 / (g.degrees[node] + 1)
        # Each count is Binomial(draws, p): within 5 sd at this fixed seed. A walk without
        # the self-loop (p = 1/d) or uniform over the 4/8 moves would be far outside.
        sd = np.sqrt(draws * p * (1 - p))
        assert np.all(np.abs(counts - draws * p) < 5 * sd)
        wrong = 1.0 / g.degrees[node]
        assert np.all(np.abs(counts[allowed != node] - draws * wrong) > 5 * sd)


def test_step_is_vectorised_reproducible_and_keeps_the_shape():
    g = GridGraph(0.0, 0.0, 5.0, 5.0, 1.0, 8)
    nodes = np.arange(g.size).reshape(4, 9)
    a = g.step(np.random.default_rng(7), nodes)
    b = g.step(np.random.default_rng(7), nodes)
    assert a.shape == (4, 9) and np.array_equal(a, b)
    assert not np.array_equal(a, g.step(np.random.default_rng(8), nodes))
    one = g.step(np.random.default_rng(7), 14)
    assert one in set(g.neighbours_of(14)) | {14}


def test_a_long_walk_visits_nodes_in_proportion_to_the_stationary_law():
    g = GridGraph(0.0, 0.0, 2.0, 2.0, 1.0, 8)
    rng = np.random.default_rng(2)
    nodes = np.zeros(2000, dtype=np.int64)
    visits = np.zeros(g.size)
    for k in range(300):
        nodes = g.step(rng, nodes)
        if k >= 50:
            visits += np.bincount(nodes, minlength=g.size)
    freq = visits / visits.sum()
    assert np.allclose(freq, g.stationary, atol=0.004)
    assert not np.allclose(freq, 1.0 / g.size, atol=0.004)


@pytest.mark.parametrize("args, match", [
    ((0.0, 0.0, -1.0, 1.0, 1.0), "bounds"),
    ((0.0, 0.0, np.inf, 1.0, 1.0), "bounds"),
    ((0.0, 0.0, 1.0, 1.0, 0.0), "spacing"),
    ((0.0, 0.0, 1.0, 1.0, np.nan), "spacing"),
])
def test_bad_arguments_are_refused(args, match):
    with pytest.raises(ValueError, match=match):
        GridGraph(*args)


@pytest.mark.parametrize("neighbours", [6, 0, True])
def test_only_4_or_8_neighbours(neighbours):
    with pytest.raises(ValueError, match="neighbours must be 4 or 8"):
        GridGraph(0.0, 0.0, 1.0, 1.0, 1.0, neighbours)


def test_brute_force_helper_agrees_on_a_hand_count():
    # 3 x 2 grid, 8 neighbours: corners have 3, the middle of the long sides 5.
    assert list(brute_degrees(3, 2, 8)) == [3, 5, 3, 3, 5, 3]
    assert list(itertools.islice(brute_degrees(3, 2, 4), 3)) == [2, 3, 2]
