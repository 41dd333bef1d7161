"""One participant of the discovery benchmark (bench/discovery.py); not for direct use.

Usage: ``python bench/discovery_peer.py INDEX DURATION_S [STOP_FILE]``. Creates a node with a
publisher and a subscription on ``/phd_swarm_discovery`` and prints, every 0.5 s, one JSON
line ``{"t": <unix time>, "publishers": <publishers of the topic this process sees>}`` until
DURATION_S has passed or STOP_FILE exists (checked every 0.1 s), then exits 0. The parent
stops peers early through the file, not a signal: a SIGINT's KeyboardInterrupt can land
between a lock's acquire and release inside the executor, and the ``shutdown`` that
follows then waits on that lock for ever (a 9-of-10 exit seen once under load). SIGINT
still stops a peer started by hand. The environment
(domain, discovery range, Fast DDS profile, discovery server) is the parent's.
"""

from __future__ import annotations

import faulthandler
import json
import signal
import sys
import time
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from std_msgs.msg import Empty

TOPIC = "/phd_swarm_discovery"


def main(index: int, duration: float, stop: Path | None = None) -> int:
    """Run the peer for ``duration`` seconds or until ``stop`` exists, reporting what it sees."""
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
        while time.time() < end and not (stop is not None and stop.exists()):
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
    sys.exit(main(int(sys.argv[1]), float(sys.argv[2]),
                  Path(sys.argv[3]) if len(sys.argv) > 3 else None))
