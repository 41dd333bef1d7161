"""When the monitor scores a step: its reporters, with the world's verdict window in real time.

In lockstep a robot that does not report step k is dead at k+1 (W = 1). In real time the
world counts a silent robot dead only W steps later (``verdict_window``); a monitor that
waited for every robot alive at k and k+1 stalled through a cut link until its
``end_timeout``. The steps' inputs are set directly here; the messages' way in is covered by
the runs of ``test_systems_inprocess.py`` and ``test_run_swarm_hosts.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from phd_swarm.config import RunConfig
from phd_swarm.testing import small_static_scenario


def _monitor(ros, tmp_path, window: int):
    from phd_swarm.nodes.monitor import MonitorNode

    rc = RunConfig(small_static_scenario(robots=3, steps=12)).with_overrides(
        monitor={"progress_every": 0, "verdict_window": window})
    params = rc.write_params(tmp_path / f"params_{window}.yaml")
    monitor = ros.add(MonitorNode(context=ros.context,
                                  cli_args=["--ros-args", "--params-file", str(params)]))
    scored: list[int] = []
    monitor._process = lambda k: scored.append(k) or monitor.truth.pop(k)
    return monitor, scored


def _step_in(monitor, k: int, robots: set[int]) -> None:
    """Truth of step k, and the outputs and status of step k from ``robots``."""
    monitor.truth[k] = np.zeros((0, 2))
    monitor._complete[k] = set(robots)
    monitor.statuses[k] = {r: object() for r in robots}


@pytest.mark.ros
@pytest.mark.parametrize("window", [1, 4])
def test_a_robot_cut_off_is_not_waited_for_past_the_worlds_verdict(tmp_path, window):
    from phd_swarm.testing import InProcessRos

    everyone, left = frozenset({0, 1, 2}), frozenset({0, 1})
    with InProcessRos() as ros:
        monitor, scored = _monitor(ros, tmp_path, window)
        # Robot 2 reports steps 0-1, then its link is cut; the world says so at step 5.
        for k in range(8):
            _step_in(monitor, k, {0, 1, 2} if k <= 1 else {0, 1})
        for k in range(5):
            monitor.alive[k] = everyone
            monitor._process_ready_steps()
        # Steps 0 and 1 are whole; step 2 waits (robot 2 was alive at 2..4).
        assert scored == [0, 1]
        monitor.alive[5] = left
        monitor._process_ready_steps()
        if window == 1:
            # Lockstep's rule: robot 2, alive at 2 and 3, is awaited at step 2 for good.
            assert scored == [0, 1]
        else:
            # Steps 2-4 are within the verdict window of step 5: robot 2 is not awaited.
            assert scored == [0, 1, 2, 3, 4]
            monitor.alive[6] = left
            monitor._process_ready_steps()
            assert scored == [0, 1, 2, 3, 4, 5]


@pytest.mark.ros
def test_a_slow_robot_within_the_window_is_waited_for(tmp_path):
    from phd_swarm.testing import InProcessRos

    everyone = frozenset({0, 1, 2})
    with InProcessRos() as ros:
        monitor, scored = _monitor(ros, tmp_path, 4)
        _step_in(monitor, 0, {0, 1})
        for k in range(6):
            monitor.alive[k] = everyone
        monitor._process_ready_steps()
        assert scored == []         # alive through k + W: its report is still awaited
        _step_in(monitor, 0, {0, 1, 2})
        monitor._process_ready_steps()
        assert scored == [0]
