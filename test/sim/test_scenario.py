"""Tests for scenarios: paper presets, overrides and building from a mapping."""

from __future__ import annotations

import math

import pytest

from phd_swarm.core import models as core_models
from phd_swarm.core.extraction import ExtractionConfig
from phd_swarm.sim.presets import PRESETS, chen_clustered, dames_moving, dames_static
from phd_swarm.sim.scenario import EXTRACTION_WINDOW_M, Scenario, TargetConfig
from phd_swarm.sim.scenario_dict import scenario_from_dict


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


def test_with_overrides_revalidates():
    s = dames_static().with_overrides(robots=7, seed=3)
    assert (s.robots, s.seed) == (7, 3)
    with pytest.raises(ValueError, match="robots"):
        s.with_overrides(robots=0)
    with pytest.raises(ValueError, match="robot_start_box"):
        s.with_overrides(robot_start_box=(90.0, 0.0, 110.0, 10.0))
    with pytest.raises(ValueError, match="resolution"):
        s.with_overrides(resolution=0.3)
    with pytest.raises(ValueError, match="heading_rate"):
        dames_moving().with_overrides(dt=0.25 / 2 + 0.01)


def test_target_config_checks_kind_specific_fields():
    with pytest.raises(ValueError, match="targets.kind"):
        TargetConfig(kind="teleport")
    with pytest.raises(ValueError, match="draw_box"):
        TargetConfig(kind="static", count=3)
    with pytest.raises(ValueError, match="sum"):
        TargetConfig(kind="clustered_walk", count=5, clusters=((0, 0, 1, 1),),
                     per_cluster=(4,))
    with pytest.raises(ValueError, match=r"clusters\[0\]"):
        chen_clustered().with_overrides(targets=TargetConfig(
            kind="clustered_walk", count=1, clusters=((90, 90, 120, 120),), per_cluster=(1,)))


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


def test_the_dataclasses_check_with_the_same_messages():
    with pytest.raises(ValueError, match=r"^robots: expected an integer >= 1, got 0$"):
        dames_static().with_overrides(robots=0)
    with pytest.raises(ValueError, match=r"^targets.count: expected an integer >= 0, got True$"):
        TargetConfig(kind="dames_walk", count=True)
    with pytest.raises(ValueError, match=r"^targets.clusters\[0\]: expected four numbers"):
        TargetConfig(kind="clustered_walk", count=1, clusters=((0, 0, 1),), per_cluster=(1,))
    with pytest.raises(ValueError, match=r"^name: expected a non-empty string, got ''$"):
        dames_static().with_overrides(name="")


def test_from_dict_needs_a_known_preset():
    with pytest.raises(ValueError, match="f.yaml: preset: missing"):
        scenario_from_dict({"robots": 3}, where="f.yaml")
    with pytest.raises(ValueError, match=r"f.yaml: preset: expected one of \[.*\], got 'nope'"):
        scenario_from_dict({"preset": "nope"}, where="f.yaml")
    with pytest.raises(ValueError, match="f.yaml: expected a mapping"):
        scenario_from_dict([1, 2], where="f.yaml")


def test_scenario_is_hashable_and_comparable():
    assert dames_static() == dames_static()
    assert hash(dames_static()) == hash(dames_static())
    assert isinstance(dames_static(), Scenario)


def test_birth_heading_is_read_from_the_config_and_checked():
    from phd_swarm.sim.presets import dames_moving
    from phd_swarm.sim.scenario_dict import scenario_from_dict

    assert dames_moving().targets.birth_heading == "inward"
    sc = scenario_from_dict({"preset": "dames_moving",
                             "targets": {"birth_heading": "uniform"}})
    assert sc.targets.birth_heading == "uniform"
    with pytest.raises(ValueError, match="targets.birth_heading: expected one of"):
        scenario_from_dict({"preset": "dames_moving", "targets": {"birth_heading": "north"}})


