"""One participant of the discovery benchmark (bench/discovery.py); not for direct use.

Usage: ``python bench/discovery_peer.py INDEX DURATION_S``. Creates a node with a publisher
and a subscription on ``/phd_swarm_discovery`` and prints, every 0.5 s, one JSON line
``{"t": <unix time>, "publishers": <publishers of the topic this process sees>}`` until
DURATION_S has passed or it is interrupted (SIGINT), then exits 0. The environment
(domain, discovery range, Fast DDS profile, discovery server) is the parent's.
"""

from __future__ import annotations

import faulthandler
import json
import signal
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from std_msgs.msg import Empty

TOPIC = "/phd_swarm_discovery"


def main(index: int, duration: float) -> int:
    """Run the peer for ``duration`` seconds, reporting what it sees."""
    # The parent asks a peer that does not exit for its stack (bench/discovery.py).
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    rclpy.init()
    node = rclpy.create_node(f"discovery_peer_{index}")
    node.create_publisher(Empty, TOPIC, 10)
    node.create_subscription(Empty, TOPIC, lambda _msg: None, 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    end = time.time() + duration
    next_report = time.time()
    try:
        while time.time() < end:
            executor.spin_once(timeout_sec=0.1)
            if time.time() >= next_report:
                print(json.dumps({"t": time.time(),
                                  "publishers": node.count_publishers(TOPIC)}), flush=True)
                next_report += 0.5
    except (KeyboardInterrupt, ExternalShutdownException):
        pass                                                     # stopped by the parent
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]), float(sys.argv[2])))
