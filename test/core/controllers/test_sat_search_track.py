"""Papaioannou et al.'s control: search by plans, track by the Rényi reward, yield overlaps."""

from __future__ import annotations

import numpy as np

from phd_swarm.core import registry
from phd_swarm.core.controllers.base import Knowledge
from phd_swarm.core.exchange.sat_share import SatMsg, SatView
from phd_swarm.core.scan import Scan
from phd_swarm.core.sensors.square_range_bearing import simulate_scan
from phd_swarm.core.tracking_overlap import pick_switcher
from phd_swarm.sim.scenario import PRESETS


def _parts(robot_id=0, **options):
    sc = PRESETS["papaioannou"]()
    sc = sc.with_overrides(system=sc.system.with_parts(options={"process_noise": 0.01,
                                                                **options}))
    est_part = registry.lookup("estimator", "papaioannou_sat")
    ctl_part = registry.lookup("controller", "sat_search_track")
    return (est_part.make(est_part.setup(sc, sc.system), robot_id),
            ctl_part.make(ctl_part.setup(sc, sc.system), robot_id), sc)


def test_searching_moves_towards_the_nearest_unvisited_node():
    est, ctl, _ = _parts()
    s = np.array([2.5, 2.5])
    est.predict()
    est.update(Scan(0, 0, s, np.empty((0, 2))))
    d = ctl.decide(Knowledge(0, 0, s, np.empty((0, 2)), SatView(0), est),
                   np.random.default_rng(0))
    assert not ctl.tracking
    step = d.goal - s
    assert np.hypot(*step) == 4.0 and ctl.plan is not None and not ctl.plan.done
    target = est.setup.grid.positions[ctl.plan.next_node()]
    assert np.hypot(*(target - d.goal)) < np.hypot(*(target - s))


def test_tracking_keeps_a_detected_target_in_the_square():
    est, ctl, _ = _parts()
    rng = np.random.default_rng(4)
    s, target = np.array([50.0, 50.0]), np.array([[53.0, 50.0]])
    for k in range(6):
        est.predict()
        est.update(Scan(0, k, s, simulate_scan(rng, est.setup.sensor, s, target)))
    assert len(est.estimates())
    d = ctl.decide(Knowledge(0, 3, s, np.empty((0, 2)), SatView(3), est), rng)
    assert ctl.tracking
    assert np.abs(d.goal - target[0]).max() <= 5.0               # the target stays in view


def test_of_two_agents_tracking_the_same_targets_the_picked_one_yields():
    """Exactly the agent pick_switcher names yields, once the window fires.

    No clutter, and Q_th raised to 6 m: two agents' estimates of one target differ by
    about the range sd (1 m), so the paper's 0.9 m over 3 steps rarely fires
    (docs/decisions.md).
    """
    rng = np.random.default_rng(5)
    target = np.array([[50.0, 50.0]])
    agents = [_parts(r, overlap_threshold=6.0, clutter_rate=0.0) for r in (0, 1)]
    where = [np.array([48.0, 50.0]), np.array([52.0, 50.0])]
    for k in range(5):
        for (est, _, _), s in zip(agents, where, strict=True):
            est.predict()
            est.update(Scan(0, k, s, simulate_scan(rng, est.setup.sensor, s, target)))
    yielded = []
    for k in range(5, 12):
        preds = [est.predicted_states()[:, :2] for est, _, _ in agents]
        for r, (est, ctl, _) in enumerate(agents):
            other = 1 - r
            msg = SatMsg(other, k, where[other], agents[other][1].tracking or k == 5,
                         preds[other], np.empty(0))
            ctl.decide(Knowledge(r, k, where[r], np.empty((0, 2)), SatView(k, {other: msg}),
                                 est), rng)
        yielded.append([bool(ctl.yielding) for _, ctl, _ in agents])
        for (est, _, _), s in zip(agents, where, strict=True):
            est.predict()
            est.update(Scan(0, k, s, simulate_scan(rng, est.setup.sensor, s, target)))
    first = next(i for i, y in enumerate(yielded) if any(y))
    switcher = pick_switcher(agents[0][2].seed, 5 + first, 0, 1)
    assert yielded[first] == [switcher == 0, switcher == 1]


def test_an_agent_alone_keeps_a_slow_target_in_view_with_the_default_models():
    """One agent tracks one target at ~1 m/s for >= 45 of 50 steps.

    The default models: the paper's clutter (10 per scan over the measurement space),
    estimates from all the particles' weight.
    """
    est, ctl, _ = _parts()
    rng = np.random.default_rng(0)
    s, x = np.array([50.0, 50.0]), np.array([52.0, 51.0, 0.7, -0.7])
    tracked = 0
    for k in range(50):
        est.predict()
        est.update(Scan(0, k, s, simulate_scan(rng, est.setup.sensor, s, x[None, :2])))
        d = ctl.decide(Knowledge(0, k, s, np.empty((0, 2)), SatView(k), est), rng)
        e = est.estimates()
        tracked += bool(len(e)) and np.min(np.hypot(*(e - x[:2]).T)) <= 3.0
        s, x = d.goal, x + np.r_[x[2:], 0.0, 0.0]
    assert tracked >= 45


def test_a_search_only_agent_keeps_searching_with_targets_in_view():
    rng = np.random.default_rng(4)
    s, target = np.array([50.0, 50.0]), np.array([[53.0, 50.0]])
    for track, expected in ((True, True), (False, False)):
        est, ctl, _ = _parts(track_targets=track)
        for k in range(4):
            est.predict()
            est.update(Scan(0, k, s, simulate_scan(rng, est.setup.sensor, s, target)))
        assert len(est.estimates())
        ctl.decide(Knowledge(0, 3, s, np.empty((0, 2)), SatView(3), est), rng)
        assert ctl.tracking is expected
