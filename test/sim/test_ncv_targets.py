"""Papaioannou et al.'s truth: NCV targets with births, lifetimes and deaths at the border."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.sim.ncv_targets import NcvTargets, ncv_matrices

ENV = Environment(0.0, 0.0, 100.0, 100.0)


def test_ncv_matrices_standard_and_printed_agree_at_one_second():
    f, q = ncv_matrices(1.0, 1.0)
    np.testing.assert_array_equal(f[:2, :2], [[1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_allclose(q[:2, :2], [[1 / 3, 1 / 2], [1 / 2, 1.0]])
    assert np.array_equal(q, ncv_matrices(1.0, 1.0, "printed")[1])
    assert not np.allclose(ncv_matrices(2.0, 1.0)[1], ncv_matrices(2.0, 1.0, "printed")[1])
    assert np.array_equal(q[2:, 2:], q[:2, :2]) and not q[:2, 2:].any()
    with pytest.raises(ValueError, match="noise form"):
        ncv_matrices(1.0, 1.0, "other")


def test_without_noise_targets_fly_straight_are_born_on_time_and_die_on_time():
    states = np.array([[10.0, 1.0, 20.0, -1.0], [50.0, 0.0, 50.0, 2.0],
                       [92.0, 5.0, 50.0, 0.0]])
    t = NcvTargets(ENV, states, birth_steps=[0, 2, 0], lifetimes=[3, 10, 10], dt=1.0, q=0.0)
    rng = np.random.default_rng(0)
    seen = []
    for _ in range(6):
        seen.append((t.ids.tolist(), t.positions.copy()))
        t.step(rng, 1.0)
    assert [ids for ids, _ in seen] == [[0, 2], [0, 2], [0, 1], [1], [1], [1]]
    np.testing.assert_array_equal(seen[2][1], [[12.0, 18.0], [50.0, 50.0]])
    np.testing.assert_array_equal(seen[4][1], [[50.0, 54.0]])       # born at 2, 2 m/s in y


def test_sample_is_reproducible_and_follows_its_settings():
    a = NcvTargets.sample(np.random.default_rng(3), ENV, 200, 1.0, spawn="centre",
                          lifetime_mean=60.0)
    b = NcvTargets.sample(np.random.default_rng(3), ENV, 200, 1.0, spawn="centre",
                          lifetime_mean=60.0)
    assert np.array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.positions, np.full((200, 2), 50.0))
    speeds = np.hypot(a.states[:, 1], a.states[:, 3])
    np.testing.assert_allclose(speeds, np.sqrt(2.0))
    spread = NcvTargets.sample(np.random.default_rng(4), ENV, 4000, 1.0, birth_spread=100.0,
                               lifetime_mean=30.0)
    births, lives = spread._births, spread._ends - spread._births
    assert births.min() == 0 and births.max() == 99
    assert lives.mean() == pytest.approx(30.0, rel=0.05)
    assert len(spread.ids) == np.count_nonzero(births == 0)


def test_a_target_that_leaves_the_region_dies_and_its_id_is_never_reused():
    t = NcvTargets(ENV, [[99.5, 1.0, 50.0, 0.0], [10.0, 0.0, 10.0, 0.0]], [0, 0], [50, 50],
                   dt=1.0, q=0.0)
    t.step(np.random.default_rng(0), 1.0)
    assert t.ids.tolist() == [1]
    for _ in range(5):
        t.step(np.random.default_rng(0), 1.0)
    assert t.ids.tolist() == [1]


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="lifetimes"):
        NcvTargets(ENV, [[0.0, 0.0, 0.0, 0.0]], [0], [0], dt=1.0)
    with pytest.raises(ValueError, match="spawn"):
        NcvTargets.sample(np.random.default_rng(0), ENV, 3, 1.0, spawn="edge")
    with pytest.raises(ValueError, match="lifetime_mean"):
        NcvTargets.sample(np.random.default_rng(0), ENV, 3, 1.0, lifetime_mean=0.5)
