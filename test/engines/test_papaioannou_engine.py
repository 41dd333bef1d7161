"""Papaioannou et al.'s system in the distributed engine: reproducible, searching, in range."""

from __future__ import annotations

import numpy as np

from phd_swarm.core.search_map import searched_fraction
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim.scenario import PRESETS


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
