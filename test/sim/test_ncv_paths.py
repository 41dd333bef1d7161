"""Papaioannou et al.'s Fig. 5 truth: whole lives inside the area and the run (issue 33)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phd_swarm.config.sweep_spec import config_hash
from phd_swarm.core.geometry.grid import Environment
from phd_swarm.sim.lifetimes import alive_steps, in_area_lifetimes
from phd_swarm.sim.ncv_paths import NcvPaths, truncated_geometric_p
from phd_swarm.sim.ncv_targets import NcvTargets
from phd_swarm.sim.presets import PRESETS
from phd_swarm.sim.targets import make_targets

ENV = Environment(0.0, 0.0, 100.0, 100.0)


def _run(targets, steps):
    """Ids and positions of ``targets`` at every step of a run."""
    rng = np.random.default_rng(0)
    out = []
    for _ in range(steps):
        out.append((targets.ids.copy(), targets.positions.copy()))
        targets.step(rng, 1.0)
    return out


def test_contained_paths_stay_inside_and_end_by_the_runs_end():
    t = NcvPaths.sample(np.random.default_rng(1), ENV, 200, 1.0, 100, model="contained",
                        lifetime_mean=30.0, birth_spread=100.0, q=0.01)
    seen = _run(t, 100)
    births, lives = t.birth_steps, t.lifetimes
    assert np.all(births + lives <= 100) and np.all(births < 100) and np.all(lives >= 1)
    for _, pos in seen:
        assert np.all((pos >= 0.0) & (pos <= 100.0))
    counts = dict(zip(*alive_steps(_table(seen)), strict=True))
    assert all(counts[i] == lives[i] for i in range(200))       # no life is cut short
    same = NcvPaths.sample(np.random.default_rng(1), ENV, 200, 1.0, 100, model="contained",
                           lifetime_mean=30.0, birth_spread=100.0, q=0.01)
    np.testing.assert_array_equal(same.lifetimes, lives)
    # Without a birth spread every target is there from the start.
    assert not NcvPaths.sample(np.random.default_rng(2), ENV, 20, 1.0, 100,
                               model="contained").birth_steps.any()


def test_exit_paths_live_until_they_leave_the_area():
    """Without process noise the move after a life's last step is the one that leaves E."""
    t = NcvPaths.sample(np.random.default_rng(3), ENV, 100, 1.0, 100, model="exit", q=0.0)
    f = np.eye(4) + np.diag([1.0, 0.0, 1.0], 1)
    lives = t.lifetimes
    assert np.all(lives < 100)                     # 141 m at most at sqrt(2) m/s
    for i in range(100):
        path = t._paths[i]
        assert np.all((path[:, [0, 2]] >= 0.0) & (path[:, [0, 2]] <= 100.0))
        np.testing.assert_allclose(path[1:], path[:-1] @ f.T)
        nxt = (f @ path[-1])[[0, 2]]
        assert np.any((nxt < 0.0) | (nxt > 100.0))
        assert np.hypot(path[0, 1], path[0, 3]) == pytest.approx(np.sqrt(2.0))
    rng = np.random.default_rng(0)
    before = rng.bit_generator.state
    t.step(rng, 1.0)
    assert rng.bit_generator.state == before                     # the paths are drawn


def test_truncated_geometric_p_gives_the_mean_it_is_asked_for():
    for mean, n in ((30.0, 100), (5.0, 10), (1.0, 50)):
        p = truncated_geometric_p(mean, n)
        q = 1.0 - p
        ell = np.arange(1, n + 1)
        w = p * q ** (ell - 1)
        assert (w * ell).sum() / w.sum() == pytest.approx(mean, rel=1e-9)
    assert truncated_geometric_p(60.0, 100) is None and truncated_geometric_p(0.5, 10) is None


def _table(seen):
    width = max(len(ids) for ids, _ in seen)
    out = np.full((len(seen), width), -1, dtype=np.int64)
    for k, (ids, _) in enumerate(seen):
        out[k, :len(ids)] = ids
    return out


def _fig5(model, seed):
    base = PRESETS["papaioannou"](agents=2, targets=20, spawn="uniform")
    return base.with_overrides(seed=seed, targets=dataclasses.replace(
        base.targets, lifetime_mean=30.0, birth_spread=100.0, lifetime_model=model))


@pytest.mark.parametrize("model, low, high", [
    ("cut", 13.5, 16.5),          # the geometric 30 cut by the edge and the run's end: ~15
    ("contained", 28.5, 31.5),    # the stated 30
    ("exit", 33.0, 37.0),         # the time to cross the area at sqrt(2) m/s: ~35
])
def test_the_in_area_mean_lifetime_of_each_model_over_many_seeds(model, low, high):
    """Fig. 5a's truth (20 targets, mean 30 s, births over the run), 100 seeds each."""
    lives = np.concatenate([in_area_lifetimes(_fig5(model, seed)) for seed in range(100)])
    assert len(lives) == 2000
    assert low < lives.mean() < high


def test_the_scenario_names_the_model_and_only_a_new_model_enters_the_hash():
    cut = _fig5("cut", 0)
    assert isinstance(make_targets(np.random.default_rng(0), cut), NcvTargets)
    assert isinstance(make_targets(np.random.default_rng(0), _fig5("exit", 0)), NcvPaths)
    hashes = {m: config_hash(_fig5(m, 0), "sat_search_track", "mean", (0.0, 100.0),
                             "distributed") for m in ("cut", "contained", "exit")}
    assert len(set(hashes.values())) == 3
    base = PRESETS["papaioannou"]()
    with pytest.raises(ValueError, match="spawn: uniform"):                # from the centre
        base.with_overrides(targets=dataclasses.replace(base.targets, lifetime_model="contained"))
    with pytest.raises(ValueError, match="lifetime_model"):
        dataclasses.replace(base.targets, spawn="uniform", lifetime_model="forever")
