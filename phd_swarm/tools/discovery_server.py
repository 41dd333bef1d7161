"""A Fast DDS discovery server on 127.0.0.1 or a host's address for one run (``run_swarm.sh``).

With simple discovery every participant announces itself and all its endpoints to every
other one: at 53 processes on 2 cores that is ~16,000 discovery datagrams a second on
loopback, the recorder's receive socket overflows, and start-up can stall for good
(docs/deployment.md, "Discovery for large teams"). With a server each process talks
discovery with the server only, and learns just the endpoints on its own topics.

``python -m phd_swarm.tools.discovery_server --profile FILE --port PORT``: ``FILE`` is
:func:`phd_swarm.tools.dds.server_profile` written out, and must also be the process's
``FASTRTPS_DEFAULT_PROFILES_FILE`` (:func:`phd_swarm.tools.dds.server_env`): Fast DDS reads
it when rclpy starts. It logs ``discovery server: listening on 127.0.0.1:PORT`` once up and
serves until SIGINT or SIGTERM.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

UP = "discovery server: listening on "


def main(argv: list[str] | None = None) -> int:
    """Serve discovery until SIGINT or SIGTERM; 2 if the environment is not the server's."""
    p = argparse.ArgumentParser(prog="python -m phd_swarm.tools.discovery_server",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--profile", required=True, type=Path, help="the server's Fast DDS profile")
    p.add_argument("--port", required=True, type=int, help="the port the profile listens on")
    p.add_argument("--address", default="127.0.0.1",
                   help="the address the profile listens on (default 127.0.0.1)")
    opts = p.parse_args(argv)
    for var in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
        if os.environ.get(var) != str(opts.profile):
            print(f"discovery server: {var} must be {opts.profile} (it is "
                  f"{os.environ.get(var)!r})", file=sys.stderr)
            return 2
    if not opts.profile.is_file():
        print(f"discovery server: no profile at {opts.profile}", file=sys.stderr)
        return 2
    if os.environ.get("ROS_DISCOVERY_SERVER"):
        print("discovery server: ROS_DISCOVERY_SERVER is set; the server must not be a client",
              file=sys.stderr)
        return 2

    import rclpy
    from rclpy.executors import ExternalShutdownException

    signal.signal(signal.SIGTERM, lambda *_: rclpy.try_shutdown())
    rclpy.init()
    node = rclpy.create_node("discovery_server")
    node.get_logger().info(f"{UP}{opts.address}:{opts.port}")
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
