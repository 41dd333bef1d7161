"""What a part publishes in its robot's namespace: the declared outputs of a system.

A robot node writes three topics whatever its system (``goal``, ``estimates`` and
``status``). Everything else a robot publishes belongs to one of its system's parts: the
grid PHD's density window, the Voronoi cell, a Gaussian mixture's components and tracks, a
reward set, a search map, a search-and-track agent's state and plan, the markers a viewer
draws. A part declares each of them as an :class:`Output` when it registers
(``register(..., outputs=(...))``, :mod:`phd_swarm.core.registry`), and the nodes, the
topic table, the log-completeness check and the generated docs read the declarations
(:func:`system_outputs`); none of them names a system.

How an output is built from the robot's parts at a step, and read back, is ROS business:
the declaration names its *face* as ``"module:NAME"``, a string, so the core stays free of
rclpy (:mod:`phd_swarm.nodes.face` loads it), the way an exchange names its wire.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

#: Topics every robot node writes itself, whatever its system (relative names).
NODE_OUTPUTS = ("goal", "status", "estimates")


@dataclass(frozen=True)
class Output:
    """One topic a part's robots publish, relative to the robot's namespace.

    Attributes
    ----------
    topic : str
        Relative topic name (``density``, ``components``...).
    type : str
        ROS message type, ``pkg/msg/Type``.
    face : str
        ``"module:NAME"`` of the :class:`phd_swarm.nodes.face.Face` that builds the message
        from the robot's parts at a step (and reads it back).
    description : str
        What the topic holds, for docs/topics.md.
    qos : str
        A profile name of :mod:`phd_swarm.nodes.qos`: ``STEP`` (one message per step, kept
        until acknowledged) or ``OBSERVATION`` (for viewers).
    observed : bool
        Every observer (the monitor and the recorder) reads it, and a robot starts its
        first step only once they all match it, so that no step of it is lost.
    """

    topic: str
    type: str
    face: str
    description: str
    qos: str = "STEP"
    observed: bool = False

    @property
    def per_step(self) -> bool:
        """Whether a complete log holds one message of it per step (a ``STEP`` topic)."""
        return self.qos == "STEP"

    def __post_init__(self) -> None:
        if not self.topic.isidentifier():
            raise ValueError(f"output topic must be a relative name (an identifier), got "
                             f"{self.topic!r}")
        if self.topic in NODE_OUTPUTS:
            raise ValueError(f"output {self.topic!r} is written by every robot node; a part "
                             f"cannot declare it")
        if self.type.count("/") != 2:
            raise ValueError(f"output {self.topic!r}: type must be pkg/msg/Type, got "
                             f"{self.type!r}")
        if ":" not in self.face:
            raise ValueError(f"output {self.topic!r}: face must be 'module:NAME', got "
                             f"{self.face!r}")


def system_outputs(parts: Mapping[str, Any], drop: Iterable[str] = ()) -> tuple[Output, ...]:
    """The outputs the parts of one system declare, in role order, without ``drop``.

    ``parts``: role -> :class:`~phd_swarm.core.registry.Part` (``SystemConfig.parts()``);
    ``drop``: topics switched off by the node's parameters (``publish_density``...).

    Raises
    ------
    ValueError
        If two parts declare the same topic (the message says which).
    """
    out: dict[str, tuple[str, Output]] = {}
    dropped = set(drop)
    for role, part in parts.items():
        for o in part.outputs:
            if o.topic in out:
                other = out[o.topic][0]
                raise ValueError(f"output {o.topic!r} is declared by {other} and by "
                                 f"{role} {part.name!r}; a topic has one writer")
            out[o.topic] = (f"{role} {part.name!r}", o)
    return tuple(o for _, o in out.values() if o.topic not in dropped)


def output_topics(parts: Mapping[str, Any], drop: Iterable[str] = (),
                  per_step: bool | None = None) -> tuple[str, ...]:
    """Every robot output topic of a system: the node's own, then the declared ones.

    With ``per_step`` True only the step topics (log completeness), False only the others.
    """
    declared = system_outputs(parts, drop)
    own = () if per_step is False else NODE_OUTPUTS
    return own + tuple(o.topic for o in declared
                       if per_step is None or o.per_step == per_step)


@dataclass(frozen=True)
class Observation:
    """How the observers score the team from its robots' outputs (declared by the estimator).

    The monitor scores each step live, and ``evaluate`` again from the log, the same way:
    per robot they wait for ``inputs`` (and the robot's ``estimates``, unless the team
    estimate is an image), then

    - with ``image`` set (a grid PHD, Dames Sec. IV): add the robots' windows on that topic
      into the team PHD image, extract the team estimate from it and score that (Dames eq.
      2, 12);
    - else: score the union of the robots' own estimates with the sum of their expected
      counts; and if the estimator has a ``figures`` hook and ``view`` is set, call the
      hook with one view per robot, built from its inputs by ``view``.

    Attributes
    ----------
    inputs : tuple of str
        Declared outputs read per robot and step.
    image : str
        The output whose windows make the team PHD image, or "" (union of estimates).
    view : str
        ``"module:NAME"`` of the ROS-side function that turns a robot's read inputs
        (topic -> value) into what the estimator's ``figures`` hook reads in place of the
        estimator, or "".
    meetings : str
        An input whose messages name the robots met at the step (``met_ids``), drawn by
        the monitor, or "".
    """

    inputs: tuple[str, ...] = ()
    image: str = ""
    view: str = ""
    meetings: str = ""

    def __post_init__(self) -> None:
        for name in (self.image, self.meetings):
            if name and name not in self.inputs:
                raise ValueError(f"observation: {name!r} is not one of its inputs "
                                 f"{list(self.inputs)}")
        if self.view and ":" not in self.view:
            raise ValueError(f"observation: view must be 'module:NAME', got {self.view!r}")
