"""The reward-set union (Shirsat & Berman eq. 6, Alg. 1 d, Alg. 3) for real-valued points."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.estimators.shirsat.reward_sets import (
    as_points,
    extend,
    extend_by_label,
    union,
    union_by_label,
)


def _reference(sets, distance):
    """The documented rule, one point at a time: keep unless within distance of a kept one."""
    kept = []
    for s in sets:
        for x in np.asarray(s, dtype=float).reshape(-1, 2):
            if all(np.hypot(*(x - y)) > distance for y in kept):
                kept.append(x)
    return np.array(kept).reshape(-1, 2)


def test_the_earlier_set_wins_so_the_result_depends_on_the_order():
    a = np.array([[0.0, 0.0], [5.0, 0.0]])
    b = np.array([[0.5, 0.0], [9.0, 9.0]])
    np.testing.assert_array_equal(union([a, b], 1.0), [[0.0, 0.0], [5.0, 0.0], [9.0, 9.0]])
    np.testing.assert_array_equal(union([b, a], 1.0), [[0.5, 0.0], [9.0, 9.0], [5.0, 0.0]])
    # Only the order of the points matters, not how they are split into sets.
    np.testing.assert_array_equal(union([a, b], 1.0), union([np.concatenate([a, b])], 1.0))


def test_points_within_the_distance_are_dropped_boundary_included():
    kept = np.array([[0.0, 0.0]])
    # A 3-4-5 triangle: (3, 4) lies exactly 5 from the origin.
    np.testing.assert_array_equal(union([kept, [[3.0, 4.0]]], 5.0), kept)
    np.testing.assert_array_equal(union([kept, [[3.0, 4.0]]], 4.999),
                                  [[0.0, 0.0], [3.0, 4.0]])


def test_within_one_set_the_first_point_of_a_cluster_is_kept_and_a_dropped_one_shadows_nothing():
    # 0.8 apart in a chain with distance 1: the middle one is dropped (close to the first),
    # the third is kept (1.6 from the first; the dropped middle one does not count).
    chain = np.array([[0.0, 0.0], [0.8, 0.0], [1.6, 0.0]])
    np.testing.assert_array_equal(union([chain], 1.0), [[0.0, 0.0], [1.6, 0.0]])
    np.testing.assert_array_equal(union([chain[::-1]], 1.0), [[1.6, 0.0], [0.0, 0.0]])
    # Two copies of one component's mean (round(w) = 2) are one point.
    np.testing.assert_array_equal(union([[[1.0, 2.0], [1.0, 2.0]]], 0.0), [[1.0, 2.0]])
    # A first set whose points are farther apart than the distance survives whole.
    spread = np.array([[0.0, 0.0], [1.5, 0.0], [0.0, 1.5]])
    np.testing.assert_array_equal(union([spread, spread + 0.1], 1.0), spread)


def test_distance_zero_is_the_exact_union():
    a = np.array([[1.0, 1.0], [2.0, 2.0]])
    b = np.array([[2.0, 2.0], [2.0, 2.0 + 1e-12]])
    np.testing.assert_array_equal(union([a, b], 0.0), [[1.0, 1.0], [2.0, 2.0],
                                                       [2.0, 2.0 + 1e-12]])


def test_empty_sets():
    assert union([], 1.0).shape == (0, 2)
    assert union([[], np.empty((0, 2))], 1.0).shape == (0, 2)
    a = np.array([[1.0, 2.0]])
    np.testing.assert_array_equal(union([[], a, np.empty((0, 2))], 1.0), a)
    np.testing.assert_array_equal(union([a, []], 1.0), a)
    assert as_points([]).shape == (0, 2)


def test_the_result_is_a_new_array():
    a = np.array([[1.0, 2.0]])
    out = union([a], 1.0)
    out[0, 0] = 99.0
    assert a[0, 0] == 1.0


@pytest.mark.parametrize("seed", range(5))
def test_matches_the_point_by_point_rule_on_random_sets(seed):
    rng = np.random.default_rng(seed)
    sets = [rng.uniform(0.0, 5.0, (int(rng.integers(0, 12)), 2)) for _ in range(4)]
    for distance in (0.0, 0.3, 1.0, 2.5):
        np.testing.assert_array_equal(union(sets, distance), _reference(sets, distance))


def test_two_robots_merging_the_same_sets_in_the_same_order_agree():
    # What merge_rewards relies on: the sets keyed by robot id, taken in increasing id,
    # give one result whichever robot computes it and whatever order they arrived in.
    rng = np.random.default_rng(7)
    by_id = {3: rng.uniform(0, 5, (6, 2)), 1: rng.uniform(0, 5, (4, 2)),
             8: rng.uniform(0, 5, (5, 2))}
    arrived_one_way = dict(sorted(by_id.items()))
    arrived_other_way = dict(sorted(by_id.items(), reverse=True))
    first = union([arrived_one_way[k] for k in sorted(arrived_one_way)], 1.0)
    second = union([arrived_other_way[k] for k in sorted(arrived_other_way)], 1.0)
    np.testing.assert_array_equal(first, second)
    # ... and not in arrival order, which differs (so the sorting is what makes them agree).
    unsorted = union(list(arrived_other_way.values()), 1.0)
    assert not (unsorted.shape == first.shape and np.array_equal(unsorted, first))


@pytest.mark.parametrize("bad, match", [
    ([[[np.nan, 0.0]]], r"sets\[0\]: coordinates must be finite"),
    ([[[0.0, 0.0]], [[1.0, 2.0, 3.0]]], r"sets\[1\]: expected shape \(K, 2\)"),
])
def test_malformed_sets_are_refused_naming_them(bad, match):
    with pytest.raises(ValueError, match=match):
        union(bad, 1.0)


@pytest.mark.parametrize("distance", [-0.1, float("nan"), float("inf"), "far"])
def test_a_bad_distance_is_refused(distance):
    with pytest.raises(ValueError, match="distance"):
        union([[[0.0, 0.0]]], distance)


@pytest.mark.parametrize("seed", range(5))
def test_extend_of_a_union_equals_the_union_with_the_new_sets(seed):
    rng = np.random.default_rng(seed)
    reduced = union([rng.uniform(0.0, 6.0, (12, 2))], 1.0)
    new = [rng.uniform(0.0, 6.0, (int(rng.integers(0, 5)), 2)) for _ in range(3)]
    np.testing.assert_array_equal(extend(reduced, new, 1.0), union([reduced, *new], 1.0))


def test_extend_with_nothing_new_returns_the_set_itself():
    reduced = np.array([[0.0, 0.0], [3.0, 0.0]])
    assert extend(reduced, [np.empty((0, 2))], 1.5) is reduced
    assert extend(np.empty((0, 2)), [[]], 1.5).shape == (0, 2)
    np.testing.assert_array_equal(extend(np.empty((0, 2)), [[[1.0, 1.0], [1.2, 1.0]]], 1.5),
                                  [[1.0, 1.0]])
    with pytest.raises(ValueError, match="distance"):
        extend(reduced, [], -1.0)


# ------------------------------------------------------------------- the labelled reading
def test_union_by_label_keeps_the_first_member_of_each_label_wherever_it_lies():
    a = ([3, 5], [[0.0, 0.0], [9.0, 9.0]])
    b = ([5, 7, 3], [[0.1, 0.0], [0.2, 0.0], [50.0, 50.0]])
    labels, points = union_by_label([a, b])
    # Label 5 of b (0.1 m from a's label 3) is the same target as a's 5, 13 m away; label 7
    # (0.2 m from a's label 3) is a new target: position plays no part.
    np.testing.assert_array_equal(labels, [3, 5, 7])
    np.testing.assert_array_equal(points, [[0.0, 0.0], [9.0, 9.0], [0.2, 0.0]])
    labels, points = union_by_label([b, a])
    np.testing.assert_array_equal(labels, [5, 7, 3])
    np.testing.assert_array_equal(points, [[0.1, 0.0], [0.2, 0.0], [50.0, 50.0]])


def test_members_without_a_label_are_not_added():
    labels, points = union_by_label([([0, 2, 0, 2], [[1.0, 1.0], [2.0, 2.0], [3.0, 3.0],
                                                     [4.0, 4.0]])])
    np.testing.assert_array_equal(labels, [2])
    np.testing.assert_array_equal(points, [[2.0, 2.0]])
    labels, points = union_by_label([])
    assert labels.shape == (0,) and labels.dtype == np.int64 and points.shape == (0, 2)
    labels, points = union_by_label([([], np.empty((0, 2))), ([0], [[1.0, 1.0]])])
    assert labels.shape == (0,) and points.shape == (0, 2)


def test_extend_by_label_returns_the_set_itself_when_nothing_new_comes():
    labels, points = union_by_label([([4, 9], [[0.0, 0.0], [1.0, 1.0]])])
    same = extend_by_label(labels, points, np.array([9, 0]), np.array([[5.0, 5.0],
                                                                       [6.0, 6.0]]))
    assert same[0] is labels and same[1] is points
    grown = extend_by_label(labels, points, np.array([0, 2]), np.array([[5.0, 5.0],
                                                                        [6.0, 6.0]]))
    np.testing.assert_array_equal(grown[0], [4, 9, 2])
    np.testing.assert_array_equal(grown[1], [[0.0, 0.0], [1.0, 1.0], [6.0, 6.0]])


@pytest.mark.parametrize("bad, match", [
    ([([1], [[0.0, 0.0], [1.0, 1.0]])], r"sets\[0\]: labels must be 2 integers"),
    ([([1], [[0.0, 0.0]]), ([-1], [[1.0, 1.0]])], r"sets\[1\]: labels must be 1 integers"),
    ([([0.5], [[0.0, 0.0]])], r"sets\[0\]: labels must be 1 integers"),
])
def test_malformed_labelled_sets_are_refused_naming_them(bad, match):
    with pytest.raises(ValueError, match=match):
        union_by_label(bad)
