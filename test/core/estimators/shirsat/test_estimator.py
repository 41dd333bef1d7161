"""Shirsat & Berman's estimator: ring births, the GM-PHD step, the reward set, the figures."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config import load_run_config
from phd_swarm.core import registry
from phd_swarm.core.estimators.gm_phd.births import RING_ANGLES, RingBirth
from phd_swarm.core.estimators.gm_phd.filter import GaussianMixture
from phd_swarm.core.estimators.shirsat.estimator import (
    ShirsatEstimator,
    paper_setup,
    step_team,
    update_team,
)
from phd_swarm.core.estimators.shirsat.figures import FIGURES, step_figures
from phd_swarm.core.models import (
    DiskDetection,
    GaussianMeasurement,
    PhdModels,
    UniformClutter,
)
from phd_swarm.core.ospa import ospa
from phd_swarm.core.scan import Scan
from phd_swarm.core.sensors.disk import simulate_scan
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim.scenario_dict import scenario_from_dict

#: Sec. VI's sensor: FoV radius 0.6 m, p_D 0.8, R = 0.25 I, lambda_C = 3.98e-3 per m^2.
MODELS = PhdModels(detection=DiskDetection(p_d=0.8, radius=0.6),
                   measurement=GaussianMeasurement(variance=0.25),
                   clutter=UniformClutter(density=3.98e-3))
KAPPA = 3.98e-3
ROOT = Path(__file__).resolve().parents[4]


def _gauss(z, m, var):
    """N(z; m, var I_2) by hand."""
    d2 = np.sum((np.asarray(z) - np.asarray(m)) ** 2, axis=-1)
    return np.exp(-0.5 * d2 / var) / (2.0 * np.pi * var)


# ---------------------------------------------------------------------------- births
def test_ring_birth_places_four_components_on_the_ring_around_the_robot():
    q = np.array([1.0, 2.0])
    mix = RingBirth(radius=0.48).components(q, 2)
    s = 0.48 / np.sqrt(2.0)
    np.testing.assert_allclose(mix.means, q + np.array([[s, s], [-s, s], [-s, -s], [s, -s]]),
                               rtol=0, atol=1e-15)
    np.testing.assert_array_equal(mix.weights, [0.1] * 4)
    np.testing.assert_array_equal(mix.covs, np.broadcast_to(0.5 * np.eye(2), (4, 2, 2)))
    assert RING_ANGLES == pytest.approx((np.pi / 4, 3 * np.pi / 4, 5 * np.pi / 4,
                                         7 * np.pi / 4))


def test_ring_rows_give_each_robot_its_components_bit_for_bit():
    birth = RingBirth(radius=0.48)
    sensors = np.random.default_rng(2).uniform(-5.0, 5.0, (6, 2))
    w, means, covs = birth.ring_rows(sensors)
    for q, m in zip(sensors, means, strict=True):
        mix = birth.components(q, 2)
        assert np.array_equal(m, mix.means) and np.array_equal(w, mix.weights)
        assert np.array_equal(covs, mix.covs)


def test_ring_birth_options_and_a_longer_state():
    mix = RingBirth(1.0, weight=0.3, variance=2.0, angles=(0.0,),
                    other_mean=np.array([0.5, -0.5])).components(np.zeros(2), 4)
    np.testing.assert_allclose(mix.means, [[1.0, 0.0, 0.5, -0.5]])
    np.testing.assert_allclose(mix.covs[0], np.diag([2.0, 2.0, 1.0, 1.0]))
    assert mix.weights.tolist() == [0.3]


@pytest.mark.parametrize("kw, match", [({"radius": -1.0}, "radius"),
                                       ({"radius": 1.0, "variance": 0.0}, "variance"),
                                       ({"radius": 1.0, "weight": float("nan")}, "weight"),
                                       ({"radius": 1.0, "angles": ()}, "angles")])
def test_ring_birth_refuses_bad_settings(kw, match):
    with pytest.raises(ValueError, match=match):
        RingBirth(**kw)


def test_the_births_of_a_step_sit_around_that_steps_robot_position_and_take_its_scan():
    # An empty scan: the four births (at q_k, not at an earlier position) keep only their
    # missed-detection terms 0.1 (1 - 0.8) and, 0.68 m apart with covariance 0.5 I, merge
    # into one component at q_k (Table II): weight 0.08, covariance 0.5 I + the ring's
    # spread 0.48^2 / 2 I.
    est = ShirsatEstimator(paper_setup(), robot_id=0)
    est.predict()
    est.update(Scan(0, 0, [5.0, 5.0], np.empty((0, 2))))
    est.predict()
    q = np.array([1.0, 2.0])
    est.update(Scan(0, 1, q, np.empty((0, 2))))
    mix = est.mixture
    at_q = np.hypot(*(mix.means - q).T) < 1e-12
    assert at_q.sum() == 1
    assert mix.weights[at_q][0] == pytest.approx(0.08, rel=1e-12)
    np.testing.assert_allclose(mix.covs[at_q][0], (0.5 + 0.48 ** 2 / 2) * np.eye(2),
                               rtol=1e-12, atol=1e-15)
    # The first step's births, one step older: 0.08 p_S (1 - 0) (out of view), P + Q.
    old = np.hypot(*(mix.means - 5.0).T) < 1e-12
    assert mix.weights[old][0] == pytest.approx(0.008, rel=1e-12)
    np.testing.assert_allclose(mix.covs[old][0], (0.6152 + 0.2) * np.eye(2), rtol=1e-12,
                               atol=1e-15)


@pytest.mark.parametrize("offset, kappa", [(0.58, KAPPA), (0.7, 0.0)])
def test_a_target_seen_at_the_edge_of_the_fov_gets_a_component_there(offset, kappa):
    # One measurement near (0.58 m) or just beyond (0.7 m; clutter only inside the FoV,
    # so kappa = 0 there) the 0.6 m edge, off the ring's diagonals. By hand (eq. 33-38,
    # then Table II: all eight terms are within U = 4 of the heaviest, each in its own
    # metric, so they merge): the births m_l (P = 0.5 I, p_D = 0.8 at their means 0.48 m
    # from the robot), S = 0.75 I, K = 2/3, updated covariance 1/6 I. The test is about the
    # births and the update, so it takes the merge metric under which all eight merge
    # (under the part's default, heaviest, the far births stay apart from the tight
    # updated terms: test_gm_reduce covers the two metrics).
    q = np.array([1.0, 2.0])
    z = q + offset * np.array([np.cos(0.3), np.sin(0.3)])
    est = ShirsatEstimator(paper_setup(merge_metric="candidate"), robot_id=0)
    est.predict()
    est.update(Scan(0, 0, q, z[None]))
    m = RingBirth(0.48).components(q, 2).means
    lik = 0.8 * 0.1 * _gauss(z, m, 0.75)
    share = lik / (kappa + lik.sum())
    w = np.concatenate([np.full(4, 0.02), share])
    means = np.concatenate([m, m + (2.0 / 3.0) * (z - m)])
    covs = np.concatenate([np.broadcast_to(0.5 * np.eye(2), (4, 2, 2)),
                           np.broadcast_to(np.eye(2) / 6.0, (4, 2, 2))])
    mean = (w[:, None] * means).sum(axis=0) / w.sum()
    d = means - mean
    cov = (w[:, None, None] * (covs + d[:, :, None] * d[:, None, :])).sum(axis=0) / w.sum()
    mix = est.mixture
    assert len(mix) == 1
    assert mix.weights[0] == pytest.approx(w.sum(), rel=1e-12)
    np.testing.assert_allclose(mix.means[0], mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mix.covs[0], cov, rtol=1e-10, atol=1e-14)
    # Weight ~1 (0.08 + the measurement's share): one target, about 0.2 m from z towards
    # the robot (the births pull it in), and in the reward set.
    np.testing.assert_array_equal(est.estimates(), mix.means)
    np.testing.assert_array_equal(est.reward_set(), mix.means)
    assert np.hypot(*(est.estimates()[0] - z)) < 0.25
    if kappa == 0.0:
        assert share.sum() == pytest.approx(1.0, rel=1e-12)


# ---------------------------------------------------------------------------- a run
def _sit_then_leave(seed, sit=30, away=8, **options):
    """One robot on a node 0.27 m from a target for ``sit`` steps, then 3 m away."""
    rng = np.random.default_rng(seed)
    target = np.array([[1.25, 1.1]])
    est = ShirsatEstimator(paper_setup(**options), robot_id=0)
    steps = []
    for k in range(sit + away):
        q = np.array([1.0, 1.0]) if k < sit else np.array([4.0, 3.0])
        est.predict()
        est.update(Scan(0, k, q, simulate_scan(rng, MODELS, q, target)))
        near = np.hypot(*(est.mixture.means - target[0]).T) < 1.0
        steps.append((est.estimates(), est.reward_set(), near.any()))
    return target[0], steps


SEEDS = range(8)


@pytest.mark.parametrize("seed", SEEDS)
def test_a_seen_target_enters_the_estimates_and_the_reward_set_which_keeps_it(seed):
    target, steps = _sit_then_leave(seed)
    sitting, away = steps[:30], steps[30:]

    def seen(x):
        return len(x) and np.hypot(*(x - target).T).min() < 1.0

    # Detected at p_D = 0.8: in X^_k at most steps.
    assert sum(bool(seen(x)) for x, _, _ in sitting) >= 18
    # M_k = M_{k-1} U X^_k: it only grows, the old points first and unchanged.
    for (_, before, _), (_, after, _) in zip(sitting[:-1], sitting[1:], strict=True):
        np.testing.assert_array_equal(after[:len(before)], before)
    reward = sitting[-1][1]
    assert 1 <= len(reward) <= 2
    assert np.all(np.hypot(*(reward - target).T) < 1.5)
    # Once out of view (p_D = 0), p_S = 0.1 forgets it: out of X^_k at once (weight ~1 ->
    # 0.1 < 0.5), its component pruned within 3 steps (0.1, 0.01, 0.001 <= T) ...
    assert not any(seen(x) for x, _, _ in away)
    assert not any(near for _, _, near in away[3:])
    # ... while the reward set keeps it, unchanged (a clutter point seen away may add a
    # false target after it: seed 6, one target's worth of weight from one measurement).
    for _, m, _ in away:
        np.testing.assert_array_equal(m[:len(reward)], reward)


def test_the_reward_set_rarely_counts_a_target_twice():
    # The default duplicate distance (1.5 m, 3 measurement sds) against X^_k's scatter:
    # over 8 runs of 30 sightings, at most two extra points (the module docstring's
    # measurements: 0.06 per target on average for a moving robot; here 1 of 8).
    extra = [len(_sit_then_leave(seed, away=0)[1][-1][1]) - 1 for seed in SEEDS]
    assert min(extra) == 0 and sum(extra) <= 2
    # The paper's exact union (distance 0) counts it at every detection instead.
    exact = _sit_then_leave(0, away=0, duplicate_distance=0.0)[1]
    assert len(exact[-1][1]) >= 18


def test_with_survival_one_the_filter_would_remember_what_p_s_makes_it_forget():
    # The contrast that shows p_S is applied to every component: p_S = 1 keeps the target.
    target, steps = _sit_then_leave(0, survival_probability=1.0)
    assert all(near for _, _, near in steps[30:])


def test_merge_rewards_makes_the_sets_of_robots_that_meet_equal():
    rng = np.random.default_rng(4)
    targets = np.array([[1.2, 1.0], [3.0, 3.2]])
    robots = {0: np.array([1.0, 1.0]), 1: np.array([3.0, 3.0])}
    est = {rid: ShirsatEstimator(paper_setup(), rid) for rid in robots}
    for k in range(15):
        for rid, q in robots.items():
            est[rid].predict()
            est[rid].update(Scan(rid, k, q, simulate_scan(rng, MODELS, q, targets)))
    m0, m1 = est[0].reward_set(), est[1].reward_set()
    assert len(m0) == 1 and len(m1) == 1 and np.hypot(*(m0[0] - m1[0])) > 1.5
    est[0].merge_rewards({1: m1})
    est[1].merge_rewards({0: m0})
    np.testing.assert_array_equal(est[0].reward_set(), est[1].reward_set())
    np.testing.assert_array_equal(est[0].reward_set(), np.concatenate([m0, m1]))
    assert est[0].met.tolist() == [1] and est[1].met.tolist() == [0]
    est[0].predict()
    est[0].update(Scan(0, 15, robots[0], np.empty((0, 2))))
    assert est[0].met.tolist() == [], "a step without a meeting met nobody"


def _with_reward(rid, points):
    """An estimator of robot ``rid`` whose reward set is ``points`` (merged from robot 99)."""
    est = ShirsatEstimator(paper_setup(), rid)
    est.merge_rewards({99: points})
    np.testing.assert_array_equal(est.reward_set(), points)
    return est


def test_a_meeting_of_three_ends_with_one_set_whatever_the_message_order():
    # Robots 2 and 5 saw target A 0.3 m apart (one target at 1.5 m): every robot keeps
    # robot 2's point, the lower id's, whatever order the sets came in.
    sets = {5: np.array([[1.3, 1.0], [4.0, 4.0]]), 2: np.array([[1.0, 1.0]]),
            7: np.array([[8.0, 1.0], [1.1, 1.1]])}
    est = {rid: _with_reward(rid, pts) for rid, pts in sets.items()}
    for rid, e in est.items():
        others = [(o, sets[o]) for o in sets if o != rid]
        e.merge_rewards(dict(others[::-1] if rid == 5 else others))
    expected = np.array([[1.0, 1.0], [4.0, 4.0], [8.0, 1.0]])
    for e in est.values():
        np.testing.assert_array_equal(e.reward_set(), expected)


def test_merge_rewards_refuses_its_own_id_and_malformed_sets_leaving_the_set():
    est = _with_reward(0, np.array([[1.0, 1.0]]))
    with pytest.raises(ValueError, match="own id"):
        est.merge_rewards({0: np.array([[2.0, 2.0]])})
    with pytest.raises(ValueError, match="reward set of robot 3"):
        est.merge_rewards({1: np.array([[5.0, 5.0]]), 3: np.array([[np.nan, 0.0]])})
    np.testing.assert_array_equal(est.reward_set(), [[1.0, 1.0]])
    est.merge_rewards({})
    np.testing.assert_array_equal(est.reward_set(), [[1.0, 1.0]])


def test_reward_set_and_estimates_are_copies():
    est = _with_reward(0, np.array([[1.0, 1.0]]))
    est.reward_set()[0, 0] = 9.0
    est.estimates().resize(0)
    np.testing.assert_array_equal(est.reward_set(), [[1.0, 1.0]])


def test_export_and_import_the_mixture():
    est = ShirsatEstimator(paper_setup(), 0)
    mix = GaussianMixture(np.array([0.7, 0.2]), np.array([[1.0, 2.0], [3.0, 4.0]]),
                          np.array([np.eye(2), 2.0 * np.eye(2)]))
    est.import_state(mix.to_arrays())
    out = est.export_state()
    for key in ("weights", "means", "covs"):
        np.testing.assert_array_equal(out[key], getattr(mix, key))
    assert est.expected_count() == pytest.approx(0.9)
    with pytest.raises(ValueError, match="link: state dimension 4"):
        est.import_state(GaussianMixture.empty(4).to_arrays(), "link")


# ---------------------------------------------------------------------------- the part
def _scenario(**options):
    return scenario_from_dict({
        "preset": "dames_static", "robots": 2, "duration": 2.0, "seed": 5,
        "env": {"xmin": 0.0, "ymin": 0.0, "xmax": 5.0, "ymax": 5.0},
        "robot_start_box": [0.0, 0.0, 5.0, 5.0], "targets": {"count": 3,
                                                             "draw_box": [0.0, 0.0, 5.0, 5.0]},
        "models": {"detection": {"p_d": 0.8, "radius": 0.6},
                   "measurement": {"variance": 0.25}, "clutter": {"density": 3.98e-3}},
        "system": {"sensor": "disk", "estimator": "shirsat_gmphd", "exchange": "none",
                   "controller": "lawnmower", "options": options}})


def test_the_part_reads_the_scenarios_models_and_the_options():
    sc = _scenario()
    part = registry.lookup("estimator", "shirsat_gmphd")
    assert {"gaussian_mixture", "reward_set"} <= part.provides
    assert part.requires == {"disk_fov"}
    setup = part.setup(sc, sc.system)
    model = setup.model
    np.testing.assert_array_equal(model.F, np.eye(2))
    np.testing.assert_allclose(model.Q, 0.2 * np.eye(2))
    np.testing.assert_allclose(model.R, 0.25 * np.eye(2))
    assert (model.p_s, model.clutter_intensity, model.prune_threshold, model.merge_threshold,
            model.max_components, model.extraction_threshold) == (0.1, 3.98e-3, 1e-3, 4.0,
                                                                  100, 0.5)
    assert len(model.birth_weights) == 0 and len(model.spawn_weights) == 0
    assert (setup.fov.radius, setup.fov.p_inside, setup.fov.integrate) == (0.6, 0.8, False)
    assert setup.birth.radius == pytest.approx(0.48)
    assert (setup.birth.weight, setup.birth.variance) == (0.1, 0.5)
    assert setup.clutter_in_fov_only and setup.duplicate_distance == 1.5
    est = part.make(setup, 3)
    assert isinstance(est, ShirsatEstimator) and est.robot_id == 3
    other = part.setup(*(lambda s: (s, s.system))(_scenario(
        p_d_evaluation="integrated", clutter_region="everywhere", duplicate_distance=0.4,
        survival_probability=0.9)))
    assert other.fov.integrate and not other.clutter_in_fov_only
    assert (other.duplicate_distance, other.model.p_s) == (0.4, 0.9)
    z = np.array([[0.1, 0.0], [2.0, 0.0]])
    np.testing.assert_array_equal(setup.clutter(z, np.zeros(2)), [3.98e-3, 0.0])
    np.testing.assert_array_equal(other.clutter(z, np.zeros(2)), [3.98e-3, 3.98e-3])


def test_a_team_runs_through_the_engine_with_the_figures_hook():
    engine = DistributedEngine(_scenario())
    for _ in range(3):
        _, truth = engine.world.truth()
        engine.step()
    f = engine.figures(truth)
    assert tuple(f) == FIGURES
    ests = [engine.agents[rid].estimator for rid in engine.live_ids()]
    assert f == step_figures(ests, truth, engine.scenario.ospa_c, engine.scenario.ospa_p)


@pytest.mark.parametrize("p_d_evaluation", ["mean", "integrated"])
def test_a_team_step_equals_each_robot_stepping_alone_bit_for_bit(p_d_evaluation):
    """step_team (the engine's) against predict + update robot by robot (a ROS node's)."""
    setup = paper_setup(p_d_evaluation=p_d_evaluation)
    rng = np.random.default_rng(11)
    targets = rng.uniform(0.0, 3.0, (6, 2))
    team = [ShirsatEstimator(setup, rid) for rid in range(5)]
    alone = [ShirsatEstimator(setup, rid) for rid in range(5)]
    positions = rng.uniform(0.0, 3.0, (5, 2))
    measured = 0
    for k in range(40):
        positions = np.clip(positions + rng.normal(0.0, 0.3, positions.shape), 0.0, 3.0)
        scans = [Scan(rid, k, positions[rid], simulate_scan(rng, MODELS, positions[rid],
                                                            targets)) for rid in range(5)]
        measured += sum(len(s.z) > 0 for s in scans)
        step_team(team, scans)
        for est, scan in zip(alone, scans, strict=True):
            est.predict()
            est.update(scan)
        for a, b in zip(team, alone, strict=True):
            for x, y in ((a.mixture.weights, b.mixture.weights),
                         (a.mixture.means, b.mixture.means), (a.mixture.covs, b.mixture.covs),
                         (a.estimates(), b.estimates()), (a.reward_set(), b.reward_set())):
                assert np.array_equal(x, y)
            assert a.step == b.step == k
    assert measured > 20 and sum(len(e.reward_set()) for e in team) > 0


def test_the_engine_gives_the_same_run_with_and_without_the_team_step(monkeypatch):
    """The small scenario (3 robots walking and meeting), 120 steps."""
    scenario = load_run_config(ROOT / "config" / "shirsat_small.yaml").scenario
    scenario = scenario.with_overrides(duration=120 * scenario.dt, seed=4)

    def run():
        engine = DistributedEngine(scenario)
        met = 0
        for _ in range(scenario.steps):
            engine.step()
            met += sum(engine.agents[r].estimator.met.size > 0 for r in engine.agents)
        return met, [np.concatenate([e.mixture.weights, e.mixture.means.ravel(),
                                     e.mixture.covs.ravel(), e.reward_set().ravel()])
                     for e in (engine.agents[r].estimator for r in sorted(engine.agents))]

    met, with_team = run()
    part = registry.lookup("estimator", "shirsat_gmphd")
    assert part.team_step is step_team
    monkeypatch.setitem(registry._PARTS["estimator"], "shirsat_gmphd",
                        dataclasses.replace(part, team_step=None))
    met_alone, without = run()
    assert met == met_alone > 0
    assert all(np.array_equal(a, b) for a, b in zip(with_team, without, strict=True))


def test_a_team_step_needs_one_setup_and_a_scan_per_robot():
    a, b = ShirsatEstimator(paper_setup(), 0), ShirsatEstimator(paper_setup(), 1)
    with pytest.raises(ValueError, match="share one setup"):
        step_team([a, b], [Scan(0, 0, np.zeros(2), np.empty((0, 2)))] * 2)
    with pytest.raises(ValueError, match="1 scans for 2 robots"):
        update_team([a, ShirsatEstimator(a.setup, 1)], [Scan(0, 0, np.zeros(2),
                                                             np.empty((0, 2)))])


# ---------------------------------------------------------------------------- figures
class _View:
    """What the hook may read: reward_set(), met and mixture.weights, nothing else."""

    def __init__(self, reward, n_components, met=()):
        self._reward = np.asarray(reward, dtype=float).reshape(-1, 2)
        self.mixture = type("M", (), {"weights": np.full(n_components, 0.3)})()
        self.met = np.asarray(met, dtype=np.int64)

    def reward_set(self):
        return self._reward


def test_figures_of_hand_made_estimators():
    truth = np.array([[0.0, 0.0], [3.0, 0.0]])
    views = [_View([[0.0, 0.0], [3.0, 0.0]], 4, met=[2]), _View([[0.0, 0.0]], 2),
             _View([[0.0, 1.0], [3.0, 0.0], [9.0, 9.0]], 6, met=[0])]
    f = step_figures(views, truth, 10.0, 1.0)
    assert tuple(f) == FIGURES
    assert f["robots_meeting"] == 2.0
    # OSPA(p = 1, c = 10): 0; (0 + 10) / 2 = 5; (1 + 0 + 10) / 3.
    assert f["reward_ospa_mean"] == pytest.approx((0.0 + 5.0 + 11.0 / 3.0) / 3.0)
    assert f["reward_ospa_mean"] == pytest.approx(np.mean([ospa(truth, v.reward_set(), 10.0,
                                                                1.0) for v in views]))
    assert (f["reward_min"], f["reward_mean"], f["reward_max"]) == (1.0, 2.0, 3.0)
    assert f["all_found"] == 0.0 and f["components_mean"] == 4.0
    # Every cardinality right (positions need not be: the paper's criterion).
    found = step_figures([views[0], _View([[5.0, 5.0], [6.0, 6.0]], 0)], truth, 10.0, 1.0)
    assert found["all_found"] == 1.0 and found["components_mean"] == 2.0
    assert found["reward_ospa_mean"] == pytest.approx(0.5 * (0.0 + 0.5 * (np.hypot(5, 5)
                                                                          + np.hypot(3, 6))))


def test_figures_without_robots_or_targets():
    none = step_figures([], np.zeros((2, 2)), 10.0, 1.0)
    assert none["all_found"] == 0.0
    assert none["robots_meeting"] == 0.0
    assert all(np.isnan(v) for k, v in none.items() if k not in ("all_found",
                                                                 "robots_meeting"))
    empty = step_figures([_View([], 0)], np.empty((0, 2)), 10.0, 2.0)
    assert empty["all_found"] == 1.0 and empty["reward_ospa_mean"] == 0.0


@pytest.mark.parametrize("metric, near", [("heaviest", 2), ("candidate", 1)])
def test_the_merge_metric_option_reaches_the_model_and_the_team_step(metric, near):
    sc = _scenario(merge_metric=metric)
    part = registry.lookup("estimator", "shirsat_gmphd")
    assert part.setup(sc, sc.system).model.merge_metric == metric
    default = _scenario()
    assert part.setup(default, default.system).model.merge_metric == "heaviest"
    assert paper_setup().model.merge_metric == "heaviest"
    with pytest.raises(ValueError, match="system.options.merge_metric"):
        _scenario(merge_metric="own")
    # A tight heavy component and a wide one 0.5 m from it, far from the robot (p_D = 0
    # there): squared distance 0.25 / 1 <= U = 4 in the wide one's metric, 0.25 / 0.04 =
    # 6.25 > 4 in the tight one's.
    est = ShirsatEstimator(paper_setup(merge_metric=metric), 0)
    est.import_state({"weights": np.array([0.9, 0.3]),
                      "means": np.array([[10.0, 10.0], [10.5, 10.0]]),
                      "covs": np.array([0.04 * np.eye(2), np.eye(2)])})
    est.update(Scan(0, 0, np.zeros(2), np.empty((0, 2))))
    assert np.count_nonzero(np.hypot(*(est.mixture.means - 10.0).T) < 1.0) == near
