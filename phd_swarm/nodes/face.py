"""The ROS side of a part's declared outputs: how a robot builds each message at a step.

A part declares what its robots publish as :class:`phd_swarm.core.outputs.Output` (topic,
type, QoS, description) and names the output's *face*, ``"module:NAME"``: a :class:`Face`
that builds the ROS message from the robot's parts once the step is done. The built-in
parts' faces live in :mod:`phd_swarm.nodes.faces`, one module per part or family; a plugin
brings its own, named by its file (``"/path/to/ros_faces.py:NAME"``, :func:`load_named`).
The robot node (:mod:`phd_swarm.nodes.robot_outputs`) loads the faces of its system with
:func:`load_face` and publishes what they build, in the declared order, without knowing
whose they are.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np

from phd_swarm.core.outputs import Output
from phd_swarm.core.registry import import_file
from phd_swarm.nodes import convert


@dataclass
class Step:
    """What a face builds a step's message from.

    Attributes
    ----------
    agent : phd_swarm.core.agent.Agent
        The robot's agent after step ``k`` (estimator, exchange, controller, position).
    k : int
        The step.
    decision : phd_swarm.core.controllers.base.Decision
        The controller's decision of the step.
    points : np.ndarray, shape (N, 2)
        The robot's estimates of the step [m] (what it publishes on ``estimates``).
    dt : float
        The scenario's time step [s] (stamps are k dt).
    frame_id : str
        The world frame.
    options : dict
        Node parameters a face may read (``publish_density``...).
    cache : dict
        Shared between the faces of one step (a conversion two faces need is made once).
    """

    agent: Any
    k: int
    decision: Any
    points: np.ndarray
    dt: float
    frame_id: str
    options: dict[str, Any] = field(default_factory=dict)
    cache: dict[str, Any] = field(default_factory=dict)

    @property
    def robot_id(self) -> int:
        """The robot's id."""
        return self.agent.robot_id

    def header(self) -> Any:
        """The step's ``std_msgs/Header`` (stamp k dt, the world frame)."""
        return convert.header(self.k, self.dt, self.frame_id)

    def stamp(self) -> Any:
        """The step's stamp (k dt)."""
        return convert.stamp(self.k, self.dt)

    def provides(self, role: str, capability: str) -> bool:
        """Whether the system's ``role`` part provides ``capability``."""
        return capability in self.agent.team.parts[role].provides


@dataclass(frozen=True)
class Face:
    """How one output becomes a ROS message.

    Attributes
    ----------
    msg_type : type
        The ROS message class (must be the declared ``Output.type``).
    build : callable
        ``build(step: Step, memo: dict)`` -> the message of the step; ``memo`` is the
        face's own, kept per robot from step to step (e.g. the track ids a marker array
        showed last, to delete those gone).
    read : callable, optional
        ``read(msg)`` -> the checked value an observer takes from a received message
        (:class:`~phd_swarm.core.outputs.Observation`); raises
        :class:`~phd_swarm.nodes.convert.InvalidMessage` naming the field. None: the
        message itself.
    """

    msg_type: type
    build: Callable[[Step, dict[str, Any]], Any]
    read: Callable[[Any], Any] | None = None


def ros_type_name(msg_type: type) -> str:
    """``pkg/msg/Type`` of a ROS message class."""
    return f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"


@cache
def _load(spec: str) -> Face:
    face = load_named(spec, "face")
    if not isinstance(face, Face):
        raise ValueError(f"face {spec!r} is a {type(face).__name__}, not a Face")
    return face


def load_named(spec: str, what: str) -> Any:
    """The object ``"module:NAME"`` names (a face, a wire, a view builder...).

    The module part is a module name (``phd_swarm.nodes.faces.grid_phd:DENSITY``) or the
    path of a ``.py`` file (``/path/to/ros_faces.py:DETECTIONS``): a plugin's parts are a
    file, not an importable module, so a file is imported once under the name derived from
    its absolute path (:func:`phd_swarm.core.registry.import_file`), the same module its
    other names and a plugin list load.

    Raises
    ------
    ValueError
        Naming ``what``, if the module, the file or the name does not exist.
    """
    module, _, name = spec.rpartition(":")
    try:
        loaded = (import_file(module) if module.endswith(".py")
                  else importlib.import_module(module))
        return getattr(loaded, name)
    except (ImportError, AttributeError, OSError) as exc:
        raise ValueError(f"{what} {spec!r} cannot be loaded: {type(exc).__name__}: {exc}") \
            from None


def load_face(output: Output) -> Face:
    """The face an output names, checked against the declared type.

    Raises
    ------
    ValueError
        If the module or name does not exist, is no :class:`Face`, or builds another type.
    """
    face = _load(output.face)
    if ros_type_name(face.msg_type) != output.type:
        raise ValueError(f"output {output.topic!r} is declared as {output.type} but its face "
                         f"{output.face!r} builds {ros_type_name(face.msg_type)}")
    return face
