"""Tests for a scenario from a mapping, a preset plus overrides (sim.scenario_dict)."""

from __future__ import annotations

import math

import pytest

from phd_swarm.sim.presets import PRESETS, chen_clustered
from phd_swarm.sim.scenario_dict import scenario_from_dict


def test_from_dict_overrides_a_preset():
    s = scenario_from_dict({
        "preset": "chen_clustered", "robots": 60, "resolution": 1, "seed": 4,
        "targets": {"per_cluster": [10, 20], "count": 30, "step_sd": 0.5},
        "models": {"detection": {"p_d": 0.9}},
        "robot_start_box": [0, 0, 10, 10], "ospa_p": math.inf}, where="runs/a.yaml")
    assert s.robots == 60 and s.resolution == 1.0 and s.seed == 4
    assert s.targets.per_cluster == (10, 20) and s.targets.step_sd == 0.5
    assert s.targets.clusters == chen_clustered().targets.clusters
    assert s.models.detection.p_d == 0.9 and s.models.detection.radius == 5.0
    assert s.robot_start_box == (0.0, 0.0, 10.0, 10.0) and s.ospa_p == math.inf


def test_from_dict_preset_only_equals_the_preset():
    for name, make in PRESETS.items():
        assert scenario_from_dict({"preset": name}) == make()


@pytest.mark.parametrize("cfg, key", [
    ({"preset": "dames_static", "robot": 3}, "robot"),
    ({"preset": "dames_static", "targets": {"sped": 1.0}}, "targets.sped"),
    ({"preset": "dames_static", "models": {"detection": {"pd": 1.0}}},
     "models.detection.pd"),
    ({"preset": "dames_static", "models": {"sensor": {}}}, "models.sensor"),
    ({"preset": "dames_static", "env": {"zmax": 1.0}}, "env.zmax"),
])
def test_from_dict_rejects_unknown_keys(cfg, key):
    with pytest.raises(ValueError, match=rf"runs/b\.yaml: {key}: unknown key"):
        scenario_from_dict(cfg, where="runs/b.yaml")


@pytest.mark.parametrize("cfg, key", [
    ({"preset": "dames_static", "robots": 2.5}, "robots"),
    ({"preset": "dames_static", "robots": True}, "robots"),
    ({"preset": "dames_static", "dt": "0.5"}, "dt"),
    ({"preset": "dames_moving", "targets": {"birth": 1}}, "targets.birth"),
    ({"preset": "dames_static", "robot_start_box": [0, 0, 1]}, "robot_start_box"),
    ({"preset": "chen_clustered", "targets": {"clusters": [[0, 0, 1, "x"]]}},
     r"targets.clusters\[0\]\[3\]"),
    ({"preset": "dames_static", "models": {"detection": {"p_d": "high"}}},
     "models.detection.p_d"),
    ({"preset": "dames_static", "targets": "many"}, "targets"),
    ({"preset": 3}, "preset"),
])
def test_from_dict_rejects_wrong_types(cfg, key):
    with pytest.raises(ValueError, match=rf"cfg\.yaml: {key}: expected"):
        scenario_from_dict(cfg, where="cfg.yaml")


@pytest.mark.parametrize("cfg, key", [
    ({"preset": "dames_static", "robots": 0}, "robots"),
    ({"preset": "dames_static", "dt": 0.0}, "dt"),
    ({"preset": "dames_static", "duration": -1.0}, "duration"),
    ({"preset": "dames_moving", "targets": {"speed": -1.0}}, "targets.speed"),
    ({"preset": "dames_static", "robot_max_speed": 0.0}, "robot_max_speed"),
    ({"preset": "dames_static", "robot_start_box": [40, -5, 60, 5]}, "robot_start_box"),
    ({"preset": "dames_static", "models": {"detection": {"p_d": 1.5}}},
     "models.detection.p_d"),
    ({"preset": "dames_static", "ospa_p": 0.5}, "ospa_p"),
    ({"preset": "dames_static", "seed": -1}, "seed"),
    ({"preset": "dames_static", "env": {"xmax": -1.0}}, "env"),
    ({"preset": "dames_static", "targets": {"count": -2}}, "targets.count"),
])
def test_from_dict_rejects_values_out_of_range(cfg, key):
    with pytest.raises(ValueError, match=rf"cfg\.yaml: {key}"):
        scenario_from_dict(cfg, where="cfg.yaml")


@pytest.mark.parametrize("cfg, message", [
    ({"dt": math.nan}, "dt: expected a finite number, got nan"),
    ({"robot_max_speed": math.inf}, "robot_max_speed: expected a finite number, got inf"),
    ({"targets": {"speed": -math.inf}}, "targets.speed: expected a finite number, got -inf"),
    ({"models": {"detection": {"p_d": math.nan}}},
     "models.detection.p_d: expected a finite number, got nan"),
    ({"robot_start_box": [0, 0, math.inf, 5]},
     "robot_start_box[2]: expected a finite number, got inf"),
    ({"ospa_p": math.nan}, "ospa_p: expected a number, got nan"),
    ({"ospa_p": -math.inf}, "ospa_p: expected a number >= 1, got -inf"),
    ({"seed": True}, "seed: expected an integer, got True"),
    ({"targets": {"per_cluster": [30, 30.0]}},
     "targets.per_cluster[1]: expected an integer >= 0, got 30.0"),
])
def test_from_dict_refuses_nan_infinities_and_bools_naming_the_key(cfg, message):
    with pytest.raises(ValueError) as exc:
        scenario_from_dict({"preset": "chen_clustered", **cfg}, where="cfg.yaml")
    assert str(exc.value) == f"cfg.yaml: {message}"


def test_from_dict_needs_a_known_preset():
    with pytest.raises(ValueError, match="f.yaml: preset: missing"):
        scenario_from_dict({"robots": 3}, where="f.yaml")
    with pytest.raises(ValueError, match=r"f.yaml: preset: expected one of \[.*\], got 'nope'"):
        scenario_from_dict({"preset": "nope"}, where="f.yaml")
    with pytest.raises(ValueError, match="f.yaml: expected a mapping"):
        scenario_from_dict([1, 2], where="f.yaml")
