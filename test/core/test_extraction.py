"""Tests of target extraction from the grid PHD (Dames Sec. IV)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from phd_swarm.core.extraction import ExtractionConfig, expected_cardinality, extract_targets
from phd_swarm.core.geometry.grid import Environment, Grid


@pytest.fixture
def grid() -> Grid:
    """6 x 5 bins of 1 m on [0, 6] x [0, 5]: nx = 6, ny = 5."""
    return Grid(Environment(0.0, 0.0, 6.0, 5.0), 1.0)


def centre(grid: Grid, iy: int, ix: int) -> list[float]:
    return [grid.xs[ix], grid.ys[iy]]


# ---------------------------------------------------------------- hand-made images

def test_all_zero_gives_empty(grid: Grid) -> None:
    out = extract_targets(grid, np.zeros(grid.shape))
    assert out.shape == (0, 2)


def test_single_peak(grid: Grid) -> None:
    w = np.zeros(grid.shape)
    w[2, 3] = 0.9
    w[1:4, 2:5] += 0.02  # a shoulder around the peak, below the peak
    out = extract_targets(grid, w)
    np.testing.assert_allclose(out, [centre(grid, 2, 3)])
    np.testing.assert_allclose(out, [[3.5, 2.5]])


def test_two_peaks_in_flat_index_order(grid: Grid) -> None:
    w = np.zeros(grid.shape)
    w[3, 1] = 0.4   # flat 19
    w[1, 4] = 0.8   # flat 10
    out = extract_targets(grid, w)
    np.testing.assert_allclose(out, [centre(grid, 1, 4), centre(grid, 3, 1)])


def test_adjacent_unequal_bins_give_the_larger(grid: Grid) -> None:
    w = np.zeros(grid.shape)
    w[2, 2], w[2, 3] = 0.3, 0.5
    np.testing.assert_allclose(extract_targets(grid, w), [centre(grid, 2, 3)])


def test_peaks_two_bins_apart_are_both_found(grid: Grid) -> None:
    w = np.zeros(grid.shape)
    w[2, 1], w[2, 2], w[2, 3] = 0.5, 0.1, 0.4
    np.testing.assert_allclose(extract_targets(grid, w),
                               [centre(grid, 2, 1), centre(grid, 2, 3)])
    # A 5-bin window suppresses the lower one.
    np.testing.assert_allclose(
        extract_targets(grid, w, ExtractionConfig(neighbourhood=5)), [centre(grid, 2, 1)])


@pytest.mark.parametrize("iy,ix", [(0, 0), (0, 5), (4, 0), (4, 5), (0, 2), (4, 3), (2, 0),
                                   (3, 5)])
def test_peak_on_border_or_corner(grid: Grid, iy: int, ix: int) -> None:
    w = np.full(grid.shape, 0.01)
    w[iy, ix] = 0.7
    np.testing.assert_allclose(extract_targets(grid, w), [centre(grid, iy, ix)])


@pytest.mark.parametrize("cells", [
    [(2, 2), (2, 3)],                   # horizontal pair
    [(1, 4), (2, 4)],                   # vertical pair
    [(1, 1), (2, 2)],                   # diagonal pair (8-connected)
    [(2, 2), (2, 3), (3, 2), (3, 3)],   # 2 x 2 block
    [(0, 0), (0, 1), (1, 0), (1, 1)],   # 2 x 2 block in a corner
])
def test_plateau_gives_one_estimate_at_lowest_flat_index(grid: Grid, cells) -> None:
    w = np.zeros(grid.shape)
    for iy, ix in cells:
        w[iy, ix] = 0.6
    out = extract_targets(grid, w)
    lowest = min(iy * grid.nx + ix for iy, ix in cells)
    np.testing.assert_allclose(out, grid.centres_of(np.array([lowest])))


def test_two_separate_plateaus_give_two_estimates(grid: Grid) -> None:
    w = np.zeros(grid.shape)
    w[0, 0:2] = 0.3
    w[3:5, 4] = 0.3
    out = extract_targets(grid, w)
    np.testing.assert_allclose(out, [centre(grid, 0, 0), centre(grid, 3, 4)])


def test_plateau_next_to_a_higher_bin_is_not_a_maximum(grid: Grid) -> None:
    # Row 2: 0.2 0.2 0.2 0.9 -- the plateau's left bins see no larger neighbour, but the
    # plateau continues into a bin next to 0.9, so only the 0.9 bin is a maximum.
    w = np.zeros(grid.shape)
    w[2, 0:3] = 0.2
    w[2, 3] = 0.9
    np.testing.assert_allclose(extract_targets(grid, w), [centre(grid, 2, 3)])


def test_values_at_or_below_threshold_ignored(grid: Grid) -> None:
    w = np.zeros(grid.shape)
    w[1, 1] = 0.05           # at the threshold: not strictly above
    w[3, 4] = 0.049
    w[0, 5] = 0.0500001
    np.testing.assert_allclose(extract_targets(grid, w), [centre(grid, 0, 5)])
    cfg = ExtractionConfig(threshold=0.01)
    assert extract_targets(grid, w, cfg).shape == (3, 2)


def test_uniform_image_is_one_plateau(grid: Grid) -> None:
    out = extract_targets(grid, np.full(grid.shape, 0.2))
    np.testing.assert_allclose(out, [centre(grid, 0, 0)])


def test_flat_image_accepted(grid: Grid) -> None:
    w = np.zeros(grid.shape)
    w[4, 2] = 1.0
    np.testing.assert_allclose(extract_targets(grid, w.ravel()), [centre(grid, 4, 2)])


def test_does_not_modify_input(grid: Grid) -> None:
    w = np.random.default_rng(0).uniform(0, 0.3, grid.shape)
    before = w.copy()
    extract_targets(grid, w)
    np.testing.assert_array_equal(w, before)


def test_offset_environment_centres() -> None:
    grid = Grid(Environment(-10.0, 20.0, -4.0, 23.0), 0.5)
    w = np.zeros(grid.shape)
    w[5, 11] = 0.3
    np.testing.assert_allclose(extract_targets(grid, w), [[-4.25, 22.75]])


# ---------------------------------------------------------------- ordering

@pytest.mark.parametrize("seed", range(5))
def test_output_order_independent_of_peak_heights(grid: Grid, seed: int) -> None:
    # Same peak locations, heights permuted: same estimates in the same (flat) order.
    locations = [(0, 0), (0, 4), (2, 2), (4, 0), (4, 5)]
    heights = np.array([0.2, 0.4, 0.6, 0.8, 1.0])
    rng = np.random.default_rng(seed)
    w_ref = np.zeros(grid.shape)
    w_perm = np.zeros(grid.shape)
    for (iy, ix), h, hp in zip(locations, heights, rng.permutation(heights), strict=True):
        w_ref[iy, ix], w_perm[iy, ix] = h, hp
    ref = extract_targets(grid, w_ref)
    np.testing.assert_array_equal(extract_targets(grid, w_perm), ref)
    np.testing.assert_allclose(ref, [centre(grid, iy, ix) for iy, ix in locations])


@settings(max_examples=50, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1))
def test_random_images_sorted_and_are_maxima(seed: int) -> None:
    grid = Grid(Environment(0.0, 0.0, 9.0, 7.0), 1.0)
    rng = np.random.default_rng(seed)
    # Values rounded to 0.1 make plateaus common.
    w = np.round(rng.uniform(0.0, 0.5, grid.shape), 1)
    out = extract_targets(grid, w)
    flat = grid.bin_of(out)
    assert np.all(np.diff(flat) > 0)
    iy, ix = grid.unravel(flat)
    padded = np.pad(w, 1, constant_values=-np.inf)
    for y, x in zip(iy, ix, strict=True):
        assert w[y, x] > 0.05
        assert w[y, x] == padded[y:y + 3, x:x + 3].max()
    # No two estimates on the same 8-connected plateau.
    for a in range(len(flat)):
        for b in range(a + 1, len(flat)):
            same = w[iy[a], ix[a]] == w[iy[b], ix[b]]
            adjacent = max(abs(iy[a] - iy[b]), abs(ix[a] - ix[b])) <= 1
            assert not (same and adjacent)
    np.testing.assert_array_equal(flat, reference_maxima(w, 0.05))


def reference_maxima(w: np.ndarray, threshold: float) -> np.ndarray:
    """Return the maxima by a slow reference method.

    The lowest flat index of each equal-valued 8-connected region above the threshold none
    of whose bins has a larger 8-neighbour.
    """
    padded = np.pad(w, 1, constant_values=-np.inf)
    found = []
    for value in np.unique(w[w > threshold]):
        labels, k = ndimage.label(w == value, structure=np.ones((3, 3)))
        for lab in range(1, k + 1):
            ys, xs = np.nonzero(labels == lab)
            if all(padded[y:y + 3, x:x + 3].max() == value for y, x in zip(ys, xs, strict=True)):
                found.append(int(np.min(ys * w.shape[1] + xs)))
    return np.array(sorted(found), dtype=np.int64)


# ---------------------------------------------------------------- resolution options

def test_threshold_per_m2_scales_with_bin_area() -> None:
    env = Environment(0.0, 0.0, 4.0, 4.0)
    cfg = ExtractionConfig(threshold=0.5, threshold_per_m2=0.05)
    assert cfg.bin_threshold(Grid(env, 1.0)) == pytest.approx(0.05)
    assert cfg.bin_threshold(Grid(env, 0.1)) == pytest.approx(5e-4)
    assert cfg.bin_threshold(Grid(env, 0.5)) == pytest.approx(0.0125)
    assert ExtractionConfig().bin_threshold(Grid(env, 0.1)) == 0.05


def test_threshold_per_m2_finds_fine_grid_peak() -> None:
    # A unit mass spread as a Gaussian of 0.5 m s.d. on a 0.1 m grid: the peak bin holds
    # ~0.0063 < 0.05, so only the per-m^2 threshold finds it.
    grid = Grid(Environment(0.0, 0.0, 6.0, 6.0), 0.1)
    c = grid.centres - np.array([3.05, 2.95])
    w = np.exp(-0.5 * np.sum(c ** 2, axis=1) / 0.25)
    w = (w / w.sum()).reshape(grid.shape)
    assert extract_targets(grid, w).shape == (0, 2)
    out = extract_targets(grid, w, ExtractionConfig(threshold_per_m2=0.05))
    np.testing.assert_allclose(out, [[3.05, 2.95]])


def test_threshold_per_m2_matches_dames_at_1m(grid: Grid) -> None:
    rng = np.random.default_rng(4)
    w = rng.uniform(0.0, 0.2, grid.shape)
    np.testing.assert_array_equal(
        extract_targets(grid, w, ExtractionConfig(threshold_per_m2=0.05)),
        extract_targets(grid, w))


@pytest.mark.parametrize("res,metres,bins", [
    (1.0, 3.0, 3), (1.0, 1.0, 3), (1.0, 5.2, 5), (0.5, 3.0, 7), (0.2, 3.0, 15),
    (0.1, 3.0, 31), (0.1, 2.9, 29), (0.25, 1.0, 5), (1.0, 6.0, 7)])
def test_neighbourhood_m_rounds_to_odd_bins(res: float, metres: float, bins: int) -> None:
    grid = Grid(Environment(0.0, 0.0, 10.0, 10.0), res)
    assert ExtractionConfig(neighbourhood_m=metres).window_bins(grid) == bins
    assert ExtractionConfig(neighbourhood=5).window_bins(grid) == 5


def test_neighbourhood_m_suppresses_nearby_peak() -> None:
    grid = Grid(Environment(0.0, 0.0, 4.0, 4.0), 0.5)
    w = np.zeros(grid.shape)
    w[2, 2], w[2, 4] = 0.9, 0.5    # 1 m apart
    assert extract_targets(grid, w).shape == (2, 2)
    out = extract_targets(grid, w, ExtractionConfig(neighbourhood_m=2.5))  # 5 bins
    np.testing.assert_allclose(out, [centre(grid, 2, 2)])


# ---------------------------------------------------------------- cardinality, validation

def test_expected_cardinality_is_total_mass(grid: Grid) -> None:
    w = np.full(grid.shape, 0.01)
    w[1, 1] = 0.7
    assert expected_cardinality(w) == pytest.approx(0.7 + 29 * 0.01)
    assert expected_cardinality(w.ravel()) == pytest.approx(0.99)
    assert expected_cardinality(np.zeros(0)) == 0.0


@pytest.mark.parametrize("kwargs", [
    {"threshold": -0.1}, {"threshold": np.nan}, {"neighbourhood": 4},
    {"neighbourhood": 1}, {"neighbourhood": 0}, {"neighbourhood": 3.0},
    {"neighbourhood": True}, {"threshold_per_m2": -1.0}, {"threshold_per_m2": np.inf},
    {"neighbourhood_m": 0.0}, {"neighbourhood_m": -2.0}, {"neighbourhood_m": np.nan}])
def test_config_validation(kwargs) -> None:
    with pytest.raises(ValueError, match="extraction."):
        ExtractionConfig(**kwargs)


def test_config_is_frozen() -> None:
    cfg = ExtractionConfig()
    with pytest.raises(AttributeError):
        cfg.threshold = 0.1  # type: ignore[misc]


def test_wrong_image_shape(grid: Grid) -> None:
    with pytest.raises(ValueError, match="weights_image"):
        extract_targets(grid, np.zeros((grid.nx, grid.ny)))


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_image(grid: Grid, value: float) -> None:
    w = np.zeros(grid.shape)
    w[1, 1] = value
    with pytest.raises(ValueError, match="weights_image"):
        extract_targets(grid, w)


# ------------------------------------------- windows that separate close peaks (issue 34)

HALF = Grid(Environment(0.0, 0.0, 10.0, 10.0), 0.5)


def _two_peaks(second: tuple[int, int]) -> np.ndarray:
    """Peaks of 1.0 at bin (10, 10) and 0.8 at ``second`` on the 0.5 m grid."""
    w = np.zeros(HALF.shape)
    w[10, 10] = 1.0
    w[second] = 0.8
    return w


@pytest.mark.parametrize(("second", "config", "found"), [
    # 1.5 m apart along x (3 bins): inside the 3 m square (half-width 1.5 m, 7 bins) ...
    ((10, 13), ExtractionConfig(threshold_per_m2=0.05, neighbourhood_m=3.0), 1),
    # ... outside a 1.5 m one (3 bins) and outside a disk of 1 m.
    ((10, 13), ExtractionConfig(threshold_per_m2=0.05, neighbourhood_m=1.5), 2),
    ((10, 13), ExtractionConfig(threshold_per_m2=0.05, radius_m=1.0), 2),
    ((10, 13), ExtractionConfig(threshold_per_m2=0.05, radius_m=1.5), 1),
    # 1.41 m apart on the diagonal (2 bins each way): the 3 m square merges them, a 1 m disk
    # does not, a 1.5 m disk does.
    ((12, 12), ExtractionConfig(threshold_per_m2=0.05, neighbourhood_m=3.0), 1),
    ((12, 12), ExtractionConfig(threshold_per_m2=0.05, radius_m=1.0), 2),
    ((12, 12), ExtractionConfig(threshold_per_m2=0.05, radius_m=1.5), 1),
])
def test_close_peaks_are_separated_by_a_smaller_window(second, config, found):
    out = extract_targets(HALF, _two_peaks(second), config)
    peaks = HALF.centres_of(HALF.flat_index(np.array([10, second[0]]),
                                            np.array([10, second[1]])))
    np.testing.assert_allclose(out, peaks[:found])


def test_disk_footprints():
    one = Grid(Environment(0.0, 0.0, 4.0, 4.0), 1.0)
    plus = ExtractionConfig(radius_m=1.0).footprint(one)
    np.testing.assert_array_equal(plus, [[0, 1, 0], [1, 1, 1], [0, 1, 0]])
    assert ExtractionConfig(radius_m=np.sqrt(2.0)).footprint(one).all()
    assert ExtractionConfig(radius_m=1.0).footprint(HALF).sum() == 13  # within 2 bins
    assert ExtractionConfig(neighbourhood_m=3.0).footprint(HALF) is None
    with pytest.raises(ValueError, match="below the bin side"):
        ExtractionConfig(radius_m=0.4).footprint(HALF)
    with pytest.raises(ValueError, match="radius_m"):
        ExtractionConfig(radius_m=-1.0)


def test_a_plus_footprint_keeps_diagonal_maxima_apart_and_joins_plateaus_along_edges():
    one = Grid(Environment(0.0, 0.0, 5.0, 5.0), 1.0)
    plus = ExtractionConfig(radius_m=1.0)
    w = np.zeros(one.shape)
    w[1, 1], w[2, 2] = 0.5, 0.4  # diagonal neighbours: both maxima of their plus
    np.testing.assert_allclose(extract_targets(one, w, plus), [[1.5, 1.5], [2.5, 2.5]])
    assert len(extract_targets(one, w)) == 1  # the 3 x 3 square keeps one
    w = np.zeros(one.shape)
    w[2, 1:3] = 0.5  # an edge plateau: one estimate, at its lowest flat index
    np.testing.assert_allclose(extract_targets(one, w, plus), [[1.5, 2.5]])
    w[1, 3] = 0.5  # a diagonal bin of equal value is another plateau under the plus
    np.testing.assert_allclose(extract_targets(one, w, plus), [[3.5, 1.5], [1.5, 2.5]])
    w[1, 2] = 0.5  # ... joined to the first through an edge neighbour
    np.testing.assert_allclose(extract_targets(one, w, plus), [[2.5, 1.5]])
