"""Tests for the papers' presets (phd_swarm.sim.presets)."""

from __future__ import annotations

import pytest

from phd_swarm.core import models as core_models
from phd_swarm.sim.presets import chen_clustered, dames_moving, dames_static


def test_dames_static_preset():
    s = dames_static()
    assert (s.env.width, s.env.height, s.resolution) == (100.0, 100.0, 1.0)
    assert s.dt == 0.5 and s.steps == 500 and s.robots == 20
    assert s.robot_max_speed == 2.0 and s.robot_start_box == (40.0, 0.0, 60.0, 10.0)
    assert s.targets.kind == "static" and s.targets.count == 30
    assert s.targets.draw_box == (-10.0, -10.0, 110.0, 110.0)
    assert s.models == core_models.dames_static()
    assert (s.ospa_c, s.ospa_p, s.extraction_threshold) == (10.0, 1.0, 0.05)
    assert s.extraction.bin_threshold(s.grid) == pytest.approx(0.05)


def test_dames_moving_preset():
    s = dames_moving(robots=40, targets=10)
    assert s.robots == 40 and s.steps == 1000
    t = s.targets
    assert (t.kind, t.count, t.speed, t.heading_sd, t.heading_rate, t.birth) == (
        "dames_walk", 10, 1.0, 0.1, 10.0, True)
    assert s.models == core_models.dames_moving()


def test_chen_preset():
    s = chen_clustered()
    assert s.robots == 70 and s.resolution == 0.1 and s.steps == 2000
    assert s.robot_max_speed == 5.0 and s.robot_start_box == (40.0, 0.0, 60.0, 10.0)
    t = s.targets
    assert t.clusters == ((0.0, 0.0, 33.0, 33.0), (67.0, 67.0, 100.0, 100.0))
    assert t.per_cluster == (30, 30) and t.count == 60 and t.max_speed == 3.0
    assert s.models.detection.radius == 5.0
    assert s.grid.shape == (1000, 1000)
    # 0.05 per m^2 on 0.01 m^2 bins.
    assert s.extraction.bin_threshold(s.grid) == pytest.approx(5e-4)
    assert chen_clustered(resolution=1.0).grid.shape == (100, 100)
