"""Robot nodes reject bad messages with a reason and a counter, and keep running."""

from __future__ import annotations

import math
import struct

import pytest
from geometry_msgs.msg import Point
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message

from phd_swarm.nodes import convert, inbox
from phd_swarm.nodes.qos import publisher_qos
from phd_swarm.testing import small_static_scenario, start_swarm
from phd_swarm_msgs.msg import InboxMessage, MeasurementSet, ParticleTransfer, RobotState


def _state(robot_id: int, step: int, x: float = 10.0) -> RobotState:
    return RobotState(header=convert.header(step, 0.5, "map"), robot_id=robot_id, step=step,
                      position=Point(x=x, y=5.0), power_weight=0.0, cell_radius=1.0)


@pytest.mark.ros
def test_bad_messages_are_rejected_counted_and_the_team_finishes(tmp_path):
    from phd_swarm.testing import InProcessRos

    scenario = small_static_scenario(robots=3, steps=24)
    with InProcessRos(executor="events") as ros:
        world, monitor, robots = start_swarm(ros, tmp_path, scenario)
        victim = robots[1]
        ros.spin_until(lambda: victim.filter.step >= 2, timeout=60.0)
        evil = ros.node("evil")
        pub = evil.create_publisher(InboxMessage, "/robot_1/inbox", publisher_qos("INBOX"))
        ros.spin_until(lambda: pub.get_subscription_count() > 0, timeout=10.0)

        def send(sender: int, kind: str, msg) -> None:
            pub.publish(inbox.pack(sender, [(kind, serialize_message(msg))]))

        k = victim.filter.step + 1
        send(0, "state", _state(0, k, x=math.nan))                   # NaN position
        send(99, "state", _state(99, k))                             # unknown robot id
        send(1, "state", _state(1, k))                               # its own id: duplicate
        send(0, "state", _state(0, 10**6))                           # step out of range
        send(2, "state", _state(0, k))                               # robot 0's, from 2
        send(2, "measurements", MeasurementSet(
            header=convert.header(k, 0.5, "map"), robot_id=2, step=k,
            sensor_position=Point(x=1.0, y=1.0),
            measurements=[Point(x=1.0, y=1.0)] * 20_000))            # absurd
        send(0, "particles", ParticleTransfer(
            header=convert.header(k, 0.5, "map"), from_id=0, to_id=1, step=k, kind=0,
            bin_indices=[10**8], weights=[0.1]))                     # bin off the grid
        send(0, "particles", ParticleTransfer(
            header=convert.header(k, 0.5, "map"), from_id=0, to_id=1, step=k, kind=0,
            radius_ids=[2], cell_radii=[-1.0]))                      # negative cell radius
        send(0, "particles", ParticleTransfer(
            header=convert.header(k, 0.5, "map"), from_id=0, to_id=2, step=k,
            kind=0))                                                 # for another robot
        good = inbox.pack(0, [("state", serialize_message(_state(0, k)))])
        pub.publish(InboxMessage(sender=0, kinds=["gossip"], offsets=good.offsets,
                                 data=good.data))                    # unknown kind
        pub.publish(InboxMessage(sender=0, kinds=good.kinds, offsets=[0, 3],
                                 data=good.data))                    # offsets cut wrong
        # Pieces that do not decode, each rejected as its kind: a truncated state, a
        # transfer whose bin count (at byte 36) claims 2^31 bins.
        transfer = bytearray(serialize_message(ParticleTransfer(
            header=convert.header(k, 0.5, "map"), from_id=0, to_id=1, step=k, kind=0,
            bin_indices=[1, 2], weights=[0.1, 0.2])))
        transfer[36:40] = struct.pack("<I", 2**31)
        pub.publish(inbox.pack(0, [("state", serialize_message(_state(0, k))[:20]),
                                   ("particles", bytes(transfer))]))
        # On the world's topic (a raw subscription, decoded by the robot): another robot's
        # set, a NaN sensor position, bytes that are not a measurement set.
        scans = evil.create_publisher(MeasurementSet, "/robot_1/measurements",
                                      publisher_qos("STEP"))
        ros.spin_until(lambda: scans.get_subscription_count() > 0, timeout=10.0)
        for robot_id, x in ((0, 1.0), (1, math.nan)):
            scans.publish(MeasurementSet(header=convert.header(k + 1, 0.5, "map"),
                                         robot_id=robot_id, step=k + 1,
                                         sensor_position=Point(x=x, y=1.0)))
        scans.publish(serialize_message(_state(0, k))[:6])
        assert ros.spin_until(lambda: monitor.done, timeout=120.0)
        assert dict(victim.rejections) == {"state": 6, "measurements": 4, "particles": 4,
                                           "envelope": 2}
        assert world.dead == set()
        assert len(monitor.series) == scenario.steps


@pytest.mark.ros
def test_duplicate_or_unknown_robot_id_refuses_to_start(tmp_path):
    from phd_swarm.nodes.robot import RobotNode
    from phd_swarm.nodes.ros_params import ParameterError
    from phd_swarm.testing import InProcessRos

    scenario = small_static_scenario(robots=3, steps=8)
    with InProcessRos(executor="events") as ros:
        start_swarm(ros, tmp_path, scenario)
        args = ["--ros-args", "--params-file", str(tmp_path / "params.yaml")]
        probe = ros.node("probe")
        ros.spin_until(lambda: probe.count_publishers("/robot_2/status") > 0, timeout=10.0)
        with pytest.raises(ParameterError, match="duplicate robot id 2"):
            RobotNode(context=ros.context, namespace="/robot_2", cli_args=args,
                      parameter_overrides=[Parameter("robot_id", value=2)])
        with pytest.raises(ParameterError, match="robot_id must be set to 0..2"):
            RobotNode(context=ros.context, namespace="/robot_7", cli_args=args,
                      parameter_overrides=[Parameter("robot_id", value=7)])
