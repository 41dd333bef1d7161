"""Shirsat & Berman's labelled reading is refused by the ROS stack, naming the reading.

The system itself runs as ROS nodes against the engine in the table of
``test_systems_inprocess.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from phd_swarm.config import load_run_config

ROOT = Path(__file__).resolve().parents[2]
STEPS = 60


@pytest.mark.ros
def test_the_ros_stack_refuses_the_labelled_sensor_naming_the_reading(tmp_path):
    """MeasurementSet and RewardSet carry no labels: the nodes refuse to run without them."""
    from phd_swarm.nodes.ros_params import ParameterError
    from phd_swarm.testing import InProcessRos, start_swarm

    scenario = load_run_config(ROOT / "config" / "shirsat_small.yaml").scenario.with_system(
        sensor="disk_labelled", options={"reward_union": "label"})
    with InProcessRos(executor="events") as ros:
        with pytest.raises(ParameterError, match=r"scenario\.system: sensor disk_labelled "
                                                 r"labels its measurements.*reward_union: "
                                                 r"label\) runs on the in-memory engines only"):
            start_swarm(ros, tmp_path, scenario)


def test_run_swarm_refuses_the_labelled_sensor_before_anything_starts(tmp_path):
    import subprocess
    import sys

    text = (ROOT / "config" / "shirsat_small.yaml").read_text()
    config = tmp_path / "labelled.yaml"
    config.write_text(text.replace("sensor: disk\n", "sensor: disk_labelled\n").replace(
        "grid_spacing: 0.5 ", "reward_union: label\n          grid_spacing: 0.5 "))
    assert "disk_labelled" in config.read_text() and "reward_union: label" in config.read_text()
    out = tmp_path / "runs"
    res = subprocess.run([sys.executable, "-m", "phd_swarm.tools.run_swarm", str(config),
                          "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "sensor disk_labelled labels its measurements" in res.stderr
    assert "in-memory engines only" in res.stderr and not out.exists()
