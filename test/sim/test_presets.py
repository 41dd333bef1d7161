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


# --- the registry ---------------------------------------------------------------------------

def test_every_preset_is_registered_by_its_papers_module():
    from phd_swarm.sim.presets import PRESETS, registered

    homes = {p.name: p.build.__module__.rsplit(".", 1)[-1] for p in registered()}
    assert homes == {"dames_static": "dames", "dames_moving": "dames",
                     "chen_clustered": "chen", "sung_tokekar": "sung",
                     "shirsat_berman": "shirsat", "papaioannou": "papaioannou"}
    assert dict(PRESETS) == {p.name: p.build for p in registered()}
    assert list(PRESETS) == sorted(PRESETS)
    for p in registered():
        assert p.paper and "\n" not in p.paper, p.name


def test_presets_build_their_papers_scenario_without_arguments():
    from phd_swarm.sim.presets import PRESETS

    for name, build in PRESETS.items():
        assert build().name == name


def test_presets_is_read_only_and_a_name_is_registered_once():
    from phd_swarm.sim.presets import PRESETS
    from phd_swarm.sim.presets.registry import preset

    with pytest.raises(TypeError):
        PRESETS["mine"] = dames_static  # type: ignore[index]
    with pytest.raises(ValueError, match="already registered"):
        preset("Dames (2020)")(dames_static)


def test_every_target_kind_is_written_out_over_one_preset():
    import dataclasses

    from phd_swarm.config import scenario_to_dict
    from phd_swarm.sim.presets import PRESETS, preset_of_kind
    from phd_swarm.sim.scenario import TARGET_KINDS

    of_kind = preset_of_kind()
    assert set(of_kind) == set(TARGET_KINDS) and set(of_kind.values()) <= set(PRESETS)
    # The preset config files name for a scenario of each kind (phd_swarm.config).
    base = PRESETS["sung_tokekar"]()
    for kind in TARGET_KINDS:
        extra = ({"clusters": ((0.0, 0.0, 50.0, 50.0),), "per_cluster": (10,)}
                 if kind == "clustered_walk" else {})
        s = base.with_overrides(targets=dataclasses.replace(base.targets, kind=kind, **extra))
        assert scenario_to_dict(s)["preset"] == of_kind[kind]
