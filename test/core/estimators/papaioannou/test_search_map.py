"""The search map of Papaioannou et al.: eq. 7 (decay), eq. 9 (update), eq. 10, V-B(c)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.estimators.papaioannou.search_map import (
    DEFAULT_DECAY,
    SearchGrid,
    check_values,
    initial_values,
    max_merge,
    predict,
    searched_fraction,
    unvisited,
    update,
)


@pytest.fixture
def grid() -> SearchGrid:
    """4 x 3 nodes of 1 m on [0, 4] x [0, 3]; sensing square of side 2 m (half side 1 m).

    Node centres: x in {0.5, 1.5, 2.5, 3.5}, y in {0.5, 1.5, 2.5}; flat index iy * 4 + ix:

        y = 2.5:   8  9 10 11
        y = 1.5:   4  5  6  7
        y = 0.5:   0  1  2  3
    """
    return SearchGrid(0.0, 0.0, 4.0, 3.0, node_size=1.0, side=2.0)


def mask(size: int, nodes: list[int]) -> np.ndarray:
    m = np.zeros(size, dtype=bool)
    m[nodes] = True
    return m


def test_nodes_are_region_centres_in_flat_order(grid):
    assert (grid.nx, grid.ny, grid.size) == (4, 3, 12)
    assert np.array_equal(grid.positions[0], [0.5, 0.5])
    assert np.array_equal(grid.positions[1], [1.5, 0.5])  # x fastest
    assert np.array_equal(grid.positions[4], [0.5, 1.5])
    assert np.array_equal(grid.positions[11], [3.5, 2.5])
    assert grid.area == 12.0 and grid.node_area == 1.0
    assert grid.bounds == (0.0, 0.0, 4.0, 3.0)
    assert int(grid.flat_index(2, 3)) == 11
    iy, ix = grid.unravel(np.array([6]))
    assert (int(iy[0]), int(ix[0])) == (1, 2)
    assert np.array_equal(grid.node_of(np.array([[2.2, 1.7], [4.0, 3.0], [5.0, 0.0]])),
                          [6, 11, -1])
    with pytest.raises(AttributeError):
        grid.side = 3.0  # frozen


def test_inside_is_the_closed_square_edges_included(grid):
    # At (1.5, 1.5) with half side 1: x in {0.5, 1.5, 2.5}, every y; the nodes at exactly
    # 1 m along an axis (and the corners at (1, 1)) are on the closed square's edge.
    assert np.array_equal(grid.inside([1.5, 1.5]), mask(12, [0, 1, 2, 4, 5, 6, 8, 9, 10]))
    # Just beyond the edge: the node at x = 2.5 is 1 + 1e-6 m away.
    assert np.array_equal(grid.inside([1.5 - 1e-6, 0.5]), mask(12, [0, 1, 4, 5]))
    # A smaller square sees only the node it sits on; a point between nodes sees none.
    assert np.array_equal(grid.inside([2.5, 1.5], side=1.0), mask(12, [6]))
    assert not grid.inside([2.0, 1.0], side=0.5).any()


def test_inside_keeps_an_edge_node_despite_rounding_in_the_position():
    g = SearchGrid(0.0, 0.0, 4.0, 1.0, node_size=1.0, side=1.4)
    s = np.array([0.1 + 0.7, 0.5])  # 0.7999999999999999: the node at x = 1.5 is 0.7 away
    assert abs(1.5 - s[0]) > 0.7  # in floating point it is just outside
    assert np.array_equal(g.inside(s), [True, True, False, False])


def test_inside_is_vectorised_over_positions(grid):
    positions = np.array([[1.5, 1.5], [3.5, 0.5], [0.5, 2.5]])
    many = grid.inside(positions)
    assert many.shape == (3, 12)
    for row, s in zip(many, positions, strict=True):
        assert np.array_equal(row, grid.inside(s))
    brute = (np.abs(grid.positions[None] - positions[:, None]).max(axis=2) <= 1.0)
    assert np.array_equal(many, brute)


def test_eq7_and_eq9_over_four_steps_exactly(grid):
    # J = 0.5 keeps every value exact in binary.
    J = 0.5
    v = initial_values(grid)
    assert np.array_equal(v, np.zeros(12))
    path = [(1.5, 1.5), (3.5, 0.5), (0.5, 2.5), (3.5, 2.5), (0.5, 0.5)]
    values = []
    for prev, now in zip(path[:-1], path[1:], strict=True):
        v = update(predict(v, grid, prev, J), grid, now)
        values.append(v)
    # k = 1: S_a(3.5, 0.5) holds x in {2.5, 3.5}, y in {0.5, 1.5}: nodes 2, 3, 6, 7.
    assert np.array_equal(values[0], [0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 0, 0])
    # k = 2: 2, 3, 6, 7 were inside S_a(s_1): no decay (eq. 7); 4, 5, 8, 9 seen.
    assert np.array_equal(values[1], [0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0])
    # k = 3: 2, 3 decay once (outside S_a(s_2)); 6, 7, 10, 11 seen now.
    assert np.array_equal(values[2], [0, 0, .5, .5, 1, 1, 1, 1, 1, 1, 1, 1])
    # k = 4: outside S_a(s_3) = {6, 7, 10, 11} everything decays; 0, 1, 4, 5 seen now.
    assert np.array_equal(values[3], [1, 1, .25, .25, 1, 1, 1, 1, .5, .5, 1, 1])


def test_predict_leaves_the_previous_square_alone_and_decays_the_rest(grid):
    v = np.full(12, 0.8)
    out = predict(v, grid, (0.5, 0.5))  # default J = 0.999
    inside = mask(12, [0, 1, 4, 5])
    assert DEFAULT_DECAY == 0.999
    assert np.array_equal(out[inside], np.full(4, 0.8))
    assert np.array_equal(out[~inside], np.full(8, 0.8 * 0.999))
    assert np.array_equal(v, np.full(12, 0.8))  # inputs untouched
    # n steps away from a node decay it by J^n.
    w = np.ones(12)
    for _ in range(10):
        w = predict(w, grid, (0.5, 0.5), 0.9)
    assert w[11] == pytest.approx(0.9 ** 10, rel=1e-14)
    assert w[0] == 1.0


def test_update_sets_the_square_to_one_and_nothing_else(grid):
    v = np.linspace(0.0, 0.55, 12)
    out = update(v, grid, (2.0, 1.0))  # x in {1.5, 2.5}, y in {0.5, 1.5}
    inside = grid.inside((2.0, 1.0))
    assert np.array_equal(inside, mask(12, [1, 2, 5, 6]))
    assert np.array_equal(out[inside], np.ones(4))
    assert np.array_equal(out[~inside], v[~inside])


def test_max_merge_is_the_elementwise_max():
    a = np.array([0.0, 0.5, 1.0, 0.25])
    b = np.array([0.1, 0.4, 0.9, 0.25])
    assert np.array_equal(max_merge(a, b), [0.1, 0.5, 1.0, 0.25])
    assert np.array_equal(max_merge(a, b), max_merge(b, a))
    with pytest.raises(ValueError, match="second map"):
        max_merge(a, b[:3])


def test_unvisited_threshold_is_inclusive_and_ascending():
    v = np.array([0.5, 0.2, 1.0, 0.2000001, 0.0, 0.2])
    assert np.array_equal(unvisited(v, 0.2), [1, 4, 5])
    assert np.array_equal(unvisited(v, 0.0), [4])
    assert np.array_equal(unvisited(v, 1.0), np.arange(6))
    assert unvisited(v, 0.2).dtype.kind == "i"


def test_searched_fraction_is_the_mean_search_value(grid):
    assert searched_fraction(initial_values(grid)) == 0.0
    v = update(initial_values(grid), grid, (1.5, 1.5))  # 9 of 12 equal nodes
    assert searched_fraction(v) == 0.75
    assert searched_fraction(np.array([1.0, 0.5, 0.25, 0.25])) == 0.5
    # With decay it stays below 1 even when every node has been seen.
    w = update(predict(np.ones(12), grid, (0.5, 0.5), 0.999), grid, (3.5, 2.5))
    assert 0.99 < searched_fraction(w) < 1.0


@pytest.mark.parametrize("kwargs, match", [
    (dict(xmin=0.0, ymin=0.0, xmax=4.0, ymax=3.0, node_size=0.0, side=2.0), "node_size"),
    (dict(xmin=0.0, ymin=0.0, xmax=4.0, ymax=3.0, node_size=1.0, side=-1.0), "side"),
    (dict(xmin=0.0, ymin=0.0, xmax=4.0, ymax=3.0, node_size=0.7, side=2.0), "width"),
    (dict(xmin=0.0, ymin=0.0, xmax=4.0, ymax=3.5, node_size=1.0, side=2.0), "height"),
    (dict(xmin=0.0, ymin=0.0, xmax=0.0, ymax=3.0, node_size=1.0, side=2.0), "bounds"),
    (dict(xmin=0.0, ymin=np.nan, xmax=4.0, ymax=3.0, node_size=1.0, side=2.0), "bounds"),
])
def test_bad_grid_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SearchGrid(**kwargs)


def test_bad_arguments_are_refused(grid):
    v = initial_values(grid)
    with pytest.raises(ValueError, match="shape"):
        predict(v[:5], grid, (1.0, 1.0))
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        update(np.full(12, 1.5), grid, (1.0, 1.0))
    with pytest.raises(ValueError, match="NaN"):
        update(np.full(12, np.nan), grid, (1.0, 1.0))
    with pytest.raises(ValueError, match="decay"):
        predict(v, grid, (1.0, 1.0), decay=1.2)
    with pytest.raises(ValueError, match="position"):
        update(v, grid, (1.0, np.inf))
    with pytest.raises(ValueError, match="position"):
        update(v, grid, (1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="beta"):
        unvisited(v, -0.1)
    with pytest.raises(ValueError, match="empty"):
        searched_fraction(np.zeros(0))
    with pytest.raises(ValueError, match="side"):
        grid.inside((1.0, 1.0), side=0.0)
    with pytest.raises(ValueError, match="positions"):
        grid.inside(np.zeros(3))
    with pytest.raises(ValueError, match="my map"):
        check_values(np.zeros((2, 2)), what="my map")


def test_a_100_step_trial_with_5_agents_is_cheap():
    """The per-step map work is a handful of numpy calls (100 x 100 m, 400 nodes)."""
    import time

    g = SearchGrid(0.0, 0.0, 100.0, 100.0, node_size=5.0, side=10.0)
    rng = np.random.default_rng(3)
    pos = rng.uniform(0.0, 100.0, size=(5, 2))
    maps = [initial_values(g) for _ in range(5)]
    t0 = time.perf_counter()
    for _ in range(100):
        new = np.clip(pos + rng.uniform(-2.0, 2.0, size=(5, 2)), 0.0, 100.0)
        maps = [update(predict(m, g, p), g, q) for m, p, q in zip(maps, pos, new,
                                                                  strict=True)]
        pos = new
    assert time.perf_counter() - t0 < 2.0
    assert 0.0 < searched_fraction(maps[0]) < 1.0
