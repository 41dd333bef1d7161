"""Tests of phd_swarm.core.geometry.polygons: cell radii, boxes, distances, sorted bin sets."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.geometry.polygons import (
    bounding_boxes,
    cell_radii,
    cell_radius,
    isin_sorted,
    points_to_edges2,
    polygon_distances,
    positions_in_sorted,
)

#: The unit square, counter-clockwise.
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def _square(x0: float, y0: float, side: float = 1.0) -> np.ndarray:
    return SQUARE * side + np.array([x0, y0])


def test_cell_radius_is_the_farthest_vertex_and_0_for_an_empty_cell():
    triangle = np.array([[1.0, 1.0], [4.0, 5.0], [1.0, 3.0]])
    assert cell_radius(np.array([1.0, 1.0]), triangle) == 5.0  # the 3-4-5 vertex
    assert cell_radius(np.array([0.5, 0.5]), SQUARE) == np.sqrt(0.5)
    assert cell_radius(np.array([3.0, 3.0]), np.empty((0, 2))) == 0.0


def test_cell_radii_equal_one_cell_radius_per_pair():
    generators = [np.array([1.0, 1.0]), np.array([9.0, 9.0]), np.array([0.0, 0.0])]
    cells = [np.array([[1.0, 1.0], [4.0, 5.0], [1.0, 3.0]]), np.empty((0, 2)), SQUARE]
    got = cell_radii(generators, cells)
    np.testing.assert_array_equal(got, [5.0, 0.0, np.sqrt(2.0)])
    assert got.tolist() == [cell_radius(q, c) for q, c in zip(generators, cells, strict=True)]
    np.testing.assert_array_equal(cell_radii([generators[1]], [cells[1]]), [0.0])


def test_bounding_boxes_of_each_polygon():
    triangle = np.array([[2.0, -1.0], [5.0, 3.0], [-4.0, 0.5]])
    lo, hi = bounding_boxes([SQUARE, triangle, _square(10.0, 20.0, 2.0)])
    np.testing.assert_array_equal(lo, [[0.0, 0.0], [-4.0, -1.0], [10.0, 20.0]])
    np.testing.assert_array_equal(hi, [[1.0, 1.0], [5.0, 3.0], [12.0, 22.0]])
    lo, hi = bounding_boxes([])
    assert lo.shape == hi.shape == (0, 2)


def test_points_to_edges2_is_the_squared_distance_to_each_segment():
    points = np.array([[0.0, 1.0], [3.0, 0.0], [2.0, 5.0]])
    p0 = np.array([[-1.0, 0.0], [2.0, 2.0]])
    p1 = np.array([[1.0, 0.0], [2.0, 2.0]])  # the second segment is a point
    got = points_to_edges2(points, p0, p1)
    # (0, 1) is 1 above the first segment; (3, 0) is 2 past its end (1, 0);
    # distances to the point (2, 2): 5, 5 and 9.
    np.testing.assert_allclose(got, [[1.0, 5.0], [4.0, 5.0], [26.0, 9.0]], rtol=0, atol=1e-12)


@pytest.mark.parametrize(("poly", "want"), [
    (_square(4.0, 0.0), 3.0),                                        # side by side
    (_square(2.0, 2.0), np.sqrt(2.0)),                               # corner to corner
    (_square(0.5, 0.5), 0.0),                                        # overlap
    (_square(1.0, 0.0), 0.0),                                        # a shared edge
    (np.array([[0.5, 2.0], [6.0, 10.0], [-5.0, 10.0]]), 1.0),        # its vertex, our edge
    (np.array([[-10.0, -2.0], [10.0, -2.0], [0.0, -20.0]])[::-1], 2.0),  # our vertex, its edge
])
def test_polygon_distance_to_the_unit_square(poly, want):
    got = polygon_distances(SQUARE, [poly])
    np.testing.assert_allclose(got, [want], rtol=1e-12, atol=1e-12)


def test_polygon_distances_do_not_depend_on_the_grouping():
    others = [_square(4.0, 0.0), _square(0.5, 0.5), _square(2.0, 2.0),
              np.array([[0.5, 2.0], [6.0, 10.0], [-5.0, 10.0]])]
    together = polygon_distances(SQUARE, others)
    one_by_one = [polygon_distances(SQUARE, [p])[0] for p in others]
    assert together.tolist() == one_by_one
    assert together[1] == 0.0 and together[0] == 3.0


def test_positions_in_sorted_keeps_the_order_of_the_values_held():
    bins = np.array([2, 5, 9, 12], dtype=np.int64)
    got = positions_in_sorted(bins, np.array([9, 3, 2, 12, 13], dtype=np.int64))
    assert got.dtype == np.int64 and got.tolist() == [2, 0, 3]
    assert positions_in_sorted(bins, np.empty(0, dtype=np.int64)).size == 0
    assert positions_in_sorted(np.empty(0, dtype=np.int64), bins).size == 0


def test_isin_sorted_equals_isin():
    bins = np.array([2, 5, 9, 12], dtype=np.int64)
    values = np.array([9, 3, 2, 12, 13, 0], dtype=np.int64)
    assert isin_sorted(values, bins).tolist() == [True, False, True, True, False, False]
    assert isin_sorted(values, bins).tolist() == np.isin(values, bins).tolist()
    empty = isin_sorted(values.reshape(2, 3), np.empty(0, dtype=np.int64))
    assert empty.shape == (2, 3) and not empty.any()
