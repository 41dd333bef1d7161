"""The run config: checks that involve several nodes."""

from __future__ import annotations

from pathlib import Path

import pytest

from phd_swarm.config import load_run_config

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
