"""The ROS side of the sixth system (``parts.py``): the beacon's wire and the detections' face.

``parts.py`` names both by this file's path (``"/path/ros_faces.py:WIRE"``), and the robot
node loads them with :func:`phd_swarm.nodes.face.load_named`, so the parts stay free of
rclpy and neither file is a package:

- :data:`WIRE`: a beacon (:class:`BeaconMsg`) travels in the receiver's inbox as a
  ``phd_swarm_msgs/TargetSet`` of kind ``beacon``: ``source_id`` and ``step`` the
  sender's, ``positions`` its estimates, ``ids`` the age of each in steps (the
  step-by-step memory the receiver needs to forget it in time), ``expected_cardinality``
  their number;
- :data:`DETECTIONS`: the ``detections`` output, the robot's estimates at the end of a
  step as a ``geometry_msgs/PoseArray`` (identity orientations) stamped k dt in the world
  frame, for RViz; read back as the positions (N, 2).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from geometry_msgs.msg import Point, Pose, PoseArray, Quaternion

from phd_swarm.core.registry import import_file
from phd_swarm.nodes.convert import InvalidMessage, target_set, xy
from phd_swarm.nodes.face import Face, Step
from phd_swarm.nodes.wire import Wire
from phd_swarm_msgs.msg import TargetSet

#: The parts, imported once under the name the plugin list gives them (one BeaconMsg class).
parts = import_file(Path(__file__).with_name("parts.py"))
BeaconMsg = parts.BeaconMsg

#: Most points a beacon may carry (bigger ones are refused).
MAX_POINTS = 100_000


def _to_ros(msg: BeaconMsg, dt: float, frame_id: str) -> TargetSet:
    return target_set(msg.src, msg.step, msg.ages, msg.points, len(msg.points), dt, frame_id)


def _from_ros(msg: TargetSet, grid, max_measurements: int) -> BeaconMsg:
    if len(msg.positions) > MAX_POINTS:
        raise InvalidMessage(f"positions: {len(msg.positions)} points, more than {MAX_POINTS}")
    positions = xy(msg.positions, "positions")
    ages = np.array(msg.ids, dtype=np.int64)
    if len(ages) != len(positions):
        raise InvalidMessage(f"ids: {len(ages)} ages for {len(positions)} positions")
    return BeaconMsg(int(msg.source_id), int(msg.step), positions, ages)


#: The ``beacon`` exchange's messages on ROS: kind ``beacon``, a TargetSet each.
WIRE = Wire(types={"beacon": TargetSet}, kind=lambda msg: "beacon", to_ros=_to_ros,
            from_ros=_from_ros, sender=lambda msg: msg.src, addressee=lambda msg: None)


def _detections(step: Step, memo: dict) -> PoseArray:
    identity = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    return PoseArray(header=step.header(),
                     poses=[Pose(position=Point(x=float(x), y=float(y)), orientation=identity)
                            for x, y in step.points])


def _read_detections(msg: PoseArray) -> np.ndarray:
    return xy([p.position for p in msg.poses], "poses")


#: Output ``detections``: the robot's estimates as poses; read back as positions (N, 2).
DETECTIONS = Face(PoseArray, _detections, read=_read_detections)
