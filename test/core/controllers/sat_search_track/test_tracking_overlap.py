"""Tests of the tracking-overlap detection of Papaioannou et al. (Sec. V-C b, eq. 19)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.controllers.sat_search_track.tracking_overlap import (
    OverlapWindow,
    overlap_increment,
    pick_switcher,
    squares_overlap,
)

SIDE = 10.0
SAME = np.array([[10.0, 10.0], [12.0, 9.0], [15.0, 14.0]])


# ---------------------------------------------------------------- squares


@pytest.mark.parametrize("offset, expected", [
    ((0.0, 0.0), True),
    ((9.9, -3.0), True),
    ((10.0, 0.0), True),                 # edges touch: closed squares meet
    ((-10.0, 10.0), True),               # corners touch
    ((10.0 + 1e-9, 0.0), False),
    ((0.0, -10.5), False),
    ((11.0, 11.0), False),
])
def test_squares_overlap_iff_centres_within_a_side_on_both_axes(offset, expected):
    a = np.array([3.0, -2.0])
    b = a + np.asarray(offset)
    assert squares_overlap(a, b, SIDE) is expected
    assert squares_overlap(b, a, SIDE) is expected


# ---------------------------------------------------------------- eq. 19


def test_increment_against_a_hand_computation_with_m_not_n():
    x_i = np.array([[0.0, 0.0], [10.0, 0.0]])                    # m = 2
    x_j = np.array([[10.0, 0.5], [30.0, 30.0], [0.0, 1.0]])      # n = 3
    # Best injection: (0,0)->(0,1) at 1, (10,0)->(10,0.5) at 0.5; one unassigned: c^2.
    expected = np.sqrt((1.0**2 + 0.5**2 + (3 - 2) * 5.0**2) / 3)
    assert overlap_increment(x_i, x_j, cutoff=5.0) == pytest.approx(expected, rel=1e-12)
    assert overlap_increment(x_j, x_i, cutoff=5.0) == pytest.approx(expected, rel=1e-12)
    # The cut-off acting on an assigned pair: d_c = min(8, 9) = 8 and min(8, 20) = 8 left.
    y_i = np.array([[0.0, 0.0]])
    y_j = np.array([[9.0, 0.0], [0.0, 20.0]])
    assert overlap_increment(y_i, y_j, cutoff=8.0) == pytest.approx(8.0, rel=1e-12)
    assert overlap_increment(y_i, y_j, cutoff=12.0) == pytest.approx(
        np.sqrt((81.0 + 144.0) / 2), rel=1e-12)
    assert overlap_increment(SAME, SAME[::-1]) == 0.0


def test_increment_is_inf_when_a_set_is_empty():
    assert overlap_increment(np.empty((0, 2)), SAME) == np.inf
    assert overlap_increment(SAME, []) == np.inf
    assert overlap_increment([], []) == np.inf


# ---------------------------------------------------------------- the window


def test_fires_on_identical_sets_over_three_consecutive_overlapping_steps():
    win = OverlapWindow()
    assert win.push(4, True, SAME, SAME) is None
    assert not win.detected()
    assert win.push(5, True, SAME, SAME[::-1]) is None
    assert win.push(6, True, SAME, SAME) == 0.0
    assert win.detected()
    win.reset()
    assert win.score is None and not win.detected()


def test_does_not_fire_on_disjoint_sets():
    other = SAME + np.array([40.0, 0.0])
    win = OverlapWindow()
    for k in range(5):
        q = win.push(k, True, SAME, other)
    assert q == pytest.approx(3 * 10.0)            # every pair beyond the cut-off
    assert not win.detected()


def test_does_not_fire_while_a_non_overlapping_step_is_in_the_window():
    win = OverlapWindow()
    win.push(0, True, SAME, SAME)
    win.push(1, False)                             # no exchange: I = inf
    assert win.push(2, True, SAME, SAME) == np.inf
    assert not win.detected()
    assert win.push(3, True, SAME, SAME) == np.inf
    assert win.push(4, True, SAME, SAME) == 0.0    # the inf has left the window
    assert win.detected()
    # Identical sets but never overlapping squares: never.
    never = OverlapWindow()
    for k in range(4):
        never.push(k, False, SAME, SAME)
    assert never.score == np.inf and not never.detected()


def test_a_gap_in_the_steps_restarts_the_window():
    win = OverlapWindow()
    win.push(0, True, SAME, SAME)
    win.push(1, True, SAME, SAME)
    assert win.push(3, True, SAME, SAME) is None   # step 2 missing
    assert win.push(4, True, SAME, SAME) is None
    assert win.push(5, True, SAME, SAME) == 0.0
    assert win.detected()


def test_threshold_is_a_sum_of_three_ospa_values_in_metres():
    # One target seen 0.3 m apart at each step: DeltaL = 0.3 m, Q = 0.9 m = Q_th.
    win = OverlapWindow()
    for k in range(3):
        win.push(k, True, [[0.0, 0.0]], [[0.3, 0.0]])
    assert win.score == pytest.approx(0.9, abs=1e-12)
    assert win.detected(threshold=0.9 + 1e-12)
    assert not win.detected(threshold=0.89)
    win.push(3, True, [[0.0, 0.0]], [[0.0, 0.4]])   # window now 0.3 + 0.3 + 0.4
    assert win.score == pytest.approx(1.0) and not win.detected()
    # A cardinality mismatch at one step alone exceeds Q_th: c / sqrt(n) with c = 10 m.
    mism = OverlapWindow()
    mism.push(0, True, SAME, SAME)
    mism.push(1, True, SAME, SAME[:2])
    mism.push(2, True, SAME, SAME)
    assert mism.score == pytest.approx(10.0 / np.sqrt(3)) and not mism.detected()


def test_the_mean_form_bounds_the_per_step_score():
    # DeltaL = 0.36 m at every step (the smallest one-step score of the Fig. 5b runs): the
    # sum, 1.08 m, never reaches Q_th = 0.9 m; the mean, 0.36 m, does.
    win = OverlapWindow()
    for k in range(3):
        win.push(k, True, [[0.0, 0.0]], [[0.36, 0.0]])
    assert win.score == pytest.approx(1.08)
    assert not win.detected(0.9) and not win.detected(0.9, "sum")
    assert win.detected(0.9, "mean") and not win.detected(0.35, "mean")
    # A cardinality mismatch at one step still keeps the mean above Q_th (10 / sqrt(3) / 3).
    mism = OverlapWindow()
    for k, b in enumerate((SAME, SAME[:2], SAME)):
        mism.push(k, True, SAME, b)
    assert not mism.detected(0.9, "mean") and mism.detected(2.0, "mean")
    with pytest.raises(ValueError, match="form"):
        win.detected(0.9, "median")


def test_decision_does_not_depend_on_the_cutoff_above_q_th_sqrt_n():
    rng = np.random.default_rng(19)
    fired = 0
    for _ in range(300):
        windows = {c: OverlapWindow(cutoff=c) for c in (2.0, 10.0, 100.0)}  # > 0.9 sqrt(3)
        for k in range(3):
            n = int(rng.integers(1, 4))
            x_i = rng.uniform(0.0, 10.0, (n, 2))
            x_j = x_i + rng.normal(0.0, 0.15, (n, 2))
            if rng.random() < 0.1:
                x_j = x_j[1:]
            for w in windows.values():
                w.push(k, True, x_i, x_j[rng.permutation(len(x_j))])
        decisions = {c: w.detected() for c, w in windows.items()}
        assert len(set(decisions.values())) == 1, decisions
        if decisions[10.0]:
            fired += 1
            scores = [w.score for w in windows.values()]
            assert scores == pytest.approx([scores[0]] * 3, rel=1e-12)
    assert 20 < fired < 280                          # both outcomes were exercised


def test_window_refuses_bad_input():
    with pytest.raises(ValueError, match="window"):
        OverlapWindow(window=0)
    with pytest.raises(ValueError, match="cutoff"):
        OverlapWindow(cutoff=0.0)
    win = OverlapWindow()
    win.push(3, True, SAME, SAME)
    with pytest.raises(ValueError, match="step must increase"):
        win.push(3, True, SAME, SAME)
    with pytest.raises(ValueError, match="step must be an integer"):
        win.push(-1, True, SAME, SAME)
    with pytest.raises(ValueError, match="x_i and x_j"):
        win.push(4, True, SAME, None)
    with pytest.raises(ValueError, match="overlapping must be a bool"):
        win.push(4, 1, SAME, SAME)
    with pytest.raises(ValueError, match="x_j"):
        win.push(4, True, SAME, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="threshold"):
        win.detected(threshold=-1.0)
    with pytest.raises(ValueError, match="side"):
        squares_overlap(np.zeros(2), np.zeros(2), 0.0)
    with pytest.raises(ValueError, match="s_j"):
        squares_overlap(np.zeros(2), np.zeros(3), SIDE)
    with pytest.raises(ValueError, match="cutoff"):
        overlap_increment(SAME, SAME, cutoff=-1.0)


# ---------------------------------------------------------------- who switches


def test_pick_switcher_is_symmetric_reproducible_and_fair():
    picks = []
    for step in range(1000):
        p = pick_switcher(7, step, 3, 12)
        assert p in (3, 12)
        assert pick_switcher(7, step, 12, 3) == p
        assert pick_switcher(7, step, 3, 12) == p
        picks.append(p)
    assert 430 < picks.count(3) < 570
    other_seed = [pick_switcher(8, step, 3, 12) for step in range(1000)]
    assert other_seed != picks


@pytest.mark.parametrize("args, match", [
    ((1, 0, 4, 4), "must differ"),
    ((1, 0, -1, 4), "id_a"),
    ((1, 0, 2, True), "id_b"),
    ((-1, 0, 2, 3), "seed"),
    ((1, 2.0, 2, 3), "step"),
])
def test_pick_switcher_refuses_bad_input(args, match):
    with pytest.raises(ValueError, match=match):
        pick_switcher(*args)
