"""A sixth system from outside the package: last sightings, shared by beacon, random waypoints.

A complete small system (docs/architecture.md, "Adding a system") whose parts are all in
this file, registered when ``scenario.system.plugins`` lists it, with no edit to the robot
node, the engines, the sweep runner or the docs generator:

- sensor: the built-in ``disk`` (position measurements in a disk field of view);
- estimator ``last_seen`` (:class:`LastSeen`): the robot's estimates are the detections of
  the last ``memory_steps`` steps, points within ``merge_radius`` of a younger one merged
  into it; not a PHD filter, a memory of sightings (no motion model, no clutter model);
- exchange ``beacon`` (:class:`Beacon`): each step a robot sends its estimates, with their
  ages, to every robot within ``beacon_range`` metres, and merges what it receives, in
  robot-id order;
- controller ``waypoint`` (:class:`Waypoint`): each robot heads for a waypoint drawn
  uniformly on the map with its own generator, and draws the next once within
  :data:`REACH` of it.

It also publishes a topic no built-in system does: ``detections``, the robot's estimates as
a ``geometry_msgs/PoseArray`` for RViz. Its ROS side (that output's face, and the wire
that carries a beacon in the inbox as a ``phd_swarm_msgs/TargetSet``) is in
``ros_faces.py`` next to this file, named here by its path, so this module stays free of
rclpy: the in-memory engines and the sweeps run the system without ROS.

Run it with ``scripts/run_swarm.sh examples/sixth_system/sixth.yaml`` and
``scripts/sweep.sh examples/sixth_system/sixth_sweep.yaml``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from phd_swarm.core import registry
from phd_swarm.core.controllers.base import Controller, Decision, Knowledge
from phd_swarm.core.estimators.base import Estimator
from phd_swarm.core.exchange.contacts import TIMEOUT_TICKS, ContactExchange
from phd_swarm.core.exchange.radio import RangeRadio
from phd_swarm.core.outputs import Output
from phd_swarm.core.params import ParamSpec
from phd_swarm.core.scan import CDR_HEADER, CDR_POINT, Scan

#: The ROS side of these parts (faces and wire), named by file: a plugin is not a package.
ROS_FACES = Path(__file__).with_name("ros_faces.py")

#: Distance to its waypoint at which a robot draws the next [m].
REACH = 1.0

ESTIMATOR_OPTIONS = (
    ParamSpec("memory_steps", 10, "last_seen: steps a sighting is kept (1: only the current "
                                  "scan's)", low=1),
    ParamSpec("merge_radius", 1.5, "last_seen: points within this distance of a younger one "
                                   "are merged into it [m]", low=0.0),
)
EXCHANGE_OPTIONS = (
    ParamSpec("beacon_range", 30.0, "beacon: radio range; robots within it exchange their "
                                    "estimates every step [m]", low=0.0),
)

#: The estimates as poses, for RViz (the output no built-in system has).
DETECTIONS = Output("detections", "geometry_msgs/msg/PoseArray", f"{ROS_FACES}:DETECTIONS",
                    "The robot's remembered sightings as poses (identity orientation), for "
                    "RViz (example plugin examples/sixth_system, estimator last_seen).",
                    qos="STEP")


# ------------------------------------------------------------------------------ estimator
def merge_points(points: np.ndarray, ages: np.ndarray, radius: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Merge points within ``radius`` of each other into the youngest.

    Candidates are taken youngest first (equal ages: in the given order); each one kept
    absorbs every later candidate within ``radius`` (distance <= radius) of it, so a
    sighting is replaced by a fresher one of the same target. Deterministic.

    Parameters
    ----------
    points : np.ndarray, shape (N, 2)
        Candidate positions [m].
    ages : np.ndarray of int, shape (N,)
        Steps since each was seen.
    radius : float
        Merge distance [m].

    Returns
    -------
    points : np.ndarray, shape (K, 2)
    ages : np.ndarray of int64, shape (K,)
        The kept candidates, youngest first.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    ages = np.asarray(ages, dtype=np.int64).reshape(-1)
    order = np.argsort(ages, kind="stable")
    points, ages = points[order], ages[order]
    diff = points[:, None, :] - points[None, :, :]
    close = np.einsum("ijk,ijk->ij", diff, diff) <= radius * radius
    keep = np.ones(len(points), dtype=bool)
    # Greedy suppression: whether candidate i survives depends on the ones before it.
    for i in range(len(points)):
        if keep[i]:
            keep[i + 1:] &= ~close[i, i + 1:]
    return points[keep], ages[keep]


class LastSeen(Estimator):
    """A robot's memory of recent sightings: its estimates are the detections it keeps.

    One step: :meth:`predict` ages every point by one step and forgets those
    ``memory_steps`` old; :meth:`update` adds the scan's measurements (age 0) and merges
    (:func:`merge_points`). :meth:`shared` and :meth:`merge` are what the ``beacon``
    exchange sends and receives: points travel with their ages, so a sighting is forgotten
    ``memory_steps`` after it was made whichever robots pass it on.

    Parameters
    ----------
    memory_steps : int
        Steps a sighting is kept (>= 1).
    merge_radius : float
        Merge distance [m].
    """

    def __init__(self, memory_steps: int, merge_radius: float) -> None:
        self.memory_steps = int(memory_steps)
        self.merge_radius = float(merge_radius)
        self.points = np.empty((0, 2))
        self.ages = np.empty(0, dtype=np.int64)

    def predict(self) -> None:
        """One step older; sightings ``memory_steps`` old are forgotten."""
        ages = self.ages + 1
        kept = ages < self.memory_steps
        self.points, self.ages = self.points[kept], ages[kept]

    def update(self, scan: Scan) -> None:
        """Add the scan's measurements (age 0) and merge them with what is kept."""
        self._merge([scan.z, self.points], [np.zeros(len(scan.z), dtype=np.int64), self.ages])

    def estimates(self) -> np.ndarray:
        """The kept points, shape (N, 2) [m], youngest first."""
        return self.points.copy()

    def expected_count(self) -> float:
        """The number of kept points."""
        return float(len(self.points))

    def shared(self) -> tuple[np.ndarray, np.ndarray]:
        """What the robot tells others: its points (N, 2) [m] and their ages (N,)."""
        return self.points.copy(), self.ages.copy()

    def merge(self, others: Mapping[int, tuple[np.ndarray, np.ndarray]]) -> None:
        """Merge other robots' (points, ages), in robot-id order, after the own points.

        Points as old as ``memory_steps`` or older are left out. The order makes the result
        the same whatever order the messages came in.
        """
        points, ages = [self.points], [self.ages]
        for rid in sorted(others):
            p, a = others[rid]
            a = np.asarray(a, dtype=np.int64).reshape(-1)
            fresh = a < self.memory_steps
            points.append(np.asarray(p, dtype=float).reshape(-1, 2)[fresh])
            ages.append(a[fresh])
        self._merge(points, ages)

    def _merge(self, points: list[np.ndarray], ages: list[np.ndarray]) -> None:
        self.points, self.ages = merge_points(np.concatenate(points), np.concatenate(ages),
                                              self.merge_radius)


