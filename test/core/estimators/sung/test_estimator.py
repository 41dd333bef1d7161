"""Sung & Tokekar's estimator: the prior, eq. 11 through the engine, targets and tracks."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core import registry
from phd_swarm.core.estimators.gm_phd.filter import GaussianMixture
from phd_swarm.core.estimators.sung.estimator import SungEstimator, initial_belief
from phd_swarm.core.estimators.sung.figures import mahalanobis_to_tracks, step_figures
from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.scan import Scan
from phd_swarm.core.sensors.fov_detection import DiskFov
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.sim.presets import sung_tokekar

ENV = Environment(0.0, 0.0, 150.0, 150.0)
TRUTH = np.array([[10.0 * i + 5.0, 7.0 * i + 20.0] for i in range(10)])


@pytest.mark.parametrize("kind, count", [("exact", 10), ("under", 5), ("over", 15),
                                         ("none", 0)])
def test_initial_belief_sizes_offsets_and_covariances(kind, count):
    mix = initial_belief(kind, TRUTH, 15.0, "fixed", 50.0, ENV, np.random.default_rng(0))
    assert len(mix) == count
    if not count:
        return
    assert np.all(mix.weights == 1.0)
    assert np.allclose(mix.covs, 50.0 * np.eye(2))
    near = mix.means[:min(count, 10 if kind != "under" else 5)]
    d = np.hypot(*(near[:, None, :] - TRUTH[None, :, :]).transpose(2, 0, 1))
    # Each of the first components is exactly 15 m from a distinct true target.
    assert np.allclose(np.sort(np.abs(d - 15.0).min(axis=1)), 0.0, atol=1e-9)
    assert len(set(np.argmin(np.abs(d - 15.0), axis=1).tolist())) == len(near)
    if kind == "over":
        extra = mix.means[10:]
        assert np.all(ENV.contains(extra))


def test_rayleigh_offsets_have_the_given_mean_length():
    truth = np.zeros((20000, 2))
    mix = initial_belief("exact", truth, 15.0, "rayleigh", 50.0, ENV,
                         np.random.default_rng(1))
    lengths = np.hypot(mix.means[:, 0], mix.means[:, 1])
    assert abs(lengths.mean() - 15.0) < 0.2 and lengths.std() > 5.0


def _engine(**options) -> DistributedEngine:
    sc = sung_tokekar().with_system(options={"false_positive_prob": 0.0, **options})
    return DistributedEngine(sc.with_overrides(seed=3))


def test_the_limited_fov_rule_moves_exactly_the_edge_components_through_the_engine():
    # No targets, no false positives: every step is a no-detection event. Components far
    # apart (no merging) around the robot at various distances from the 25 m FoV's edge.
    engine = DistributedEngine(sung_tokekar(targets=0).with_system(
        options={"false_positive_prob": 0.0}).with_overrides(seed=1))
    agent = engine.agents[0]
    robot = engine.world.robot_positions[0]
    angles = np.array([0.2, 0.5, 0.8, 1.1, 1.4])
    radii = np.array([15.0, 24.8, 25.1, 30.0, 45.0])
    means = robot + radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    covs = np.broadcast_to(np.eye(2), (5, 2, 2)).copy()
    weights = np.linspace(1.0, 2.0, 5)
    agent.estimator.import_state(GaussianMixture(weights, means, covs).to_arrays())
    engine.step()
    # What eq. 9-11 give for the predicted components (covariance + Q) at the robot.
    predicted = covs + 0.1 ** 2 * np.eye(2)
    p_d = DiskFov(25.0, 0.98)(means, predicted, robot)
    edge = (p_d >= 0.4) & (p_d <= 0.6)
    assert edge.tolist() == [False, True, True, False, False]
    expected = means.copy()
    expected[edge] += p_d[edge, None] * (means[edge] - robot)
    keep = (1.0 - p_d) * weights > 0.001
    mix = agent.estimator.mixture
    order = np.argsort(-((1.0 - p_d) * weights)[keep], kind="stable")
    np.testing.assert_allclose(mix.means, expected[keep][order], rtol=0, atol=1e-9)
    np.testing.assert_allclose(mix.weights, ((1.0 - p_d) * weights)[keep][order], rtol=1e-12)
    # Pushed away from the robot, by p_D times the distance.
    moved = np.hypot(*(expected[edge] - robot).T) / np.hypot(*(means[edge] - robot).T)
    np.testing.assert_allclose(moved, 1.0 + p_d[edge])


def test_without_the_rule_no_component_moves():
    engine = DistributedEngine(sung_tokekar(targets=0).with_system(
        options={"false_positive_prob": 0.0, "fov_rule": False}).with_overrides(seed=1))
    robot = engine.world.robot_positions[0]
    means = robot + np.array([[24.0, 3.0], [60.0, 0.0]])
    engine.agents[0].estimator.import_state(GaussianMixture(
        np.ones(2), means, np.broadcast_to(4.0 * np.eye(2), (2, 2, 2))).to_arrays())
    engine.step()
    assert {tuple(m) for m in engine.agents[0].estimator.mixture.means.round(9)} == \
        {tuple(m) for m in means.round(9)}


def test_runs_are_reproducible_and_find_tracks():
    a, b = _engine(), _engine()
    a.run(600)
    b.run(600)
    ea, eb = a.agents[0].estimator, b.agents[0].estimator
    for x, y in zip(ea.mixture.to_arrays().values(), eb.mixture.to_arrays().values(),
                    strict=True):
        assert np.array_equal(x, y)
    assert len(ea.tracks.confirmed()) > 0
    assert np.array_equal(ea.targets()[3], eb.targets()[3])


def _one_target_estimator(**options) -> tuple[SungEstimator, np.ndarray]:
    sc = sung_tokekar(targets=1).with_system(options={"false_positive_prob": 0.0,
                                                      "initial_belief": "none", **options})
    engine = DistributedEngine(sc.with_overrides(seed=2))
    return engine.agents[0].estimator, engine.world.truth()[1][0]


def test_newborns_merge_in_the_same_step_or_wait_for_the_next():
    same, x = _one_target_estimator()
    later, _ = _one_target_estimator(newborn_merge="next_step")
    sensor = x + np.array([3.0, 0.0])
    for k in range(3):
        z = x + np.array([[0.2, -0.1]]) * (k + 1)
        for est in (same, later):
            est.predict()
            est.update(Scan(0, k, sensor, z))
    assert len(same.mixture) == 1 and len(same.estimates()) == 1
    # Next-step merging: the known target's component and this scan's newborn, two targets.
    assert len(later.mixture) == 2 and len(later.estimates()) == 2
    assert same.mixture.weights[0] > 1.5


def test_rounded_extraction_repeats_heavy_components():
    est, x = _one_target_estimator(extraction="rounded")
    heavy = GaussianMixture(np.array([2.6]), x[None, :], np.eye(2)[None])
    est.gmphd.mixture = heavy
    est.predict()
    est.update(Scan(0, 0, x + 100.0, np.empty((0, 2))))   # far: nothing changes
    assert len(est.estimates()) == 3
    per, _ = _one_target_estimator()
    per.gmphd.mixture = heavy
    per.predict()
    per.update(Scan(0, 0, x + 100.0, np.empty((0, 2))))
    assert len(per.estimates()) == 1


def test_gp_prediction_moves_confirmed_components_along_their_track():
    est, x = _one_target_estimator(gp_prediction=True, gp_signal_sd=10.0,
                                   gp_length_scale=20.0, gp_noise_sd=0.05, gp_window=10)
    sensor = x + np.array([3.0, 0.0])
    velocity = np.array([0.5, 0.25])
    for k in range(8):
        est.predict()
        est.update(Scan(0, k, sensor, (x + k * velocity)[None, :]))
    assert est.confirmed_mask().all()
    before = est.mixture.means[0].copy()
    est.predict()
    # The GP extrapolates the track forward; the linear model (F = I) would not move it.
    step = est.mixture.means[0] - before
    assert np.dot(step, velocity) > 0.5 * np.dot(velocity, velocity)


def test_mahalanobis_distances_to_tracks():
    truth = np.array([[0.0, 0.0], [10.0, 0.0]])
    means = np.array([[1.0, 0.0], [10.0, 2.0], [30.0, 0.0]])
    covs = np.array([np.eye(2), 4.0 * np.eye(2), np.eye(2)])
    d = mahalanobis_to_tracks(truth, means, covs)
    assert d[0, 0] == pytest.approx(1.0)
    assert d[1, 0] == pytest.approx(1.0)          # 2 m in sd 2
    assert d[0, 1] == pytest.approx(np.sqrt(104.0 / 4.0))   # (10, 2) with variance 4
    assert np.all(np.diff(d, axis=1) >= 0)


def test_step_figures_of_a_run():
    engine = _engine()
    for _ in range(300):
        _, truth = engine.world.truth()
        engine.step()
    f = engine.figures(truth)
    est = engine.agents[0].estimator
    assert f["components"] == len(est.mixture)
    assert f["weights_components"] == pytest.approx(est.mixture.weights.sum())
    assert f["tracks"] == len(set(est.targets()[3][est.confirmed_mask()].tolist()))
    assert 0 <= f["weights_tracks"] <= f["weights_components"] + 1e-9
    assert 0 <= f["ospa_tracks"] <= 100.0
    # The paper's figures are its one robot's: a team of two has none, and is not stopped.
    assert step_figures([est, est], truth, 100.0, 2.0) == {}


@pytest.mark.parametrize("options, metric", [({}, "heaviest"),
                                             ({"merge_metric": "candidate"}, "candidate"),
                                             ({"merge_metric": "heaviest"}, "heaviest")])
def test_the_merge_metric_option_reaches_the_model(options, metric):
    sc = sung_tokekar().with_system(options=options)
    setup = registry.lookup("estimator", "sung_gmphd").setup(sc, sc.system)
    assert setup.model.merge_metric == metric
    with pytest.raises(ValueError, match="system.options.merge_metric"):
        sung_tokekar().with_system(options={"merge_metric": "own"})


def test_the_gp_input_defaults_to_estimates_and_enters_the_hash_only_when_changed():
    from phd_swarm.config.sweep_hash import config_hash

    sc = sung_tokekar().with_system(options={"gp_prediction": True})
    setup = registry.lookup("estimator", "sung_gmphd").setup(sc, sc.system)
    assert setup.gp_input == "estimates"
    est = SungEstimator(setup)
    assert est.detections is None and not est.gmphd.record_shares
    # The committed rows were made before the option: at its default the hash is theirs.
    explicit = sc.with_system(options={"gp_input": "estimates"})
    detections = sc.with_system(options={"gp_input": "detections"})
    args = ("lawnmower", "mean", (0.0, 100.0), "distributed")
    assert config_hash(explicit, *args) == config_hash(sc, *args)
    assert config_hash(detections, *args) != config_hash(sc, *args)
    with pytest.raises(ValueError, match="system.options.gp_input"):
        sc.with_system(options={"gp_input": "measurements"})


def test_fed_by_detections_runs_are_reproducible():
    a = _engine(gp_prediction=True, gp_input="detections")
    b = _engine(gp_prediction=True, gp_input="detections")
    a.run(300)
    b.run(300)
    ea, eb = a.agents[0].estimator, b.agents[0].estimator
    for x, y in zip(ea.mixture.to_arrays().values(), eb.mixture.to_arrays().values(),
                    strict=True):
        assert np.array_equal(x, y)
    assert np.array_equal(ea.targets()[3], eb.targets()[3])
    assert any(ea.detections.count(t.track_id) >= 3 for t in ea.tracks.confirmed())
