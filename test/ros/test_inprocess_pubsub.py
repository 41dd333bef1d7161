"""A publisher and a subscriber in one process exchange a measurement set; graph API."""

from __future__ import annotations

import pytest
from geometry_msgs.msg import Point

from phd_swarm.nodes import qos
from phd_swarm_msgs.msg import MeasurementSet

pytestmark = pytest.mark.ros


def _scan(step: int) -> MeasurementSet:
    msg = MeasurementSet(robot_id=3, step=step, sensor_position=Point(x=10.0, y=20.0))
    msg.header.frame_id = "map"
    msg.measurements = [Point(x=10.5, y=19.25), Point(x=12.0, y=21.0)]
    return msg


def test_measurement_set_travels_between_nodes_in_one_process(ros):
    talker = ros.node("talker", namespace="robot_3")
    listener = ros.node("listener")
    got: list[MeasurementSet] = []
    listener.create_subscription(MeasurementSet, "/robot_3/measurements", got.append,
                                 qos.PROTOCOL)
    pub = talker.create_publisher(MeasurementSet, "measurements", qos.PROTOCOL)

    assert ros.spin_until(lambda: pub.get_subscription_count() > 0, timeout=10.0)
    sent = _scan(step=5)
    pub.publish(sent)
    assert ros.spin_until(lambda: len(got) == 1, timeout=10.0), "nothing arrived in 10 s"
    assert got[0] == sent


def test_graph_api_lists_topic_name_and_type(ros):
    node = ros.node("robot", namespace="robot_0")
    node.create_publisher(MeasurementSet, "measurements", qos.PROTOCOL)
    observer = ros.node("observer")

    def listed() -> bool:
        return ("/robot_0/measurements", ["phd_swarm_msgs/msg/MeasurementSet"]) in \
            observer.get_topic_names_and_types()

    assert ros.spin_until(listed, timeout=10.0)
    infos = observer.get_publishers_info_by_topic("/robot_0/measurements")
    assert [i.node_name for i in infos] == ["robot"]
    assert infos[0].qos_profile.reliability == qos.PROTOCOL.reliability


def test_contexts_are_private_and_on_loopback(ros):
    import os

    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert ros.context.get_domain_id() == ros.domain_id
    assert 120 <= ros.domain_id < 220
