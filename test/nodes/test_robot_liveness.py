"""A robot waiting for the world's delayed messages is slow, not dead (robot heartbeat)."""

from __future__ import annotations

import threading

import pytest

from phd_swarm.nodes.topics import robot_topic
from phd_swarm.testing import small_static_scenario, start_swarm

#: The step whose measurement set reaches robot 1 late, and how late [s].
HELD_STEP = 3
HELD_FOR = 6.0
STEP_TIMEOUT = 3.0


class _LatePublisher:
    """Stands in for a world publisher: holds back step ``HELD_STEP``'s message.

    As DDS does when it lost a reliable sample and re-sends it at the writer's next
    heartbeat, seconds later.
    """

    def __init__(self, pub) -> None:
        self.pub = pub
        self.timers: list[threading.Timer] = []

    def publish(self, msg) -> None:
        # The world publishes CDR (it keeps the bytes for its bundle, bundle.py).
        from rclpy.serialization import deserialize_message

        from phd_swarm_msgs.msg import MeasurementSet

        if deserialize_message(msg, MeasurementSet).step != HELD_STEP:
            self.pub.publish(msg)
            return
        timer = threading.Timer(HELD_FOR, self.pub.publish, args=(msg,))
        self.timers.append(timer)
        timer.start()


@pytest.mark.ros
def test_a_robot_whose_inputs_come_late_is_not_counted_dead(tmp_path):
    from phd_swarm.nodes.qos import subscription_qos
    from phd_swarm.testing import InProcessRos
    from phd_swarm_msgs.msg import RobotStatus

    scenario = small_static_scenario(robots=3, steps=8)
    with InProcessRos() as ros:
        world, monitor, robots = start_swarm(ros, tmp_path, scenario,
                                             robot={"tick_period": 0.2},
                                             step_timeout=STEP_TIMEOUT)
        late = world.scan_pubs[1] = _LatePublisher(world.scan_pubs[1])
        heard: list[tuple[int, int]] = []
        probe = ros.node("probe")
        probe.create_subscription(RobotStatus, robot_topic(1, "status"),
                                  lambda m: heard.append((m.state, m.step)),
                                  subscription_qos("STEP"))
        try:
            assert ros.spin_until(lambda: monitor.done, timeout=120.0)
        finally:
            for timer in late.timers:
                timer.cancel()
        assert late.timers, "the held step was published"
        assert world.dead == set() and world.rejoins == {}
        assert len(monitor.series) == scenario.steps
        # While it waited for step 3's measurement set, robot 1 said it was alive (its last
        # finished step, 2) about every tick_period.
        waiting = [s for state, s in heard if state == RobotStatus.STATE_WORKING]
        assert waiting.count(HELD_STEP - 1) >= HELD_FOR / 0.2 / 2
