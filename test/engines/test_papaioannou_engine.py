"""Papaioannou et al.'s system in the distributed engine: runs, series and options.

Reproducible, searching, in range; its per-target series, the look rule, the lifetime models
and the overlap test's form.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from phd_swarm.config.sweep_spec import find_spec, load_spec
from phd_swarm.core.estimators.papaioannou.search_map import searched_fraction
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim.lifetimes import alive_steps, in_area_lifetimes
from phd_swarm.sim.presets import PRESETS
from phd_swarm.tools.sweep import run_trial


def _run(seed, steps=30, agents=3):
    sc = PRESETS["papaioannou"](agents=agents).with_overrides(seed=seed,
                                                              duration=float(steps))
    engine = DistributedEngine(sc)
    fractions, sent, contacts = [], 0, 0
    for _ in range(sc.steps):
        engine.step()
        fractions.append(np.mean([searched_fraction(engine.agents[r].estimator.search)
                                  for r in engine.agents]))
        for r in engine.agents:
            ex = engine.agents[r].exchange
            contacts += ex.contacts.size
    for r in engine.agents:
        sent += engine.agents[r].exchange.stats["sent"]
    states = [engine.agents[r].estimator.particles.states.copy() for r in sorted(engine.agents)]
    return fractions, sent, contacts, states, engine


def test_a_run_is_reproducible_bit_for_bit_and_the_team_searches():
    a = _run(3)
    b = _run(3)
    assert a[0] == b[0] and all(np.array_equal(x, y) for x, y in zip(a[3], b[3], strict=True))
    fractions = a[0]
    assert fractions[-1] > 4 * fractions[0] and np.all(np.diff(fractions) >= -0.01)
    # One message per agent in range per step, nothing to agents out of range.
    assert a[1] == a[2] > 0
    c = _run(4)
    assert c[0] != a[0]


def test_out_of_radio_range_nobody_talks():
    sc = PRESETS["papaioannou"](agents=2).with_overrides(seed=1, duration=5.0)
    sc = sc.with_overrides(system=sc.system.with_parts(options={"radio_range": 0.0}))
    engine = DistributedEngine(sc)
    engine.run()
    assert all(engine.agents[r].exchange.stats["sent"] == 0 for r in engine.agents)


def _fig5a_trial(steps=30, robots=4, **changes):
    """Fig. 5a's first quick trial, cut to ``steps``, with scenario or option ``changes``."""
    trial = next(t for t in load_spec(find_spec("papaioannou_fig5a"), quick=True).trials_list()
                 if t.robots == 2)
    sc = trial.scenario.with_overrides(duration=float(steps), robots=robots)
    targets = {k: v for k, v in changes.items() if k == "lifetime_model"}
    options = {k: v for k, v in changes.items() if k not in targets}
    sc = sc.with_overrides(targets=dataclasses.replace(sc.targets, **targets),
                           system=sc.system.with_parts(options=options))
    return dataclasses.replace(trial, scenario=sc, robots=robots)


def test_a_trial_saves_each_targets_id_trackers_and_lifetime_with_its_series():
    trial = _fig5a_trial()
    _, s = run_trial(trial)
    ids, trackers, seen = s["target_ids"], s["target_trackers"], s["target_in_view"]
    assert ids.dtype == trackers.dtype == np.int64 and ids.shape[0] == 30
    assert ids.shape == trackers.shape == seen.shape and ids.shape[1] >= 1
    np.testing.assert_array_equal((ids >= 0).sum(axis=1), s["targets_alive"])
    np.testing.assert_array_equal((trackers > 0).sum(axis=1), s["targets_tracked"])
    assert np.all((trackers >= 0) == (ids >= 0)) and np.all(trackers < 2 ** 4)
    # The lifetimes the series give are the simulator's.
    _, lives = alive_steps(ids)
    np.testing.assert_array_equal(lives, in_area_lifetimes(trial.scenario))
    for name in ("agents_looking", "overlap_tests", "overlaps_fired", "overlap_best"):
        assert s[name].shape == (30,)
    assert s["agents_looking"].sum() > 0                           # clutter draws looks


def test_the_look_rule_can_be_turned_off():
    looks = {}
    for on in (True, False):
        engine = DistributedEngine(_fig5a_trial(look_tentative=on).scenario)
        engine.run()
        looks[on] = sum(engine.agents[r].controller.stats["look_steps"] for r in engine.agents)
        if not on:
            assert all(len(engine.agents[r].estimator.tentative_states()) == 0
                       for r in engine.agents)
    assert looks[True] > 0 and looks[False] == 0


def test_the_contained_lifetime_model_runs_whole_lives_in_the_engine():
    trial = _fig5a_trial(steps=100, robots=2, lifetime_model="contained")
    engine = DistributedEngine(trial.scenario)
    lives = engine.world.targets.lifetimes
    assert np.all(engine.world.targets.birth_steps + lives <= 100)
    _, measured = alive_steps(run_trial(trial)[1]["target_ids"])
    np.testing.assert_array_equal(measured, lives)


def test_the_overlap_threshold_form_reaches_the_controller():
    sc = _fig5a_trial(overlap_threshold_form="mean").scenario
    engine = DistributedEngine(sc)
    assert {engine.agents[r].controller.setup.overlap_form for r in engine.agents} == {"mean"}
    assert DistributedEngine(_fig5a_trial().scenario).agents[0].controller.setup \
        .overlap_form == "sum"
