"""Shirsat & Berman's labelled reading: labels through the GM-PHD, the union by label."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from phd_swarm.config import load_run_config
from phd_swarm.core import registry
from phd_swarm.core.agent import Team
from phd_swarm.core.estimators.gm_phd.filter import GaussianMixture
from phd_swarm.core.estimators.gm_phd.team import PaddedMixtures, prune_and_merge_rows
from phd_swarm.core.estimators.shirsat.estimator import ShirsatEstimator, paper_setup, step_team
from phd_swarm.core.estimators.shirsat.figures import step_figures, true_members
from phd_swarm.core.scan import Scan
from phd_swarm.core.sensors.disk_labelled import tags
from phd_swarm.engines.distributed import DistributedEngine

ROOT = Path(__file__).resolve().parents[4]

#: A wide FoV (3 m, births on a ring of 2.4 m) and little clutter: a measurement on a birth's
#: mean, at (+-B, +-B) from the robot, gives one component of weight ~0.99 (extracted), and
#: two such measurements on opposite births two components that do not merge.
WIDE = {"radius": 3.0, "clutter": 1e-4}
B = 2.4 / np.sqrt(2.0)


def _pair(**options):
    """The same robot under the union by label and by position."""
    return (ShirsatEstimator(paper_setup(**WIDE, reward_union="label", **options), 0),
            ShirsatEstimator(paper_setup(**WIDE, **options), 0))


def _step(est, k, z, labels=None, sensor=(0.0, 0.0)):
    est.predict()
    est.update(Scan(0, k, np.asarray(sensor), np.asarray(z, dtype=float).reshape(-1, 2),
                    labels))


def test_an_estimate_takes_its_measurements_label_and_clutter_stays_out_of_the_reward():
    labelled, plain = _pair()
    z = [[B, B], [-B, -B]]                             # target 4 (tag 5), then a clutter point
    _step(labelled, 0, z, np.array([5, 0]))
    _step(plain, 0, z)
    # The filter is the same: labels are bookkeeping beside the mixture.
    for a, b in ((labelled.mixture.weights, plain.mixture.weights),
                 (labelled.mixture.means, plain.mixture.means),
                 (labelled.estimates(), plain.estimates())):
        np.testing.assert_array_equal(a, b)
    est = labelled.estimates()
    assert len(est) == 2
    tagged = labelled.estimate_labels()
    assert sorted(tagged.tolist()) == [0, 5]
    np.testing.assert_array_equal(labelled.reward_set(), est[tagged == 5])
    np.testing.assert_array_equal(labelled.reward_labels(), [5])
    # By position both estimates are members; no labels are kept.
    assert len(plain.reward_set()) == 2
    np.testing.assert_array_equal(plain.reward_labels(), [0, 0])
    np.testing.assert_array_equal(plain.estimate_labels(), [0, 0])


def test_the_same_label_seen_again_elsewhere_is_the_same_member():
    labelled, plain = _pair()
    _step(labelled, 0, [[B, B]], np.array([5]))
    first = labelled.reward_set()
    assert len(first) == 1
    _step(plain, 0, [[B, B]])
    # Seen again 4.8 m away (beyond the 1.5 m duplicate distance): by label still one target,
    # the first position kept; by position a second member.
    for k in (1, 2):
        _step(labelled, k, [[-B, -B]], np.array([5]), sensor=(-2 * B, -2 * B))
        _step(plain, k, [[-B, -B]], sensor=(-2 * B, -2 * B))
    np.testing.assert_array_equal(labelled.reward_set(), first)
    np.testing.assert_array_equal(labelled.reward_labels(), [5])
    assert len(plain.reward_set()) == 2


def test_a_survivor_keeps_its_label_through_missed_detections():
    labelled, _ = _pair(survival_probability=1.0, process_noise_var=0.0)
    _step(labelled, 0, [[B, B]], np.array([9]))
    # The robot walks away: p_D = 0 at the component, which survives with its label.
    for k in range(1, 4):
        _step(labelled, k, np.empty((0, 2)), sensor=(20.0, 0.0))
        np.testing.assert_array_equal(labelled.estimate_labels(), [9])
    # Back, it measures a clutter point on it: the updated term (weight ~0.8) takes the
    # measurement's label, 0, and outweighs the missed-detection term (~0.2, label 9) it
    # merges with. The reward keeps its member.
    _step(labelled, 4, [[B, B]], np.array([0]))
    np.testing.assert_array_equal(labelled.estimate_labels(), [0])
    np.testing.assert_array_equal(labelled.reward_labels(), [9])


def test_a_merged_component_takes_the_label_of_its_heaviest_member():
    rows = PaddedMixtures.from_mixtures([
        GaussianMixture(np.array([0.2, 0.9, 0.3]), np.array([[0.0, 0.0], [0.1, 0.0],
                                                             [5.0, 5.0]]),
                        np.broadcast_to(np.eye(2), (3, 2, 2))),
        GaussianMixture(np.array([0.6]), np.array([[1.0, 1.0]]), np.eye(2)[None])])
    plain = prune_and_merge_rows(rows, 1e-3, 4.0, 100)
    merged, leads = prune_and_merge_rows(rows, 1e-3, 4.0, 100, with_leads=True)
    for a, b in zip(plain, merged, strict=True):
        np.testing.assert_array_equal(a.weights, b.weights)
    # Row 0: components 0 and 1 merge (weight 1.1) into the heaviest, slot 1; slot 2 alone.
    np.testing.assert_allclose(merged[0].weights, [1.1, 0.3])
    np.testing.assert_array_equal(leads[0], [1, 2])
    np.testing.assert_array_equal(leads[1], [0])
    empty, none = prune_and_merge_rows(PaddedMixtures.empty(2, 3), 1e-3, 4.0, 100,
                                       with_leads=True)
    assert [len(m) for m in empty] == [0, 0] and [len(x) for x in none] == [0, 0]


def test_the_labelled_reading_refuses_what_it_cannot_read():
    labelled, _ = _pair()
    with pytest.raises(ValueError, match="without labels.*reward_union: label"):
        _step(labelled, 0, [[B, B]])
    other = ShirsatEstimator(labelled.setup, 1)
    with pytest.raises(ValueError, match="robot 1 came without labels"):
        labelled.merge_rewards({1: other.reward_set()})
    with pytest.raises(ValueError, match="reward set of robot 1: labels must be 1 integers"):
        labelled.merge_rewards({1: [[1.0, 1.0]]}, {1: np.array([-3])})
    labelled.merge_rewards({1: [[1.0, 1.0], [2.0, 2.0]]}, {1: np.array([4, 0])})
    np.testing.assert_array_equal(labelled.reward_labels(), [4])


def test_robots_that_meet_end_with_one_set_by_label():
    setup = paper_setup(**WIDE, reward_union="label")
    a, b = ShirsatEstimator(setup, 0), ShirsatEstimator(setup, 1)
    step_team([a, b], [Scan(0, 0, np.zeros(2), [[B, B]], [3]),
                       Scan(1, 0, np.zeros(2), [[B, B + 0.1], [-B, -B]], [3, 8])])
    sets = {e.robot_id: (e.reward_set(), e.reward_labels()) for e in (a, b)}
    a.merge_rewards({1: sets[1][0]}, {1: sets[1][1]})
    b.merge_rewards({0: sets[0][0]}, {0: sets[0][1]})
    for e in (a, b):
        np.testing.assert_array_equal(e.reward_labels(), [3, 8])
    np.testing.assert_array_equal(a.reward_set(), b.reward_set())
    np.testing.assert_array_equal(a.reward_set()[0], sets[0][0][0])   # robot 0's own first


def test_true_members_by_label_and_by_position():
    truth = np.array([[0.0, 0.0], [3.0, 0.0]])
    ids = np.array([0, 6])
    # By label: tags 1 and 7 are the targets, 4 is none of them (a target gone).
    assert true_members(np.zeros((3, 2)), np.array([1, 7, 4]), truth, ids, 1.5) == 2.0
    assert np.isnan(true_members(np.zeros((1, 2)), np.array([1]), truth, None, 1.5))
    # By position: two members near target 0 count once, one 1.5 m from target 1 (the gate,
    # boundary included) counts, one 1.6 m away does not.
    pts = np.array([[0.1, 0.0], [-0.1, 0.0], [4.5, 0.0], [3.0, 1.6]])
    assert true_members(pts, np.zeros(4, dtype=np.int64), truth, None, 1.5) == 2.0
    assert true_members(pts[[0, 1, 3]], np.zeros(3, dtype=np.int64), truth, None, 1.5) == 1.0
    assert true_members(np.empty((0, 2)), np.empty(0, dtype=np.int64), truth, ids, 1.5) == 0


def _small(**system):
    scenario = load_run_config(ROOT / "config" / "shirsat_small.yaml").scenario
    return scenario.with_overrides(duration=150 * scenario.dt, seed=4).with_system(**system)


LABELLED = {"sensor": "disk_labelled", "options": {"reward_union": "label"}}


def test_a_labelled_team_through_the_engine_holds_true_targets_only():
    runs = {}
    for name, system in (("label", LABELLED), ("position", {})):
        engine = DistributedEngine(_small(**system))
        for _ in range(engine.scenario.steps):
            ids, truth = engine.world.truth()
            engine.step()
        runs[name] = engine, engine.figures(truth, ids), ids, truth
    engine, f, ids, truth = runs["label"]
    members = 0
    for rid in engine.live_ids():
        est = engine.agents[rid].estimator
        lab = est.reward_labels()
        assert len(set(lab.tolist())) == len(lab) and set(lab.tolist()) <= set(tags(ids))
        members += len(lab)
    assert members > 0
    assert f["reward_true_mean"] == f["reward_mean"]
    ests = [engine.agents[r].estimator for r in engine.live_ids()]
    assert f == step_figures(ests, truth, engine.scenario.ospa_c, engine.scenario.ospa_p,
                             ids=ids)
    # The same filter as under the union by position (only the reward sets differ).
    other = runs["position"][0]
    for rid in engine.live_ids():
        a, b = engine.agents[rid].estimator, other.agents[rid].estimator
        np.testing.assert_array_equal(a.mixture.weights, b.mixture.weights)
        np.testing.assert_array_equal(a.estimates(), b.estimates())
    assert runs["position"][1]["reward_true_mean"] <= runs["position"][1]["reward_mean"]


def test_the_labelled_engine_run_is_the_same_with_and_without_the_team_step(monkeypatch):
    def run():
        engine = DistributedEngine(_small(**LABELLED))
        engine.run()
        return [(e.reward_labels(), e.reward_set(), e.mixture.weights)
                for e in (engine.agents[r].estimator for r in sorted(engine.agents))]

    with_team = run()
    part = registry.lookup("estimator", "shirsat_gmphd")
    monkeypatch.setitem(registry._PARTS["estimator"], "shirsat_gmphd",
                        dataclasses.replace(part, team_step=None))
    for a, b in zip(with_team, run(), strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


def test_the_union_by_label_needs_a_sensor_that_identifies_targets():
    with pytest.raises(ValueError, match="reward_union: label needs a sensor that "
                                         "identifies targets.*sensor disk gives no labels"):
        Team.build(_small(options={"reward_union": "label"}))