def test_extraction_keeps_its_window_and_threshold_in_metres():
    # Dames: 3 x 3 bins of 1 m and 0.05 per bin. At 0.1 m a 3-bin window would find
    # several maxima on one target's peak, so the window stays 3 m.
    for res, bins in ((1.0, 3), (0.5, 7), (0.1, 31)):
        s = chen_clustered(robots=10, resolution=res)
        assert s.extraction.window_bins(s.grid) == bins
        assert s.extraction.bin_threshold(s.grid) == pytest.approx(0.05 * res ** 2)
    s = dames_static()
    assert (s.extraction.window_bins(s.grid), s.extraction.bin_threshold(s.grid)) == (3, 0.05)


def test_robot_start_grid_is_optional_validated_and_read_from_the_config():
    assert dames_static().robot_start_grid is None
    s = scenario_from_dict({"preset": "dames_static", "robot_start_grid": 2,
                            "robot_start_box": [0, 0, 10, 10]})
    assert s.robot_start_grid == 2.0 and isinstance(s.robot_start_grid, float)
    assert s.start_grid_ranges() == ((0, 5), (0, 5))
    assert scenario_from_dict({"preset": "dames_static", "robot_start_grid": None}) == \
        dames_static()
    for bad, message in ((0.0, "expected a number > 0"), (-1.0, "expected a number > 0"),
                         (math.inf, "expected a finite number"),
                         (math.nan, "expected a finite number"),
                         ("1", "expected a number"), (True, "expected a number")):
        with pytest.raises(ValueError, match=rf"cfg\.yaml: robot_start_grid: {message}"):
            scenario_from_dict({"preset": "dames_static", "robot_start_grid": bad},
                               where="cfg.yaml")
    # The start box (40..60 x 0..10) holds no node of a 35 m grid anchored at (0, 0) in x.
    with pytest.raises(ValueError, match="robot_start_grid: no node of the 35 m grid"):
        dames_static().with_overrides(robot_start_grid=35.0)
    with pytest.raises(ValueError, match="robot_start_grid is not set"):
        dames_static().start_grid_ranges()


def test_robot_start_grid_round_trips_and_leaves_existing_config_hashes_alone():
    from phd_swarm.config import scenario_to_dict
    from phd_swarm.config.sweep_spec import config_hash

    base = dames_static()
    on = base.with_overrides(robot_start_grid=1.0)
    assert "robot_start_grid" not in scenario_to_dict(base)
    assert scenario_from_dict(scenario_to_dict(on)) == on
    # A hash of the fields without the new one is what committed results were hashed by.
    h = config_hash(base, "phd", "ospa", (0.0, 1.0))
    assert h == config_hash(base.with_overrides(robot_start_grid=None), "phd", "ospa",
                            (0.0, 1.0))
    assert config_hash(on, "phd", "ospa", (0.0, 1.0)) != h


def test_the_extraction_window_is_the_grid_estimators_option():
    s = chen_clustered(robots=5, resolution=0.5)
    # The default is the one from before the options (Dames' 3 bins of 1 m, in metres).
    assert s.extraction == ExtractionConfig(threshold_per_m2=0.05,
                                            neighbourhood_m=EXTRACTION_WINDOW_M)
    assert s.system.option("extraction_window") == EXTRACTION_WINDOW_M
    small = s.with_system(options={"extraction_window": 1.5})
    assert small.extraction.window_bins(small.grid) == 3
    disk = s.with_system(options={"extraction_radius": 1.0})
    assert disk.extraction.radius_m == 1.0 and disk.extraction.footprint(disk.grid).sum() == 13
    doc = {"preset": "chen_clustered", "resolution": 1.0,
           "system": {"options": {"extraction_radius": 0.5}}}
    with pytest.raises(ValueError, match=r"cfg\.yaml: system\.options\.extraction_radius: "
                                         r"a radius of 0\.5 m is below the bin side"):
        scenario_from_dict(doc, where="cfg.yaml")
    with pytest.raises(ValueError, match="extraction_window"):
        s.with_system(options={"extraction_window": 0.0})