def _estimator_setup(scenario: Any, system: Any, **runtime: Any) -> tuple[int, float]:
    return int(system.option("memory_steps")), float(system.option("merge_radius"))


# ------------------------------------------------------------------------------- exchange
@dataclass(frozen=True, eq=False)
class BeaconMsg:
    """Robot ``src``'s estimates at step ``step``: points (N, 2) [m] and ages (N,) [steps]."""

    src: int
    step: int
    points: np.ndarray
    ages: np.ndarray

    #: Its ``msg_defs`` type (for the engines' traffic counts).
    WIRE_TYPE = "TargetSet"

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]: header, ids, ages, points, expected count."""
        n = len(self.points)
        return CDR_HEADER + 4 + 4 + 4 + 4 * n + 4 + CDR_POINT * n + 8


class Beacon(ContactExchange):
    """Every step, send the estimates to the robots in range and merge theirs.

    The step machinery is :class:`~phd_swarm.core.exchange.contacts.ContactExchange`'s: one
    :class:`BeaconMsg` per robot the radio reaches, and the estimator merges the contacts'
    messages once all are in (or given up on), in robot-id order, so that the ROS run
    equals the in-memory one.

    Parameters
    ----------
    robot_id : int
    radio : RangeRadio
        Who this robot reaches at a step.
    timeout_ticks : int
        Rounds without news before the missing contacts are given up for the step.
    """

    MESSAGE = BeaconMsg
    NAME = "beacon"

    def __init__(self, robot_id: int, radio: RangeRadio,
                 timeout_ticks: int = TIMEOUT_TICKS) -> None:
        super().__init__(robot_id, radio, timeout_ticks)
        self._points = np.empty((0, 2))
        self._ages = np.empty(0, dtype=np.int64)

    def bind_estimator(self, estimator: Any) -> None:
        """The robot's estimator, whose points travel (``shared``, ``merge``)."""
        if not hasattr(estimator, "shared") or not hasattr(estimator, "merge"):
            raise ValueError(f"the beacon exchange needs an estimator with shared() and "
                             f"merge(); {type(estimator).__name__} has neither")
        self.estimator = estimator

    def _begin(self, position: np.ndarray) -> None:
        self._points, self._ages = self.estimator.shared()

    def _message(self, contact: int) -> BeaconMsg:
        return BeaconMsg(self.robot_id, self._step, self._points, self._ages)

    def _complete(self, got: dict[int, BeaconMsg]) -> None:
        if got:
            self.estimator.merge({src: (m.points, m.ages) for src, m in got.items()})


