"""Child process for test_two_processes.

``pub`` publishes measurement sets until stopped; ``sub`` prints the first one it receives
as ``GOT robot_id step n`` and exits 0.
"""

from __future__ import annotations

import sys

import rclpy
from geometry_msgs.msg import Point
from rclpy.executors import ExternalShutdownException

from phd_swarm.nodes import qos
from phd_swarm_msgs.msg import MeasurementSet


def main(role: str) -> int:
    rclpy.init()
    node = rclpy.create_node(f"loopback_{role}")
    try:
        if role == "pub":
            pub = node.create_publisher(MeasurementSet, "/robot_9/measurements", qos.PROTOCOL)
            count = [0]

            def tick() -> None:
                count[0] += 1
                pub.publish(MeasurementSet(robot_id=9, step=count[0],
                                           measurements=[Point(x=1.5, y=2.5)]))

            node.create_timer(0.05, tick)
            print("READY", flush=True)
            rclpy.spin(node)
            return 0
        got: list[MeasurementSet] = []
        node.create_subscription(MeasurementSet, "/robot_9/measurements", got.append,
                                 qos.PROTOCOL)
        print("READY", flush=True)
        while rclpy.ok() and not got:
            rclpy.spin_once(node, timeout_sec=0.1)
        msg = got[0]
        print(f"GOT {msg.robot_id} {msg.step} {len(msg.measurements)}", flush=True)
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
