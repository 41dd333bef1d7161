"""Papaioannou et al.'s exchange: agents in range share maps by the event rule of Sec. V-B d."""

from __future__ import annotations

import numpy as np

from phd_swarm.core import registry
from phd_swarm.core.exchange.radio import RangeRadio
from phd_swarm.core.exchange.sat_share import SatMsg, SatShare
from phd_swarm.sim.presets import PRESETS


class _Controller:
    def __init__(self, members=(), tracking=False):
        self.plan_members = members
        self.tracking = tracking


def _agents(positions, members=None, radio=50.0):
    sc = PRESETS["papaioannou"]()
    part = registry.lookup("estimator", "papaioannou_sat")
    setup = part.setup(sc, sc.system)
    out = []
    for rid in range(len(positions)):
        ex = SatShare(rid, RangeRadio(radio))
        ex.bind_estimator(part.make(setup, rid))
        ex.bind_controller(_Controller(members[rid] if members else (rid,)))
        out.append(ex)
    ids = np.arange(len(positions))
    for ex in out:
        ex.observe_team(0, ids, np.asarray(positions, dtype=float), np.ones(len(ids), bool))
    return out


def _step(agents, positions):
    queue = []
    for ex, p in zip(agents, positions, strict=True):
        ex.estimator.search[:] = 0.0
        ex.estimator.search[ex.robot_id] = 1.0          # a mark of its own
        queue += ex.start_step(0, np.asarray(p, dtype=float), 0.0, np.empty((0, 2)))
    for env in queue:
        agents[env.dst].receive(env.msg)
    for ex in agents:
        ex.advance()
    return queue


def test_agents_in_range_exchange_and_max_merge_their_maps():
    pos = [[10.0, 10.0], [40.0, 10.0], [95.0, 95.0]]
    agents = _agents(pos)
    sent = _step(agents, pos)
    assert sorted((e.src, e.dst) for e in sent) == [(0, 1), (1, 0)]
    assert all(isinstance(e.msg, SatMsg) for e in sent)
    assert agents[0].view.maps_from == (1,) and agents[1].view.maps_from == (0,)
    assert agents[0].estimator.search[:2].tolist() == [1.0, 1.0]
    assert agents[2].done and agents[2].view.messages == {}
    np.testing.assert_array_equal(agents[0].view.messages[1].position, pos[1])


def test_agents_in_one_joint_plan_do_not_exchange_maps_again():
    pos = [[10.0, 10.0], [40.0, 10.0], [30.0, 30.0]]
    agents = _agents(pos, members=[(0, 1), (0, 1), (2,)])
    sent = _step(agents, pos)
    maps = sorted((e.src, e.dst) for e in sent if e.msg.search.size)
    assert maps == [(0, 2), (1, 2), (2, 0), (2, 1)]
    assert agents[0].view.maps_from == (2,) and agents[2].view.maps_from == (0, 1)
    # One side in a plan with the other is enough to stop the pair (the receiver's side).
    agents = _agents(pos[:2], members=[(0, 1), (1,)])
    _step(agents, pos[:2])
    assert agents[0].view.maps_from == () and agents[1].view.maps_from == ()
