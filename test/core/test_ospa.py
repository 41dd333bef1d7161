"""Tests of the OSPA distance (Dames eq. 12, Schuhmacher et al. 2008)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from phd_swarm.core.ospa import OspaComponents, ospa, ospa_components

P_VALUES = [1.0, 2.0, np.inf]


def brute_force_ospa(X: np.ndarray, Y: np.ndarray, c: float, p: float) -> float:
    """Eq. 12 by enumerating every injection of the smaller set into the larger."""
    X = np.asarray(X, dtype=float).reshape(-1, 2)
    Y = np.asarray(Y, dtype=float).reshape(-1, 2)
    if len(X) > len(Y):
        X, Y = Y, X
    m, n = len(X), len(Y)
    if n == 0:
        return 0.0
    if np.isinf(p):
        if m != n:
            return c
        return min(max(min(c, np.linalg.norm(X[i] - Y[j])) for i, j in enumerate(perm))
                   for perm in itertools.permutations(range(n)))
    best = min(sum(min(c, np.linalg.norm(X[i] - Y[j])) ** p for i, j in enumerate(perm))
               for perm in itertools.permutations(range(n), m))
    return ((best + c ** p * (n - m)) / n) ** (1.0 / p)


def random_set(rng: np.random.Generator, k: int, extent: float = 20.0) -> np.ndarray:
    return rng.uniform(0.0, extent, size=(k, 2))


points = st.integers(0, 5).flatmap(
    lambda k: arrays(np.float64, (k, 2), elements=st.floats(-15.0, 15.0, width=64)))


# ---------------------------------------------------------------- hand-computed cases

@pytest.mark.parametrize("p", P_VALUES)
def test_both_empty_is_zero(p: float) -> None:
    assert ospa(np.empty((0, 2)), np.empty((0, 2)), p=p) == 0.0
    assert ospa([], [], p=p) == 0.0


@pytest.mark.parametrize("p", P_VALUES)
def test_one_point_vs_empty_is_c(p: float) -> None:
    assert ospa([[1.0, 2.0]], np.empty((0, 2)), c=10.0, p=p) == pytest.approx(10.0)
    assert ospa([], [[1.0, 2.0], [5.0, 5.0]], c=7.5, p=p) == pytest.approx(7.5)


def test_two_points_at_distance_three() -> None:
    assert ospa([[0.0, 0.0]], [[3.0, 0.0]], c=10.0, p=1.0) == pytest.approx(3.0)


@pytest.mark.parametrize("p", P_VALUES)
def test_single_pair_is_distance_for_any_p(p: float) -> None:
    assert ospa([[1.0, 1.0]], [[4.0, 5.0]], c=10.0, p=p) == pytest.approx(5.0)


@pytest.mark.parametrize("p", P_VALUES)
def test_cut_off_applies(p: float) -> None:
    assert ospa([[0.0, 0.0]], [[30.0, 0.0]], c=10.0, p=p) == pytest.approx(10.0)
    assert ospa([[0.0, 0.0]], [[30.0, 0.0]], c=4.0, p=p) == pytest.approx(4.0)


def test_hand_case_cardinality_mismatch_p1() -> None:
    # One pair at 2 m, one extra estimate: (2 + 10) / 2 = 6.
    X = [[0.0, 0.0]]
    Y = [[2.0, 0.0], [50.0, 50.0]]
    assert ospa(X, Y, c=10.0, p=1.0) == pytest.approx(6.0)


def test_hand_case_p2() -> None:
    # Pairs at 3 m and 4 m, both below the cut-off: sqrt((9 + 16) / 2).
    X = [[0.0, 0.0], [10.0, 0.0]]
    Y = [[0.0, 3.0], [10.0, 4.0]]
    assert ospa(X, Y, c=10.0, p=2.0) == pytest.approx(np.sqrt(12.5))


def test_hand_case_optimal_assignment_is_not_greedy() -> None:
    # Greedy nearest-neighbour pairs x0-y0 (1 m) then x1-y1 (5 m): (1 + 5) / 2 = 3.
    # The optimal assignment x0-y1 (2 m), x1-y0 (2 m) gives (2 + 2) / 2 = 2.
    X = [[0.0, 0.0], [3.0, 0.0]]
    Y = [[1.0, 0.0], [-2.0, 0.0]]
    assert ospa(X, Y, c=100.0, p=1.0) == pytest.approx(2.0)


def test_p_inf_uses_bottleneck_assignment() -> None:
    # min over pairings of the largest pair distance: pairing (0-0, 1-1) gives max(1, 1).
    X = [[0.0, 0.0], [10.0, 0.0]]
    Y = [[0.0, 1.0], [10.0, 1.0]]
    assert ospa(X, Y, c=10.0, p=np.inf) == pytest.approx(1.0)
    assert ospa(X, Y[:1], c=10.0, p=np.inf) == pytest.approx(10.0)


def test_components_p1() -> None:
    comp = ospa_components([[0.0, 0.0]], [[2.0, 0.0], [50.0, 50.0]], c=10.0, p=1.0)
    assert isinstance(comp, OspaComponents)
    assert comp.localisation == pytest.approx(1.0)
    assert comp.cardinality == pytest.approx(5.0)
    assert comp.distance == pytest.approx(6.0)


@pytest.mark.parametrize("p", [1.0, 2.0, 3.5])
def test_components_compose_for_finite_p(p: float) -> None:
    rng = np.random.default_rng(7)
    X, Y = random_set(rng, 3), random_set(rng, 5)
    comp = ospa_components(X, Y, c=6.0, p=p)
    assert comp.distance ** p == pytest.approx(comp.localisation ** p + comp.cardinality ** p)


def test_components_p_inf() -> None:
    comp = ospa_components([[0.0, 0.0]], [[2.0, 0.0], [50.0, 50.0]], c=10.0, p=np.inf)
    assert comp.localisation == pytest.approx(2.0)
    assert comp.cardinality == 10.0
    assert comp.distance == 10.0


def test_large_finite_p_does_not_overflow() -> None:
    d = ospa([[0.0, 0.0]], [[3.0, 0.0], [40.0, 0.0]], c=10.0, p=800.0)
    assert np.isfinite(d)
    assert d == pytest.approx(10.0 * 0.5 ** (1 / 800))


# ---------------------------------------------------------------- metric properties

@pytest.mark.parametrize("p", P_VALUES)
@pytest.mark.parametrize("seed", range(5))
def test_zero_on_equal_and_permuted_sets(p: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    X = random_set(rng, 6)
    assert ospa(X, X, p=p) == 0.0
    assert ospa(X, X[rng.permutation(6)], p=p) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("p", P_VALUES)
@pytest.mark.parametrize("seed", range(5))
def test_symmetric(p: float, seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    X, Y = random_set(rng, 4), random_set(rng, 7)
    assert ospa(X, Y, c=5.0, p=p) == pytest.approx(ospa(Y, X, c=5.0, p=p))


@pytest.mark.parametrize("p", P_VALUES)
def test_invariant_to_order_of_points(p: float) -> None:
    rng = np.random.default_rng(3)
    X, Y = random_set(rng, 5), random_set(rng, 6)
    ref = ospa(X, Y, c=8.0, p=p)
    assert ospa(X[::-1], Y[rng.permutation(6)], c=8.0, p=p) == pytest.approx(ref)


@pytest.mark.parametrize("p", P_VALUES)
@settings(max_examples=60, deadline=None, derandomize=True)
@given(X=points, Y=points, Z=points)
def test_triangle_inequality(p: float, X: np.ndarray, Y: np.ndarray, Z: np.ndarray) -> None:
    c = 10.0
    assert ospa(X, Z, c=c, p=p) <= ospa(X, Y, c=c, p=p) + ospa(Y, Z, c=c, p=p) + 1e-9


@pytest.mark.parametrize("p", P_VALUES)
@pytest.mark.parametrize("seed", range(6))
def test_triangle_inequality_random_sets(p: float, seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    X, Y, Z = (random_set(rng, k) for k in rng.integers(0, 8, size=3))
    assert ospa(X, Z, c=4.0, p=p) <= ospa(X, Y, c=4.0, p=p) + ospa(Y, Z, c=4.0, p=p) + 1e-9


@pytest.mark.parametrize("p", P_VALUES)
@settings(max_examples=60, deadline=None, derandomize=True)
@given(X=points, Y=points)
def test_bounded_by_c(p: float, X: np.ndarray, Y: np.ndarray) -> None:
    d = ospa(X, Y, c=3.0, p=p)
    assert 0.0 <= d <= 3.0 + 1e-12


@pytest.mark.parametrize("p", P_VALUES)
@pytest.mark.parametrize("m,n", [(0, 3), (1, 1), (1, 4), (2, 5), (3, 3), (4, 2), (5, 5),
                                 (5, 1), (4, 4)])
def test_matches_brute_force(p: float, m: int, n: int) -> None:
    rng = np.random.default_rng(10 * m + n)
    for _ in range(4):
        # Extent 12 with c = 5 mixes pairs inside and beyond the cut-off.
        X, Y = random_set(rng, m, extent=12.0), random_set(rng, n, extent=12.0)
        assert ospa(X, Y, c=5.0, p=p) == pytest.approx(brute_force_ospa(X, Y, 5.0, p))


@pytest.mark.parametrize("p", P_VALUES)
@settings(max_examples=40, deadline=None, derandomize=True)
@given(X=points, Y=points)
def test_matches_brute_force_hypothesis(p: float, X: np.ndarray, Y: np.ndarray) -> None:
    assert ospa(X, Y, c=10.0, p=p) == pytest.approx(brute_force_ospa(X, Y, 10.0, p))


# ---------------------------------------------------------------- validation

@pytest.mark.parametrize("bad", [np.zeros((3, 3)), np.zeros(4), np.zeros((2, 2, 2))])
def test_wrong_shape_names_argument(bad: np.ndarray) -> None:
    with pytest.raises(ValueError, match="X"):
        ospa(bad, np.zeros((1, 2)))
    with pytest.raises(ValueError, match="Y"):
        ospa(np.zeros((1, 2)), bad)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_names_argument(value: float) -> None:
    bad = np.array([[0.0, 0.0], [1.0, value]])
    with pytest.raises(ValueError, match="X"):
        ospa(bad, np.zeros((1, 2)))
    with pytest.raises(ValueError, match="Y"):
        ospa(np.zeros((1, 2)), bad)


@pytest.mark.parametrize("c", [0.0, -1.0, np.inf, np.nan])
def test_invalid_cut_off(c: float) -> None:
    with pytest.raises(ValueError, match="c "):
        ospa([[0.0, 0.0]], [[1.0, 0.0]], c=c)


@pytest.mark.parametrize("p", [0.5, 0.0, -1.0, np.nan])
def test_invalid_order(p: float) -> None:
    with pytest.raises(ValueError, match="p "):
        ospa([[0.0, 0.0]], [[1.0, 0.0]], p=p)
