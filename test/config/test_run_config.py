"""The run config: checks that involve several nodes."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from phd_swarm.config import load_run_config, run_config_from_dict
from phd_swarm.sim.scenario import TARGET_KINDS

ROOT = Path(__file__).resolve().parents[2]


def test_the_world_deadline_must_span_several_robot_liveness_periods(tmp_path):
    rc = load_run_config(ROOT / "config" / "dames_static.yaml")
    assert rc.with_overrides(world={"step_timeout": 3.0}, robot={"tick_period": 1.0})
    with pytest.raises(ValueError, match=r"step_timeout \(2 s\) must be at least 3 x "
                                         r"robot.tick_period \(1 s\)"):
        rc.with_overrides(world={"step_timeout": 2.0})
    text = (ROOT / "config" / "dames_static.yaml").read_text().replace(
        "    step_timeout: 15.0", "    step_timeout: 0.5")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    with pytest.raises(ValueError, match=rf"{bad}: world.step_timeout"):
        load_run_config(bad)


@pytest.mark.parametrize(("block", "message"), [
    ("world: {ros__parameters: {step_timout: 15.0}}",
     "world: step_timout: unknown key; expected one of ['linger', 'mode', "),
    ("world: {ros__parameters: {step_timeout: 0.05}}",
     "world: step_timeout: expected a number in [0.1, 3600], got 0.05"),
    ("world: {ros__parameters: {step_timeout: .nan}}",
     "world: step_timeout: expected a finite number in [0.1, 3600], got nan"),
    ("world: {ros__parameters: {observers: true}}",
     "world: observers: expected an integer in [0, 64], got True"),
    ("world: {ros__parameters: {mode: fast}}",
     "world: mode: expected one of ['lockstep', 'realtime'], got 'fast'"),
    ("world: {ros__parameters: {publish_markers: 1}}",
     "world: publish_markers: expected true or false, got 1"),
    ("world: {ros__parameters: [1]}", "world.ros__parameters: expected a mapping, got [1]"),
    ("world: {params: {}}", "world: expected a mapping with the single key ros__parameters"),
])
def test_bad_node_parameters_name_the_file_the_node_and_the_key(block, message):
    doc = yaml.safe_load((ROOT / "config" / "dames_static.yaml").read_text())
    doc.update(yaml.safe_load(block))
    with pytest.raises(ValueError) as exc:
        run_config_from_dict(doc, "runs/bad.yaml", ROOT / "config")
    assert str(exc.value).startswith(f"runs/bad.yaml: {message}")


def test_overrides_are_checked_by_the_same_specs():
    rc = load_run_config(ROOT / "config" / "dames_static.yaml")
    assert rc.with_overrides(world={"observers": 2}).param("world", "observers") == 2
    with pytest.raises(ValueError, match=r"^world: observer: unknown key; expected one of"):
        rc.with_overrides(world={"observer": 2})
    with pytest.raises(ValueError, match=r"^robot: tick_period: expected a number in "
                                         r"\[0.01, 600\], got 'slow'"):
        rc.with_overrides(robot={"tick_period": "slow"})


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "config").glob("*.yaml")))
def test_every_shipped_config_loads(name):
    rc = load_run_config(ROOT / "config" / name)
    assert rc.scenario.name == name.removesuffix(".yaml")


def test_strings_that_ros_reads_as_booleans_are_quoted_in_params_files():
    from phd_swarm.config import dump_params

    text = dump_params({"a": {"ros__parameters": {"axis": "y", "rule": "On", "kind": "x",
                                                  "flag": True}}})
    assert "axis: 'y'" in text and "rule: 'On'" in text and "kind: x" in text
    assert "flag: true" in text


@pytest.mark.parametrize("kind", TARGET_KINDS)
def test_a_scenario_of_every_target_kind_survives_the_params_file(kind, tmp_path):
    import dataclasses

    from phd_swarm.config import RunConfig, scenario_from_dict, scenario_to_dict
    from phd_swarm.sim.presets import sung_tokekar

    base = sung_tokekar()
    extra = ({"clusters": ((0.0, 0.0, 50.0, 50.0),), "per_cluster": (10,)}
             if kind == "clustered_walk" else {})
    s = base.with_overrides(targets=dataclasses.replace(base.targets, kind=kind, **extra))
    assert scenario_from_dict(scenario_to_dict(s)) == s
    RunConfig(s).write_params(tmp_path / "params.yaml")


def test_a_config_that_is_not_utf8_is_refused_naming_the_file(tmp_path):
    """Found by fuzzing (issue 40): it escaped as a bare UnicodeDecodeError."""
    path = tmp_path / "bad.yaml"
    path.write_bytes(b"scenario:\n  robots: 3\n  name: \x91\n")
    with pytest.raises(ValueError, match=rf"{path}: the config file is not UTF-8 text "
                                         r"\(byte 30\)"):
        load_run_config(path)
