"""What the observers read of a robot's step, and how they join the team's, by declaration.

The live monitor (:mod:`phd_swarm.nodes.monitor`) and the log readers
(:mod:`phd_swarm.tools.run_log`, ``evaluate``) score a step from the robots' outputs the
same way, the way the estimator part declares it (its
:class:`~phd_swarm.core.outputs.Observation`). :class:`TeamReader` holds that declaration
with the faces it needs:

- which topics a robot's step is made of (:attr:`TeamReader.inputs`) and their types;
- how each received message is checked and read (:meth:`TeamReader.read`: the face's
  ``read``, or for ``estimates`` the positions and the expected count);
- the team estimate: the robots' windows added into the team PHD image
  (:func:`add_windows`, in robot-id order, exact in float64 since each bin has one owner),
  or the union of the robots' estimates with the sum of their expected counts
  (:func:`union`);
- the views the estimator's ``figures`` hook reads, one per robot (:meth:`TeamReader.views`).

Nothing here names a system: a new estimator's observers follow from its declaration.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from phd_swarm.core.geometry.grid import Grid
from phd_swarm.core.outputs import system_outputs
from phd_swarm.nodes import convert
from phd_swarm.nodes.face import load_face, load_named
from phd_swarm_msgs.msg import TargetSet

#: A robot's estimates: its own topic, whatever the system.
ESTIMATES = "estimates"


def read_estimates(msg: TargetSet) -> tuple[np.ndarray, float]:
    """A robot's ``estimates``: positions (N, 2) [m] and expected count, checked."""
    return (convert.target_positions(msg),
            convert.finite(msg.expected_cardinality, "expected_cardinality", low=0.0))


class TeamReader:
    """How observers read the robots of a ``system`` (see the module docstring).

    Attributes
    ----------
    image : str
        The topic of the windows that make the team PHD image, or "" (union of estimates).
    inputs : tuple of str
        The topics a robot's step is made of (relative names).
    types : dict of str to type
        Their ROS message classes.
    figures : callable or None
        The estimator's ``figures`` hook, when the observers compute it (not for an image).
    meetings : str
        The input whose ``met_ids`` name the robots met at the step, or "".
    """

    def __init__(self, system: Any) -> None:
        parts = system.parts()
        obs = parts["estimator"].observation
        declared = {o.topic: o for o in system_outputs(parts)}
        faces = {t: load_face(declared[t]) for t in obs.inputs}
        self.image = obs.image
        self.inputs = obs.inputs if obs.image else (ESTIMATES, *obs.inputs)
        self.types: dict[str, type] = {ESTIMATES: TargetSet,
                                       **{t: f.msg_type for t, f in faces.items()}}
        self._readers: dict[str, Callable[[Any], Any]] = {
            ESTIMATES: read_estimates,
            **{t: f.read or (lambda msg: msg) for t, f in faces.items()}}
        self.figures = None if obs.image else parts["estimator"].figures
        self._view = (load_named(obs.view, "observation view")
                      if obs.view and self.figures is not None else None)
        self.meetings = obs.meetings

    def read(self, topic: str, msg: Any) -> Any:
        """A received message of ``topic`` checked and read; InvalidMessage naming the field."""
        return self._readers[topic](msg)

    def read_robot(self, got: Mapping[str, Any]) -> dict[str, Any]:
        """Every input message of one robot's step, read (InvalidMessage on the first bad)."""
        return {t: self.read(t, got[t]) for t in self.inputs}

    def views(self, robots: Mapping[int, Mapping[str, Any]]) -> list[Any]:
        """What the ``figures`` hook reads of each robot (read inputs), in robot-id order.

        Empty when the estimator declares no view.
        """
        if self._view is None:
            return []
        return [self._view(robots[r]) for r in sorted(robots)]


def add_windows(grid: Grid, windows: Mapping[int, Any],
                on_error: Callable[[int, convert.InvalidMessage], None]) -> np.ndarray:
    """The team PHD image (ny, nx): the robots' windows added in robot-id order.

    A window that does not fit the grid is left out and passed to ``on_error(robot, exc)``.
    """
    image = np.zeros(grid.shape)
    for rid in sorted(windows):
        try:
            convert.add_density(image, windows[rid], grid)
        except convert.InvalidMessage as exc:
            on_error(rid, exc)
    return image


def union(robots: Mapping[int, Mapping[str, Any]]) -> tuple[np.ndarray, float]:
    """The robots' estimates joined in robot-id order (K, 2), and their expected counts.

    The counts are summed in the same order (the monitor's numbers bit for bit).
    """
    points, expected = [], 0.0
    for rid in sorted(robots):
        positions, count = robots[rid][ESTIMATES]
        points.append(positions)
        expected += count
    return (np.concatenate(points) if points else np.empty((0, 2))), expected
