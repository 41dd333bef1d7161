"""Tests for Chen's clustered and Sung & Tokekar's turning walkers (phd_swarm.sim.walkers)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.sim.walkers import ClusteredWalkers, TurningWalkers, reflect_into

# --- clustered walkers ----------------------------------------------------------------------

BOXES = ((0.0, 0.0, 33.0, 33.0), (67.0, 67.0, 100.0, 100.0))


def test_clustered_counts_boxes_and_speed_cap():
    w = ClusteredWalkers.sample(np.random.default_rng(0), BOXES, (30, 30), step_sd=1.0,
                                max_speed=3.0)
    assert len(w.ids) == 60 and np.bincount(w.cluster).tolist() == [30, 30]
    lo, hi = w.boxes[:, :2], w.boxes[:, 2:]
    rng = np.random.default_rng(1)
    for _ in range(2000):
        before = w.positions.copy()
        w.step(rng, 0.5)
        assert np.all(w.positions >= lo) and np.all(w.positions <= hi)
        assert np.all(np.linalg.norm(w.positions - before, axis=1) <= 1.5 + 1e-12)
    assert w.ids.tolist() == list(range(60))


def test_clustered_cap_binds_for_large_steps():
    w = ClusteredWalkers([[50.0, 50.0]], [[0, 0, 100, 100]], step_sd=100.0, max_speed=3.0)
    w.step(np.random.default_rng(0), 0.5)
    assert np.linalg.norm(w.positions[0] - [50.0, 50.0]) == pytest.approx(1.5)


def test_clustered_step_sd_sets_the_spread():
    # Far from the edges and with no cap, a step is N(0, (step_sd dt)^2 I).
    w = ClusteredWalkers(np.full((20000, 2), 50.0), np.tile([0, 0, 100, 100], (20000, 1)),
                         step_sd=1.0, max_speed=1e9)
    w.step(np.random.default_rng(5), 0.5)
    assert np.allclose(w.positions.std(axis=0), 0.5, atol=0.01)


def test_reflection_folds_back_into_the_box():
    lo, hi = np.array([0.0, 0.0]), np.array([10.0, 10.0])
    x = np.array([[-1.0, 11.5], [5.0, 25.0], [10.0, 0.0]])
    assert np.allclose(reflect_into(x, lo, hi), [[1.0, 8.5], [5.0, 5.0], [10.0, 0.0]])


# ------------------------------------------------------------------ turning walkers
def _turning(n=50, speed=0.05, turn_every=400.0, seed=0):
    env = Environment(0.0, 0.0, 150.0, 150.0)
    return env, TurningWalkers.sample(np.random.default_rng(seed), env, n, None, speed,
                                      turn_every)


def test_turning_walkers_go_straight_at_their_speed_between_turns():
    _, t = _turning()
    rng = np.random.default_rng(1)
    for _ in range(399):
        before, heading = t.positions.copy(), t.headings
        t.step(rng, 1.0)
        inside = np.all((before > 1.0) & (before < 149.0), axis=1)
        step = t.positions - before
        assert np.allclose(np.hypot(step[:, 0], step[:, 1]), 0.05)
        # Away from the boundary the heading does not change before the 400th second.
        assert np.array_equal(t.headings[inside], heading[inside])


def test_turning_walkers_turn_every_turn_every_seconds():
    _, t = _turning(speed=0.0)            # not moving: only the scheduled turns happen
    rng = np.random.default_rng(2)
    h0 = t.headings
    for _ in range(399):
        t.step(rng, 1.0)
    assert np.array_equal(t.headings, h0)
    t.step(rng, 1.0)
    assert not np.any(t.headings == h0)


def test_turning_walkers_stay_inside_and_are_reproducible():
    env, a = _turning(n=30, speed=3.0)
    _, b = _turning(n=30, speed=3.0)
    ra, rb = np.random.default_rng(5), np.random.default_rng(5)
    for _ in range(500):
        a.step(ra, 1.0)
        b.step(rb, 1.0)
        assert np.all(env.contains(a.positions))
    assert np.array_equal(a.positions, b.positions)
