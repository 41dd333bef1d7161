"""World, monitor and a team of robot nodes in one process, in real time.

Lockstep runs of every system against the engine are the table of
``test_systems_inprocess.py``.
"""

from __future__ import annotations

import pytest

from phd_swarm.testing import small_static_scenario, start_swarm


@pytest.mark.ros
def test_realtime_mode_steps_on_the_clock_and_the_team_keeps_up(tmp_path):
    import time

    from phd_swarm.testing import InProcessRos

    scenario = small_static_scenario(robots=3, steps=24)
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_swarm(ros, tmp_path, scenario, mode="realtime",
                                             realtime_factor=5.0)
        assert ros.spin_until(lambda: world._phase == "stepping", timeout=60.0)
        started = time.monotonic()
        assert ros.spin_until(lambda: world._phase in ("lingering", "finished"),
                              timeout=60.0)
        elapsed = time.monotonic() - started
        assert ros.spin_until(lambda: monitor.done, timeout=60.0)
    # 24 steps of 0.5 s at 5 x real time take 2.4 s of wall time, whatever the robots do.
    assert 2.0 < elapsed < 6.0, elapsed
    assert len(monitor.series) == scenario.steps
    assert world.dead == set()
