"""Tests for a scenario's initial targets by its kind (phd_swarm.sim.targets)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phd_swarm.sim.dames_targets import DamesWalkers, StaticTargets
from phd_swarm.sim.ncv_paths import NcvPaths
from phd_swarm.sim.ncv_targets import NcvTargets
from phd_swarm.sim.presets import (
    chen_clustered,
    dames_moving,
    dames_static,
    papaioannou,
    shirsat_berman,
    sung_tokekar,
)
from phd_swarm.sim.scenario import Scenario
from phd_swarm.sim.targets import TARGET_KINDS, make_targets
from phd_swarm.sim.walkers import ClusteredWalkers, TurningWalkers


def _of_kind(base: Scenario, kind: str, **fields) -> Scenario:
    return base.with_overrides(targets=dataclasses.replace(base.targets, kind=kind, **fields))


@pytest.mark.parametrize("preset, kind", [(dames_static, StaticTargets),
                                          (dames_moving, DamesWalkers),
                                          (chen_clustered, ClusteredWalkers)])
def test_make_targets_builds_the_preset_population(preset, kind):
    t = make_targets(np.random.default_rng(0), preset())
    assert isinstance(t, kind)
    if kind is DamesWalkers:
        assert len(t.ids) == 20
        assert t.expected_births == pytest.approx(5.26e-5 * 1900)
    if kind is ClusteredWalkers:
        assert len(t.ids) == 60


def test_make_targets_without_birth():
    s = dames_moving()
    s = s.with_overrides(targets=s.targets.__class__(kind="dames_walk", count=5, birth=False))
    t = make_targets(np.random.default_rng(0), s)
    assert t.expected_births == 0.0


def _direct(kind: str, rng: np.random.Generator, s: Scenario):
    """The population each kind stood for before the kinds were registered, drawn by hand."""
    c, env = s.targets, s.env
    if kind == "static":
        return StaticTargets.sample(rng, env, c.count, c.draw_box)
    if kind == "dames_walk":
        return DamesWalkers.sample(rng, env, c.count, c.speed, c.heading_sd, c.heading_rate,
                                   s.models.birth if c.birth else None, c.birth_heading)
    if kind == "clustered_walk":
        return ClusteredWalkers.sample(rng, c.clusters, c.per_cluster, c.step_sd, c.max_speed)
    if kind == "turning_walk":
        return TurningWalkers.sample(rng, env, c.count, c.draw_box, c.speed, c.turn_every)
    if c.lifetime_model != "cut":
        return NcvPaths.sample(rng, env, c.count, s.dt, s.steps, model=c.lifetime_model,
                               draw_box=c.draw_box, speed=c.speed,
                               lifetime_mean=c.lifetime_mean, birth_spread=c.birth_spread,
                               q=c.process_noise, noise_form=c.noise_form)
    return NcvTargets.sample(rng, env, c.count, s.dt, spawn=c.spawn, draw_box=c.draw_box,
                             speed=c.speed, lifetime_mean=c.lifetime_mean,
                             birth_spread=c.birth_spread, q=c.process_noise,
                             noise_form=c.noise_form)


def _scenarios():
    yield "static", dames_static()
    yield "dames_walk", dames_moving()
    yield "dames_walk", _of_kind(dames_moving(), "dames_walk", birth_heading="uniform")
    yield "clustered_walk", chen_clustered()
    yield "turning_walk", _of_kind(sung_tokekar(), "turning_walk")
    yield "ncv", papaioannou()
    for model in ("contained", "exit"):
        yield "ncv", _of_kind(papaioannou(targets=20, spawn="uniform"), "ncv",
                              lifetime_model=model, lifetime_mean=30.0, birth_spread=20.0)


@pytest.mark.parametrize("kind, scenario", list(_scenarios()),
                         ids=[f"{k}-{i}" for i, (k, _) in enumerate(_scenarios())])
def test_the_looked_up_kind_draws_what_the_model_draws_to_the_bit(kind, scenario):
    # Same targets, same draws in the same order: the steps consume the same stream.
    a = make_targets(np.random.default_rng(3), scenario)
    b = _direct(kind, np.random.default_rng(3), scenario)
    assert type(a) is type(b)
    ra, rb = np.random.default_rng(4), np.random.default_rng(4)
    for _ in range(20):
        assert np.array_equal(a.ids, b.ids) and np.array_equal(a.positions, b.positions)
        a.step(ra, scenario.dt)
        b.step(rb, scenario.dt)
    assert ra.bit_generator.state == rb.bit_generator.state


def test_every_kind_draws_its_targets():
    drawn = {kind for kind, s in _scenarios()
             if len(make_targets(np.random.default_rng(0), s).ids) > 0}
    assert drawn == set(TARGET_KINDS)


def test_a_layout_seed_fixes_static_targets_whatever_the_run():
    s = shirsat_berman()
    a = make_targets(np.random.default_rng(0), s)
    b = make_targets(np.random.default_rng(99), s)
    assert np.array_equal(a.positions, b.positions)
    free = _of_kind(s, "static", layout_seed=None)
    assert not np.array_equal(make_targets(np.random.default_rng(0), free).positions,
                              make_targets(np.random.default_rng(99), free).positions)