def _exchange_setup(scenario: Any, system: Any, timeout_ticks: int = TIMEOUT_TICKS,
                    **runtime: Any) -> tuple[RangeRadio, int]:
    return RangeRadio(float(system.option("beacon_range"))), int(timeout_ticks)


# ----------------------------------------------------------------------------- controller
class Waypoint(Controller):
    """Head for a random waypoint on the map; draw the next within :data:`REACH` of it.

    Parameters
    ----------
    low, high : np.ndarray, shape (2,)
        The map's corners (xmin, ymin) and (xmax, ymax) [m]; waypoints are uniform between.
    """

    def __init__(self, low: np.ndarray, high: np.ndarray) -> None:
        self.low = np.asarray(low, dtype=float)
        self.high = np.asarray(high, dtype=float)
        self.waypoint: np.ndarray | None = None

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """The current waypoint, or a new one drawn from ``rng`` once it is reached.

        Power weight 0: there is no partition.
        """
        position = np.asarray(knowledge.position, dtype=float)
        if self.waypoint is None or np.hypot(*(self.waypoint - position)) <= REACH:
            self.waypoint = rng.uniform(self.low, self.high)
        return Decision(goal=self.waypoint.copy(), power_weight=0.0)

    def planned_path(self) -> np.ndarray:
        """The waypoint, shape (1, 2) [m] (none before the first decision)."""
        return np.empty((0, 2)) if self.waypoint is None else self.waypoint.reshape(1, 2)


def _controller_setup(scenario: Any, system: Any, **runtime: Any
                      ) -> tuple[np.ndarray, np.ndarray]:
    env = scenario.env
    return np.array([env.xmin, env.ymin]), np.array([env.xmax, env.ymax])


# ---------------------------------------------------------------------------- registration
registry.register(
    "estimator", "last_seen", lambda setup, rid: LastSeen(*setup), setup=_estimator_setup,
    options=ESTIMATOR_OPTIONS, provides=("shared_estimates",),
    requires=("position_measurement",), outputs=(DETECTIONS,),
    description="The detections of the last memory_steps steps, merged within "
                "merge_radius (example plugin examples/sixth_system).")
registry.register(
    "exchange", "beacon", lambda setup, rid: Beacon(rid, *setup), setup=_exchange_setup,
    options=EXCHANGE_OPTIONS, requires=("shared_estimates",),
    wire=f"{ROS_FACES}:WIRE",
    description="Every step each robot sends its estimates to the robots within "
                "beacon_range and merges theirs (example plugin examples/sixth_system).")
registry.register(
    "controller", "waypoint", lambda setup, rid: Waypoint(*setup), setup=_controller_setup,
    description="Random waypoints on the map, drawn with the robot's generator (example "
                "plugin examples/sixth_system).")
