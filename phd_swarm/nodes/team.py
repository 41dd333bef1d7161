"""Many robot nodes in one process (one DDS participant): for large teams on small machines.

``python -m phd_swarm.nodes.team --ids 0-9 --ros-args --params-file CONFIG`` runs robots
0..9, each a :class:`~phd_swarm.nodes.robot.RobotNode` in its own namespace
``/robot_<id>``, exactly as separate processes would (same topics, same messages), on one
executor. One process per robot stays the deployment model (DESIGN.md).
"""

from __future__ import annotations

import argparse
import sys

from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from phd_swarm.nodes import topics as T


def parse_ids(text: str) -> list[int]:
    """``"0-3,7"`` -> ``[0, 1, 2, 3, 7]``; ValueError naming the bad part."""
    ids: list[int] = []
    for part in text.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            ids.extend(range(int(lo), int(hi) + 1) if sep else [int(lo)])
        except ValueError:
            raise ValueError(f"--ids: {part!r} is not an id or a range a-b") from None
    if len(set(ids)) != len(ids) or any(i < 0 for i in ids):
        raise ValueError(f"--ids: ids must be distinct and >= 0, got {text!r}")
    return ids


def main(args: list[str] | None = None) -> int:
    """Run the robots given by ``--ids`` in this process."""
    from phd_swarm.nodes.robot import RobotNode
    from phd_swarm.nodes.spin import spin_nodes

    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(prog="python -m phd_swarm.nodes.team",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--ids", required=True, help="robot ids, e.g. 0-9 or 0,2,5-7")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    try:
        ids = parse_ids(opts.ids)
    except ValueError as exc:
        parser.error(str(exc))

    def factory():
        return [RobotNode(namespace=T.robot_namespace(i),
                          parameter_overrides=[Parameter("robot_id", value=i)])
                for i in ids]

    return spin_nodes(factory, argv)


if __name__ == "__main__":
    sys.exit(main())
