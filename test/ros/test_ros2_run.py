"""``ros2 run phd_swarm robot`` joins a team that ``run_swarm.sh`` started (issue 36).

The team's robot 2 is killed mid-run; the same robot started again with the real
``ros2 run`` (the ``ros2_cli`` fixture says which ``ros2``), the run's config and the ROS
arguments ``scripts/run_robot.sh`` passes, is admitted again and steps with the team, as
the process ``run_robot.sh`` restarts does (``test/tools/test_run_swarm.py``, whose
helpers this test shares).
"""

from __future__ import annotations

import os
import signal
import subprocess

import pytest

from ..tools.test_run_swarm import (
    _assert_rejoined,
    _pid_of,
    _rejoin_and_stop,
    _start_fast,
    _wait_for,
)

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_a_robot_started_with_ros2_run_joins_a_run_swarm_team(tmp_path, children, ros2_cli):
    proc = _start_fast(children, tmp_path, "joined", 2000)
    run = tmp_path / "joined"
    _wait_for(run / "logs" / "monitor.log", "step 11/", proc)
    pid = _pid_of(run, 2)
    assert pid is not None
    os.kill(pid, signal.SIGKILL)
    _wait_for(run / "logs" / "world.log", "robot 2 did not report", proc)

    log = tmp_path / "ros2_run_robot.out"
    with open(log, "w") as sink:
        robot = children.start(
            ros2_cli("run", "phd_swarm", "robot", "--ros-args", "--params-file",
                     str(run / "config.yaml"), "-r", "__ns:=/robot_2", "-p", "robot_id:=2"),
            env={**ros2_cli.env, "ROS_LOG_DIR": str(tmp_path / "ros_log")}, stdout=sink,
            stderr=subprocess.STDOUT)
    step = _rejoin_and_stop(run, 2, proc)
    _assert_rejoined(run, 2, step)
    assert robot.poll() is None, f"ros2 run's robot exited:\n{log.read_text()}"
    children.stop(robot)
    text = log.read_text()
    assert "[robot_2.robot]: robot 2: system " in text, text
    print(f"ros2 run ({ros2_cli.origin}): robot 2 rejoined at step {step}")
