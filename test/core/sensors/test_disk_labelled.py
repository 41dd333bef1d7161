"""The labelled disk sensor: the disk sensor's positions, bit for bit, plus each target's tag."""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.core.models import DiskDetection, PhdModels, UniformClutter
from phd_swarm.core.sensors import disk
from phd_swarm.core.sensors.disk_labelled import (
    NO_LABEL,
    simulate_labelled_scan,
    simulate_scan,
    tags,
)
from phd_swarm.sim.presets import dames_moving, shirsat_berman
from phd_swarm.sim.world import World


@pytest.mark.parametrize("seed", range(5))
def test_positions_equal_the_disk_sensors_and_the_stream_is_left_in_the_same_state(seed):
    models = PhdModels(clutter=UniformClutter(density=0.05))
    targets = np.random.default_rng(100 + seed).uniform(-6.0, 6.0, (12, 2))
    a, b = np.random.default_rng(seed), np.random.default_rng(seed)
    z, labels = simulate_labelled_scan(a, models, np.zeros(2), targets, np.arange(12) + 40)
    np.testing.assert_array_equal(z, disk.simulate_scan(b, models, np.zeros(2), targets))
    assert a.random() == b.random()
    assert labels.dtype == np.int64 and labels.shape == (len(z),)
    np.testing.assert_array_equal(simulate_scan(np.random.default_rng(seed), models,
                                                np.zeros(2), targets), z)


def test_a_detection_carries_its_targets_tag_and_clutter_none():
    # p_d 1 and no noise-free shortcut: the two targets inside the 5 m disk are detected, the
    # far one is not; clutter (density 0.2 per m^2, ~16 points) carries NO_LABEL.
    models = PhdModels(detection=DiskDetection(p_d=1.0, radius=5.0),
                       clutter=UniformClutter(density=0.2))
    targets = np.array([[1.0, 1.0], [40.0, 40.0], [-2.0, 0.5]])
    ids = np.array([7, 3, 0])
    z, labels = simulate_labelled_scan(np.random.default_rng(1), models, np.zeros(2),
                                       targets, ids)
    np.testing.assert_array_equal(labels[:2], [8, 1])            # tags = ids + 1
    assert len(z) > 2 and np.all(labels[2:] == NO_LABEL)
    np.testing.assert_array_equal(tags([0, 5]), [1, 6])


def test_ids_must_match_the_targets():
    with pytest.raises(ValueError, match="2 ids for 3 targets"):
        simulate_labelled_scan(np.random.default_rng(0), PhdModels(), np.zeros(2),
                               np.zeros((3, 2)), np.arange(2))


def test_the_world_hands_the_ids_to_a_labelled_sensor_and_keeps_the_labels():
    plain = shirsat_berman().with_overrides(seed=4)
    labelled = plain.with_system(sensor="disk_labelled")
    a, b = World(plain), World(labelled)
    seen = 0
    for _ in range(60):
        za, zb = a.scans(), b.scans()
        assert a.scan_labels == {}
        assert za.keys() == zb.keys() == b.scan_labels.keys()
        ids, _ = b.truth()
        for r in zb:
            np.testing.assert_array_equal(za[r], zb[r])
            lab = b.scan_labels[r]
            assert lab.shape == (len(zb[r]),)
            assert set(lab[lab > 0].tolist()) <= set(tags(ids).tolist())
            seen += int(np.sum(lab > 0))
        for w in (a, b):
            w.apply_goals({r: w.robot_positions[r] + 0.5 for r in w.robot_ids})
            w.advance()
    assert seen > 0


def test_a_dead_robot_gets_no_scan_and_no_labels():
    world = World(dames_moving(robots=3, targets=20).with_system(sensor="disk_labelled"))
    world.kill(1)
    world.scans()
    assert sorted(world.scan_labels) == [0, 2]
