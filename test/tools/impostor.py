"""A stranger on a run's ROS domain speaking as its robots and its world (issue 40's test).

``python test/tools/impostor.py ROBOTS [--rate HZ]``: floods every robot's inbox with
envelopes claiming to come from another robot (a state of a step ahead, unsigned or under a
key of its own) and every robot's measurement topic with measurement sets claiming to be
the world's (targets nobody has, steps ahead), until stopped. Prints ``impostor: up`` once
its writers are made and ``impostor: N forged`` every second.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time

import numpy as np
import rclpy
from geometry_msgs.msg import Point
from rclpy.serialization import serialize_message

from phd_swarm.nodes import convert, inbox
from phd_swarm.nodes.qos import publisher_qos
from phd_swarm_msgs.msg import InboxMessage, MeasurementSet, RobotState


def main() -> int:
    """Flood until SIGTERM / SIGINT."""
    p = argparse.ArgumentParser()
    p.add_argument("robots", type=int)
    p.add_argument("--rate", type=float, default=200.0, help="forgeries per second, in all")
    opts = p.parse_args()
    rclpy.init()
    node = rclpy.create_node("impostor")
    inboxes = [node.create_publisher(InboxMessage, f"/robot_{r}/inbox", publisher_qos("INBOX"))
               for r in range(opts.robots)]
    scans = [node.create_publisher(MeasurementSet, f"/robot_{r}/measurements",
                                   publisher_qos("STEP")) for r in range(opts.robots)]
    own_key = os.urandom(32)
    print("impostor: up", flush=True)
    sent, last = 0, time.monotonic()
    try:
        for n in itertools.count():
            r, step = n % opts.robots, 1 + (n // opts.robots) % 400
            sender = (r + 1) % opts.robots
            key = own_key if n % 2 else None
            state = serialize_message(RobotState(
                header=convert.header(step, 0.5, "map"), robot_id=sender, step=step,
                position=Point(x=1.0, y=1.0), power_weight=0.0, cell_radius=1.0))
            inboxes[r].publish(inbox.pack_cdr(sender, [("state", state)], key))
            scans[r].publish(convert.encode_scan(step, 0.5, "map", r, np.array([5.0, 5.0]),
                                                 np.array([[6.0, 6.0], [7.0, 7.0]]), key))
            sent += 2
            rclpy.spin_once(node, timeout_sec=0.0)
            time.sleep(2.0 / opts.rate)
            if time.monotonic() - last >= 1.0:
                print(f"impostor: {sent} forged", flush=True)
                last = time.monotonic()
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
