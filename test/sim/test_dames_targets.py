"""Tests for Dames (2020) Sec. IV-A/B's targets (phd_swarm.sim.dames_targets)."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.models import BoundaryBirth
from phd_swarm.sim.dames_targets import (
    BIRTH_HEADINGS,
    DamesWalkers,
    StaticTargets,
    boundary_ring_area,
    sample_boundary_ring,
    substeps_per_step,
)

E = Environment(0.0, 0.0, 100.0, 100.0)
DRAW = (-10.0, -10.0, 110.0, 110.0)
DAMES_BIRTH = BoundaryBirth(density=5.26e-5, margin=5.0)


# --- static ---------------------------------------------------------------------------------

def test_static_targets_are_inside_the_map_with_consecutive_ids():
    t = StaticTargets.sample(np.random.default_rng(0), E, 30, DRAW)
    assert np.all(E.contains(t.positions))
    assert np.array_equal(t.ids, np.arange(len(t.ids)))
    before = t.positions.copy()
    rng = np.random.default_rng(1)
    state = rng.bit_generator.state
    t.step(rng, 0.5)
    assert np.array_equal(t.positions, before)
    assert rng.bit_generator.state == state  # static targets consume no randomness


def test_static_mean_count_is_the_area_fraction():
    # Kept count ~ Binomial(30, (100/120)^2): mean 20.83, sd 2.04 (paper: 20.0 over 10
    # trials). The mean of 2000 seeds has sd 0.046.
    counts = [len(StaticTargets.sample(np.random.default_rng(s), E, 30, DRAW).ids)
              for s in range(2000)]
    assert np.mean(counts) == pytest.approx(30 * (100 / 120) ** 2, abs=0.2)


def test_static_positions_cannot_be_written():
    t = StaticTargets.sample(np.random.default_rng(0), E, 5, DRAW)
    with pytest.raises(ValueError):
        t.positions[0, 0] = 1.0


# --- Dames walkers --------------------------------------------------------------------------

def test_substeps_per_step():
    assert substeps_per_step(0.5, 10.0) == 5
    with pytest.raises(ValueError, match="whole number"):
        substeps_per_step(0.5, 3.0)


def test_walkers_move_exactly_a_tenth_of_a_metre_per_substep():
    # Start in the middle so that no target leaves in one step, no births.
    rng = np.random.default_rng(3)
    p0 = 40.0 + 20.0 * rng.random((50, 2))
    h0 = 2 * np.pi * rng.random(50)
    w = DamesWalkers(E, p0, h0, speed=1.0, heading_sd=0.1, heading_rate=10.0)
    # Reproduce the sub-steps by hand from the same stream.
    check = np.random.default_rng(4)
    dtheta = 0.1 * check.standard_normal((50, 5))
    w.step(np.random.default_rng(4), 0.5)
    h = h0.copy()
    p = p0.copy()
    for s in range(5):
        h = h + dtheta[:, s]
        step = 0.1 * np.stack([np.cos(h), np.sin(h)], axis=1)
        assert np.allclose(np.linalg.norm(step, axis=1), 0.1, rtol=0, atol=1e-15)
        p = p + step
    assert np.allclose(w.positions, p, rtol=0, atol=1e-12)
    assert np.allclose(w.headings, h, rtol=0, atol=1e-12)
    # Net displacement <= 0.5 m (5 x 0.1 m) and close to it for small heading changes.
    disp = np.linalg.norm(w.positions - p0, axis=1)
    assert np.all(disp <= 0.5 + 1e-12) and np.all(disp > 0.45)


def test_zero_heading_noise_moves_in_a_straight_line():
    w = DamesWalkers(E, [[50.0, 50.0]], [np.pi / 2], heading_sd=0.0)
    for _ in range(10):
        w.step(np.random.default_rng(0), 0.5)
    assert np.allclose(w.positions, [[50.0, 55.0]], atol=1e-12)


def test_targets_leaving_the_map_are_removed_for_good():
    # Target 0 heads out through x = 0 within one step; target 1 stays inside.
    w = DamesWalkers(E, [[0.2, 50.0], [50.0, 50.0]], [np.pi, 0.0], heading_sd=0.0)
    w.step(np.random.default_rng(0), 0.5)
    assert w.ids.tolist() == [1]
    assert np.all(E.contains(w.positions))


class _ScriptedNormals:
    """Stands in for a Generator: returns the given heading changes."""

    def __init__(self, normals):
        self.normals = np.asarray(normals, dtype=float)

    def standard_normal(self, shape):
        assert shape == self.normals.shape
        return self.normals


def test_a_target_that_exits_and_re_enters_within_a_step_is_removed():
    # Sub-step 1 turns it to heading pi (x: 0.05 -> -0.05, outside E), sub-step 2 turns it
    # back to 0 (x -> 0.05), and it ends at x = 0.35 inside E: it left, so it is removed.
    w = DamesWalkers(E, [[0.05, 50.0], [50.0, 50.0]], [0.0, 0.0], heading_sd=1.0)
    w.step(_ScriptedNormals([[np.pi, -np.pi, 0, 0, 0], [0, 0, 0, 0, 0]]), 0.5)
    assert w.ids.tolist() == [1]
    assert np.allclose(w.positions, [[50.5, 50.0]])


def test_birth_rate_and_positions_match_the_birth_phd():
    # Eq. 14: 5.26e-5 per m^2 on the 1900 m^2 ring, 0.0999 births per step.
    w = DamesWalkers(E, np.empty((0, 2)), np.empty(0), birth=DAMES_BIRTH)
    assert w.expected_births == pytest.approx(5.26e-5 * 1900)
    rng = np.random.default_rng(7)
    births = []
    birth_positions = []
    seen = set()
    for _ in range(20000):
        before = set(w.ids.tolist())
        w.step(rng, 0.5)
        new = [i for i in w.ids.tolist() if i not in before]
        assert not (set(new) & seen)  # never reused
        seen |= set(new)
        births.append(len(new))
        mask = np.isin(w.ids, new)
        birth_positions.append(w.positions[mask])
        assert len(np.unique(w.ids)) == len(w.ids)
    # Poisson mean 0.0999: the mean of 20000 steps has sd 0.00224; allow 4 sd.
    assert np.mean(births) == pytest.approx(0.0999, abs=0.009)
    assert np.var(births) == pytest.approx(0.0999, abs=0.015)
    z = np.concatenate(birth_positions)
    assert len(z) > 1500
    assert np.all(E.contains(z))
    assert np.all(E.distance_to_boundary(z) <= 5.0)


def _newborns(heading: str, steps: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    """Positions and headings of the targets born in ``steps`` steps (no initial ones)."""
    w = DamesWalkers(E, np.empty((0, 2)), np.empty(0), heading_sd=0.0, birth=DAMES_BIRTH,
                     birth_heading=heading)
    rng = np.random.default_rng(3)
    pos, head = [], []
    for _ in range(steps):
        before = w.ids.max(initial=-1)
        w.step(rng, 0.5)
        new = w.ids > before
        pos.append(w.positions[new])
        head.append(w.headings[new])
    return np.concatenate(pos), np.concatenate(head)


def test_inward_births_head_into_the_map_and_uniform_ones_anywhere():
    centre = np.array([50.0, 50.0])
    for heading, facing in (("inward", (1.0, 1.0)), ("uniform", (0.4, 0.6))):
        p, h = _newborns(heading)
        assert len(p) > 300
        to_centre = centre - p
        cos = (np.cos(h) * to_centre[:, 0] + np.sin(h) * to_centre[:, 1]) / np.hypot(
            to_centre[:, 0], to_centre[:, 1])
        assert facing[0] <= np.mean(cos >= 0.0) <= facing[1], heading
    # The same draws place the first newborns (later the populations, and with them the
    # number of heading draws, differ).
    np.testing.assert_array_equal(_newborns("inward", 40)[0][:1],
                                  _newborns("uniform", 40)[0][:1])
    # Inward births live longer, so the population settles higher (Dames: "around 35").
    # ~9 against ~17 targets (4 runs of 1500 s, the last 1000 s; one run varies by +-4).
    counts = {}
    for heading in BIRTH_HEADINGS:
        n = []
        for seed in range(4):
            w = DamesWalkers.sample(np.random.default_rng(seed), E, 20, birth=DAMES_BIRTH,
                                    birth_heading=heading)
            rng = np.random.default_rng(seed + 10)
            for k in range(3000):
                w.step(rng, 0.5)
                if k >= 1000:
                    n.append(len(w.ids))
        counts[heading] = np.mean(n)
    assert counts["inward"] > 1.4 * counts["uniform"], counts


def test_unknown_birth_heading_is_refused():
    with pytest.raises(ValueError, match="birth_heading must be one of"):
        DamesWalkers(E, np.empty((0, 2)), np.empty(0), birth_heading="north")


def test_ids_increase_and_are_never_reused():
    w = DamesWalkers.sample(np.random.default_rng(1), E, 20, birth=DAMES_BIRTH)
    rng = np.random.default_rng(2)
    all_ids: set[int] = set(w.ids.tolist())
    alive_sets = []
    for _ in range(1000):
        w.step(rng, 0.5)
        ids = w.ids.tolist()
        assert len(set(ids)) == len(ids)
        assert ids == sorted(ids)
        alive_sets.append(set(ids))
        all_ids |= set(ids)
    # An id that disappeared never comes back.
    for k in range(1, len(alive_sets)):
        gone = alive_sets[k - 1] - alive_sets[k]
        assert not any(gone & s for s in alive_sets[k:])
    assert max(all_ids) == len(all_ids) - 1  # ids handed out consecutively


def test_ring_sampling_is_uniform_on_the_ring():
    u = np.random.default_rng(0).random((200000, 3))
    z = sample_boundary_ring(u, E, 5.0)
    assert np.all(E.distance_to_boundary(z) <= 5.0) and np.all(E.contains(z))
    # Uniform on the ring: each 5 x 5 m corner square holds 25/1900 of the points.
    corner = (z[:, 0] <= 5) & (z[:, 1] <= 5)
    assert corner.mean() == pytest.approx(25 / 1900, rel=0.05)
    bottom_mid = (z[:, 1] <= 5) & (z[:, 0] > 5) & (z[:, 0] < 95)
    assert bottom_mid.mean() == pytest.approx(450 / 1900, rel=0.02)


def test_ring_area_covers_small_maps():
    assert boundary_ring_area(E, 5.0) == pytest.approx(1900.0)
    assert boundary_ring_area(Environment(0, 0, 8, 20), 5.0) == pytest.approx(160.0)
    z = sample_boundary_ring(np.random.default_rng(0).random((1000, 3)),
                             Environment(0, 0, 8, 20), 5.0)
    assert np.all(Environment(0, 0, 8, 20).contains(z))


def test_walker_step_rejects_fractional_substeps():
    w = DamesWalkers(E, [[50.0, 50.0]], [0.0])
    with pytest.raises(ValueError, match="whole number"):
        w.step(np.random.default_rng(0), 0.25)
