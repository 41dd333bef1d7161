"""Papaioannou et al.'s SAT density: the particle PHD of the targets and the search map."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core import registry
from phd_swarm.core.estimators.papaioannou import search_map as sm
from phd_swarm.core.estimators.papaioannou.estimator import PapaioannouEstimator, ncv_model
from phd_swarm.core.estimators.smc_phd.estimator import ScanBirth, SmcPhdEstimator
from phd_swarm.core.scan import Scan
from phd_swarm.core.sensors.square_range_bearing import simulate_scan
from phd_swarm.sim.presets import PRESETS


def _estimator(robot_id=0, **options):
    sc = PRESETS["papaioannou"]()
    sc = sc.with_overrides(system=sc.system.with_parts(options=options))
    part = registry.lookup("estimator", "papaioannou_sat")
    return part.make(part.setup(sc, sc.system), robot_id), sc


def test_the_part_reads_the_sensor_and_its_options():
    est, sc = _estimator()
    s = est.setup
    assert isinstance(est, PapaioannouEstimator)
    assert (s.p_s, s.birth_mass, s.decay, s.per_target) == (0.99, 3.0, 0.999, 300)
    assert (s.sensor.side, s.sensor.p_d, s.sensor.clutter_rate) == (10.0, 0.99, 10.0)
    assert s.sensor.clutter_max_range == pytest.approx(141.42)
    assert s.grid.size == 400 and s.grid.side == 10.0              # 5 m nodes on 100 m
    assert (s.confirmed_only, s.extraction, s.measurement_births) == (True, "persistent", True)
    assert (s.hold_gate, s.look_tentative) == (5.0, True)
    f, q = ncv_model(1.0, 0.01)
    np.testing.assert_array_equal(s.f, f)
    np.testing.assert_array_equal(s.q, q)
    np.testing.assert_allclose(ncv_model(1.0, 1.0)[1][[0, 0, 2], [0, 2, 2]],
                               [1 / 3, 1 / 2, 1.0])
    # Every option reaches its own field (the setup once passed two of them swapped).
    t = _estimator(estimates_from="square", births="uniform", hold_gate=0.0,
                   look_tentative=False)[0].setup
    assert (t.confirmed_only, t.extraction, t.measurement_births) == (False, "square", False)
    assert (t.hold_gate, t.look_tentative) == (0.0, False)


@pytest.mark.parametrize("clutter", [0.0, 10.0])
def test_a_target_in_view_is_estimated_from_its_second_detection_on(clutter):
    """A slow target 2-3 m from the agent (q = 0.01: nearly constant velocity)."""
    est, _ = _estimator(process_noise=0.01, clutter_rate=clutter, clutter_space="square",
                        estimates_from="persistent")
    rng = np.random.default_rng(4)
    x = np.array([52.0, 50.0, -0.1, 0.1])
    s = np.array([50.0, 50.0])
    counts, errors = [], []
    for k in range(12):
        est.predict()
        est.update(Scan(0, k, s, simulate_scan(rng, est.setup.sensor, s, x[None, :2])))
        counts.append(len(est.estimates()))
        if counts[-1]:
            errors.append(np.min(np.hypot(*(est.estimates() - x[:2]).T)))
        x = x + np.r_[x[2:], 0.0, 0.0]
    assert counts[0] == 0                                      # births report a step later
    assert sum(c >= 1 for c in counts[1:]) >= 7
    assert np.median(errors) < 1.5                             # the range sd is 1 m
    pred = est.predicted_states()
    np.testing.assert_allclose(pred, est.estimate_states() @ est.setup.f.T)


def test_the_search_map_follows_eq_7_and_9_and_merges_by_max():
    est, _ = _estimator()
    grid = est.setup.grid
    first, second = np.array([12.5, 12.5]), np.array([32.5, 12.5])
    est.predict()
    est.update(Scan(0, 0, first, np.empty((0, 2))))
    np.testing.assert_array_equal(est.search, grid.inside(first).astype(float))
    est.predict()
    est.update(Scan(0, 1, second, np.empty((0, 2))))
    expect = sm.update(sm.predict(grid.inside(first).astype(float), grid, first, 0.999), grid,
                       second)
    np.testing.assert_array_equal(est.search, expect)
    other = np.zeros(grid.size)
    other[-1] = 0.5
    est.merge_search(other)
    assert est.search[-1] == 0.5 and est.search.max() == 1.0
    with pytest.raises(ValueError, match="search values"):
        est.merge_search(np.zeros(3))


def test_each_agent_draws_from_its_own_stream():
    a, _ = _estimator(0)
    b, _ = _estimator(1)
    c, _ = _estimator(0)
    assert a.rng.random() == c.rng.random() != b.rng.random()


def _exact_scan(sensor_model, s, targets):
    """Noise-free measurements of ``targets`` from ``s``, no clutter (M, 2)."""
    d = np.asarray(targets, dtype=float).reshape(-1, 2) - s
    return np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0])])


def test_a_first_detection_is_tentative_not_an_estimate():
    est, _ = _estimator(clutter_rate=0.0)
    s, target = np.array([50.0, 50.0]), np.array([[53.0, 51.0]])
    est.predict()
    est.update(Scan(0, 0, s, _exact_scan(est.setup.sensor.model, s, target)))
    assert len(est.estimates()) == 0
    tentative = est.tentative_states()
    assert len(tentative) == 1 and np.hypot(*(tentative[0, :2] - target[0])) < 0.5
    # The controller looks at it (track_states); it is not in X^_{k+1|k}, which the agents
    # exchange and compare by eq. 19 (issue 33).
    np.testing.assert_array_equal(est.track_states(), tentative @ est.setup.f.T)
    assert est.predicted_states().shape == (0, 4)
    est.predict()
    est.update(Scan(0, 1, s, _exact_scan(est.setup.sensor.model, s, target)))
    assert len(est.estimates()) == 1 and len(est.tentative_states()) == 0
    np.testing.assert_array_equal(est.predicted_states(), est.track_states())
    off, _ = _estimator(clutter_rate=0.0, look_tentative=False)
    off.predict()
    off.update(Scan(0, 0, s, _exact_scan(off.setup.sensor.model, s, target)))
    assert len(off.track_states()) == 0 and len(off.tentative_states()) == 0


@pytest.mark.parametrize("gate", [0.0, 5.0])
def test_an_estimate_is_held_out_of_view_and_dropped_when_missed_in_view(gate):
    est, _ = _estimator(clutter_rate=0.0, hold_gate=gate)
    s, target = np.array([50.0, 50.0]), np.array([[52.0, 50.0]])
    for k in range(4):
        est.predict()
        est.update(Scan(0, k, s, _exact_scan(est.setup.sensor.model, s, target)))
    assert len(est.estimates()) == 1
    away = np.array([70.0, 50.0])                                # the target out of view
    est.predict()
    est.update(Scan(0, 4, away, np.empty((0, 2))))
    if gate == 0.0:
        assert len(est.estimates()) == 0                           # only measurements give one
        return
    held = est.estimates()
    assert len(held) == 1 and np.hypot(*(held[0] - target[0])) < 1.0
    est.predict()
    est.update(Scan(0, 5, s, np.empty((0, 2))))                    # missed in view: 1 % stays
    assert len(est.estimates()) == 0


def test_the_particle_phd_is_the_smc_phd_estimator_it_holds():
    """Papaioannou composes the particle filter: its models, births and resampling."""
    est, _ = _estimator(clutter_rate=0.0, roughening=0.2)
    pf = est.filter
    assert isinstance(pf, SmcPhdEstimator) and pf.rng is est.rng
    assert isinstance(pf.birth, ScanBirth) and pf.extraction == "measurement_only"
    r = pf.resampling
    assert (r.per_target, r.min_particles, r.max_particles, r.roughening) == (300, 300, 6000,
                                                                              0.2)
    s, target = np.array([50.0, 50.0]), np.array([[53.0, 51.0]])
    est.predict()
    est.update(Scan(0, 0, s, _exact_scan(est.setup.sensor.model, s, target)))
    assert est.particles is pf.particles and est.expected_count() == pf.expected_count()
    states = np.array([[53.0, 51.0, 0.0, 0.0], [80.0, 80.0, 0.0, 0.0]])
    np.testing.assert_array_equal(pf.p_d(states, s), [0.99, 0.0])       # the sensor's p_D
    np.testing.assert_array_equal(est.export_state()["states"], pf.particles.states)
