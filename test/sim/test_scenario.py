"""Tests for the scenario dataclasses: validation, overrides, extraction and start grid."""

from __future__ import annotations

import math

import pytest

from phd_swarm.core.extraction import ExtractionConfig
from phd_swarm.sim.presets import chen_clustered, dames_moving, dames_static
from phd_swarm.sim.scenario import EXTRACTION_WINDOW_M, Scenario, TargetConfig
from phd_swarm.sim.scenario_dict import scenario_from_dict


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
    # Each field on its own in the config; the kind's own fields together when the
    # scenario is built (more in test_target_kinds).
    with pytest.raises(ValueError, match="targets.kind"):
        TargetConfig(kind="teleport")
    with pytest.raises(ValueError, match="draw_box"):
        dames_static().with_overrides(targets=TargetConfig(kind="static", count=3))
    with pytest.raises(ValueError, match="sum"):
        chen_clustered().with_overrides(targets=TargetConfig(
            kind="clustered_walk", count=5, clusters=((0, 0, 1, 1),), per_cluster=(4,)))
    with pytest.raises(ValueError, match=r"clusters\[0\]"):
        chen_clustered().with_overrides(targets=TargetConfig(
            kind="clustered_walk", count=1, clusters=((90, 90, 120, 120),), per_cluster=(1,)))


def test_the_dataclasses_check_with_the_same_messages():
    with pytest.raises(ValueError, match=r"^robots: expected an integer >= 1, got 0$"):
        dames_static().with_overrides(robots=0)
    with pytest.raises(ValueError, match=r"^targets.count: expected an integer >= 0, got True$"):
        TargetConfig(kind="dames_walk", count=True)
    with pytest.raises(ValueError, match=r"^targets.clusters\[0\]: expected four numbers"):
        TargetConfig(kind="clustered_walk", count=1, clusters=((0, 0, 1),), per_cluster=(1,))
    with pytest.raises(ValueError, match=r"^name: expected a non-empty string, got ''$"):
        dames_static().with_overrides(name="")


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
