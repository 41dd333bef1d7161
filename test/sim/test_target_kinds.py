"""Tests for the target kinds' registry (phd_swarm.sim.target_kinds)."""

from __future__ import annotations

import dataclasses

import pytest

from phd_swarm.sim import target_kinds
from phd_swarm.sim.presets import chen_clustered, dames_moving, dames_static, papaioannou
from phd_swarm.sim.scenario import TARGET_KINDS, TargetConfig
from phd_swarm.sim.target_kinds import TargetKind, lookup, names, register, registered

#: Each built-in kind and the module that implements and registers it.
HOMES = {"static": "phd_swarm.sim.dames_targets", "dames_walk": "phd_swarm.sim.dames_targets",
         "clustered_walk": "phd_swarm.sim.walkers", "turning_walk": "phd_swarm.sim.walkers",
         "ncv": "phd_swarm.sim.ncv_paths"}


def test_every_built_in_kind_is_registered_by_the_module_that_implements_it():
    assert TARGET_KINDS == names() == tuple(sorted(HOMES))
    assert {k.name: k.make.__module__ for k in registered()} == HOMES


def test_the_kinds_read_the_target_config_and_every_field_is_read():
    config = {f.name for f in dataclasses.fields(TargetConfig)} - {"kind"}
    read = set()
    for kind in registered():
        assert set(kind.fields) <= config, kind.name
        assert len(set(kind.fields)) == len(kind.fields)
        read |= set(kind.fields)
    assert read == config


def test_the_kinds_fields_are_those_their_functions_take():
    assert lookup("static").fields == ("count", "draw_box", "layout_seed")
    assert lookup("turning_walk").fields == ("count", "draw_box", "speed", "turn_every")
    # ``count`` is only checked against the clusters, not drawn from.
    assert lookup("clustered_walk").fields == ("clusters", "per_cluster", "step_sd",
                                               "max_speed", "count")


def test_fields_are_derived_from_make_and_check():
    def make(rng, scenario, *, a, b):
        return None

    def check(scenario, *, b, c):
        return None

    kind = TargetKind("probe", make=make, description="a probe", check=check)
    assert kind.fields == ("a", "b", "c")
    assert TargetKind("probe", make=lambda rng, s: None, description="").fields == ()


def test_a_description_is_one_line_for_the_docs():
    for kind in registered():
        assert kind.description and "\n" not in kind.description, kind.name
        assert ";" not in kind.description, kind.name   # the docs join them with commas


def test_a_name_is_registered_once_and_unknown_names_are_listed():
    with pytest.raises(ValueError, match="already registered"):
        register(lookup("static"))
    with pytest.raises(ValueError, match="unknown target kind 'teleport'; expected one of "
                                         "clustered_walk, dames_walk"):
        lookup("teleport")


def test_a_registered_kind_is_a_valid_target_kind(monkeypatch):
    monkeypatch.setitem(target_kinds._KINDS, "probe", TargetKind(
        "probe", make=lambda rng, s, *, count: None, description="a probe"))
    assert "probe" in names()
    assert TargetConfig(kind="probe").kind == "probe"


def test_the_target_config_checks_each_field_and_the_kind_name():
    with pytest.raises(ValueError, match="targets.kind: expected one of"):
        TargetConfig(kind="teleport")
    with pytest.raises(ValueError, match=r"^targets.count: expected an integer >= 0, got True$"):
        TargetConfig(kind="dames_walk", count=True)
    with pytest.raises(ValueError, match=r"^targets.clusters\[0\]: expected four numbers"):
        TargetConfig(kind="clustered_walk", count=1, clusters=((0, 0, 1),), per_cluster=(1,))


def _with(scenario, **fields):
    return scenario.with_overrides(targets=dataclasses.replace(scenario.targets, **fields))


def test_each_kind_checks_its_fields_together_and_against_the_run():
    with pytest.raises(ValueError, match="^targets.draw_box is required for static targets$"):
        _with(dames_moving(), kind="static")
    with pytest.raises(ValueError, match=r"^targets.count \(5\) must equal "
                                         r"sum\(targets.per_cluster\) \(4\)$"):
        _with(chen_clustered(), count=5, clusters=((0, 0, 1, 1),), per_cluster=(4,))
    with pytest.raises(ValueError, match="^targets.per_cluster needs one count per cluster"):
        _with(chen_clustered(), per_cluster=(60,))
    with pytest.raises(ValueError, match=r"^targets.clusters\[0\] \(90.0, 90.0, 120.0, 120.0\) "
                                         r"must lie inside the environment"):
        _with(chen_clustered(), count=1, clusters=((90, 90, 120, 120),), per_cluster=(1,))
    with pytest.raises(ValueError, match="^targets.heading_rate: dt \\* heading_rate must be"):
        _with(dames_moving(), heading_rate=3.0)
    with pytest.raises(ValueError, match="^targets.lifetime_model: contained places whole "
                                         "paths in the area and needs spawn: uniform$"):
        _with(papaioannou(), lifetime_model="contained")


def test_a_kind_checks_only_its_own_fields():
    # Dames' static targets do not read the clusters nor the walkers' heading rate.
    s = _with(dames_static(), clusters=((90, 90, 120, 120),), per_cluster=(1, 2),
              heading_rate=3.0)
    assert s.targets.kind == "static"
