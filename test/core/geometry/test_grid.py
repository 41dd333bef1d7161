"""Tests for the environment and the grid of bins (index conventions, disk_bins, bin_of)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from phd_swarm.core.geometry.grid import Environment, Grid

GRID = Grid(Environment(-2.0, 1.0, 3.0, 4.0), 0.5)  # nx = 10, ny = 6


def test_shape_and_bin_centres():
    assert (GRID.nx, GRID.ny, GRID.shape, GRID.size) == (10, 6, (6, 10), 60)
    np.testing.assert_allclose(GRID.xs, -1.75 + 0.5 * np.arange(10))
    np.testing.assert_allclose(GRID.ys, 1.25 + 0.5 * np.arange(6))
    # flat = iy * nx + ix: bin (iy=2, ix=3) has centre (-0.25, 2.25).
    flat = 2 * 10 + 3
    np.testing.assert_allclose(GRID.centres[flat], [-0.25, 2.25])
    np.testing.assert_array_equal(GRID.centres_of(np.array([flat])), [[-0.25, 2.25]])
    np.testing.assert_array_equal(GRID.centres_of(np.arange(GRID.size)), GRID.centres)
    assert not GRID.centres.flags.writeable


def test_image_scatter_matches_flat_convention():
    img = GRID.image(np.array([0, 23, 59]), np.array([1.0, 2.0, 3.0]))
    assert img.shape == GRID.shape
    assert (img[0, 0], img[2, 3], img[5, 9]) == (1.0, 2.0, 3.0)
    assert img.sum() == 6.0


@settings(max_examples=50, deadline=None)
@given(iy=st.integers(0, 5), ix=st.integers(0, 9))
def test_flat_unravel_round_trip(iy, ix):
    flat = GRID.flat_index(iy, ix)
    assert GRID.unravel(flat) == (iy, ix)
    img = np.arange(GRID.size).reshape(GRID.shape)
    assert img.ravel()[flat] == img[iy, ix]


def test_bin_of_edges_and_outside():
    env = GRID.env
    pts = np.array([
        [env.xmin, env.ymin],          # lower corner -> first bin
        [env.xmax, env.ymax],          # upper corner -> last bin
        [env.xmax, 2.0],               # upper x edge
        [-1.5, env.ymax],              # upper y edge: x = -1.5 starts bin ix = 1
        [-1.75, 1.25],                 # a centre
        [env.xmin - 1e-9, 2.0],        # just outside, each side
        [env.xmax + 1e-9, 2.0],
        [0.0, env.ymin - 1e-9],
        [0.0, env.ymax + 1e-9],
        [np.nan, 2.0],
    ])
    got = GRID.bin_of(pts)
    expected = [0, 59, 2 * 10 + 9, 5 * 10 + 1, 0, -1, -1, -1, -1, -1]
    np.testing.assert_array_equal(got, expected)


def test_bin_of_just_below_upper_edge_is_inside():
    # (x - xmin) / res rounds up to nx for the float just below 1.5 here: it must still map
    # to the last bin, not to "outside".
    grid = Grid(Environment(-1.5, -1.5, 1.5, 1.5), 0.3)
    x = np.nextafter(1.5, 0.0)
    assert grid.bin_of(np.array([[x, x]]))[0] == grid.size - 1


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(-2.0, 3.0), st.floats(1.0, 4.0)), min_size=1,
                max_size=20))
def test_bin_of_contains_point(points):
    p = np.array(points)
    flat = GRID.bin_of(p)
    assert np.all(flat >= 0)
    c = GRID.centres_of(flat)
    # The bin's square contains the point (to rounding at the shared edges).
    assert np.all(np.abs(p - c) <= 0.25 + 1e-9)


def _brute_disk(grid: Grid, centre: np.ndarray, radius: float) -> np.ndarray:
    # Same predicate as DiskDetection.probability: the bins with p_d > 0.
    d2 = np.sum((grid.centres - centre) ** 2, axis=-1)
    return np.nonzero(d2 <= radius ** 2)[0]


@settings(max_examples=60, deadline=None)
@given(cx=st.floats(-5.0, 6.0), cy=st.floats(-2.0, 7.0), radius=st.floats(0.0, 8.0))
def test_disk_bins_equals_brute_force(cx, cy, radius):
    # Centres range over the map, its edges and up to a few metres outside it.
    centre = np.array([cx, cy])
    got = GRID.disk_bins(centre, radius)
    np.testing.assert_array_equal(got, _brute_disk(GRID, centre, radius))
    assert got.dtype == np.int64
    assert np.all(np.diff(got) > 0)


def test_disk_bins_exact_centre_distance_is_included():
    # A bin centre at exactly the radius belongs to the disk (p_d uses <=).
    grid = Grid(Environment(0.0, 0.0, 10.0, 10.0), 1.0)
    got = grid.disk_bins(np.array([5.5, 5.5]), 2.0)
    assert grid.flat_index(5, 7) in got and grid.flat_index(5, 8) not in got
    assert got.size == 13


@pytest.mark.parametrize("env, res", [
    (Environment(0.0, 0.0, 100.0, 100.0), 1.0),
    (Environment(0.0, 0.0, 100.0, 100.0), 0.1),
    (Environment(-3.0, 2.0, 4.5, 5.0), 0.25),
])
def test_bin_areas_sum_to_environment_area(env, res):
    grid = Grid(env, res)
    assert grid.size * grid.bin_area == pytest.approx(env.area, rel=1e-12)


@pytest.mark.parametrize("res, match", [
    (0.0, "resolution"), (-1.0, "resolution"), (float("nan"), "resolution"),
    (0.3, "whole number"), (7.0, "whole number"),
])
def test_invalid_resolution_raises(res, match):
    with pytest.raises(ValueError, match=match):
        Grid(Environment(0.0, 0.0, 5.0, 5.0), res)


@pytest.mark.parametrize("bounds, match", [
    ((0.0, 0.0, 0.0, 1.0), "xmax > xmin"),
    ((0.0, 2.0, 1.0, 1.0), "xmax > xmin"),
    ((0.0, 0.0, float("inf"), 1.0), "finite"),
])
def test_invalid_environment_raises(bounds, match):
    with pytest.raises(ValueError, match=match):
        Environment(*bounds)


def test_environment_distance_and_contains():
    env = Environment(0.0, 0.0, 10.0, 4.0)
    np.testing.assert_allclose(env.distance_to_boundary(np.array([[1.0, 2.0], [5.0, 3.5]])),
                               [1.0, 0.5])
    np.testing.assert_array_equal(env.contains(np.array([[10.0, 4.0], [10.1, 0.0]])),
                                  [True, False])
    assert env.area == 40.0
