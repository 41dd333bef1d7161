"""The per-node scripts: run_world.sh, run_robot.sh and record.sh started by hand, as users do."""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path

import pytest

from phd_swarm.logs.mcap_log import read_messages, read_metadata, summarize
from phd_swarm_msgs.msg import RobotStatus

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ROOT / "scripts"


def _config(tmp_path: Path) -> Path:
    """config/dames_static.yaml for 2 robots and 8 steps, waiting for one observer."""
    text = (ROOT / "config" / "dames_static.yaml").read_text()
    text = text.replace("robots: 20 ", "robots: 2 ").replace("duration: 250.0", "duration: 4.0")
    text = text.replace("    step_timeout: 15.0", "    step_timeout: 15.0\n    observers: 1")
    text = text.replace("        controller: phd ", "        controller: uniform ")
    text = text.replace("    tick_period: 1.0 ", "    observers: 1\n    tick_period: 1.0 ")
    assert text.count("uniform") == 1 and text.count("observers: 1") == 2
    path = tmp_path / "two_robots.yaml"
    path.write_text(text)
    return path


@pytest.mark.ros
@pytest.mark.slow
def test_world_robots_and_recorder_started_by_hand_complete_a_run(tmp_path, children):
    config = _config(tmp_path)
    out = tmp_path / "hand.mcap"
    recorder = children.start([str(SCRIPTS / "record.sh"), str(out), str(config)])
    robots = [children.start([str(SCRIPTS / "run_robot.sh"), str(i), str(config)])
              for i in range(2)]
    world = children.start([str(SCRIPTS / "run_world.sh"), str(config)])
    try:
        world_out, world_err = world.communicate(timeout=120.0)
    except subprocess.TimeoutExpired:
        children.stop(world)
        raise
    assert world.returncode == 0, world_out + world_err
    assert "done, 8 steps" in world_out + world_err
    assert "dead robots: none" in world_out + world_err
    time.sleep(0.5)
    children.stop(recorder)
    for proc in robots:
        children.stop(proc)
        assert proc.returncode == 0, proc.communicate()
    info = summarize(out)
    assert not info.truncated
    assert info.topics["/world/truth"].message_count == 8
    done = [r.msg.step for r in read_messages(out, topics=["/robot_1/status"])
            if r.msg.state == RobotStatus.STATE_STEP_DONE]
    assert done == list(range(8))
    report = json.loads(read_metadata(out)["phd_swarm.completeness"]["report"])
    assert report["complete"] and report["steps"] == 8, report
    assert (out.parent / "metadata.yaml").exists()


def test_run_robot_rejects_a_bad_id_and_a_bad_config(tmp_path):
    bad_id = subprocess.run([str(SCRIPTS / "run_robot.sh"), "x", "config/dames_static.yaml"],
                            cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert bad_id.returncode == 2 and "robot id must be a non-negative integer" in bad_id.stderr
    config = tmp_path / "typo.yaml"
    config.write_text((ROOT / "config" / "dames_static.yaml").read_text().replace(
        "robot_max_speed: 2.0", "robot_max_sped: 2.0"))
    bad = subprocess.run([str(SCRIPTS / "run_robot.sh"), "0", str(config)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode != 0
    assert "typo.yaml" in bad.stderr and "robot_max_sped" in bad.stderr
