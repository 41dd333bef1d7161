"""What a robot node publishes when it finishes a step: its own topics and its parts' outputs.

Every robot writes ``estimates`` and ``goal`` (and the node its ``status``, last). The rest
is what the system's parts declare (:mod:`phd_swarm.core.outputs`): each declared
:class:`~phd_swarm.core.outputs.Output` is built by the face it names
(:mod:`phd_swarm.nodes.face`), in the declared order (estimator, exchange, controller). The
node parameters ``publish_density`` and ``publish_markers`` switch off the ``density`` and
``markers`` outputs where a system has them. docs/topics.md lists every declared output
with its part.

The step's messages go to the observers as one bundle on ``/team/outputs``
(:mod:`phd_swarm.nodes.bundle`), each under its topic name in the robot's namespace, and
to that topic itself, with its QoS, whenever a reader is matched there (a person or a
viewer watching the robot).

The estimates are the estimator's own (``estimates()``), or, for an estimator whose PHD
the exchange keeps on the robot's owned bins (capability ``grid_density``), those of the
owned bins. :meth:`RobotOutputs.status_fields` gives what the status reports of the step
(bins owned, PHD mass, dead peers).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.serialization import serialize_message

from phd_swarm.core.agent import Agent
from phd_swarm.core.controllers.base import Decision
from phd_swarm.nodes import convert
from phd_swarm.nodes.bundle import pack_cdr, publish_watched
from phd_swarm.nodes.face import Face, Step, load_face
from phd_swarm.nodes.qos import publisher_qos
from phd_swarm.nodes.topics import TEAM_OUTPUTS, declared_outputs, robot_topic
from phd_swarm_msgs.msg import MessageBundle, TargetSet


def robot_estimates(agent: Agent) -> tuple[np.ndarray, float]:
    """The robot's estimates (N, 2) [m] and expected count, as its ``estimates`` topic has them.

    The estimator's own, or, for an estimator whose PHD the exchange keeps on the robot's
    owned bins (capability ``grid_density``), those of the owned bins.
    """
    ex, est = agent.exchange, agent.estimator
    if "grid_density" in agent.team.parts["estimator"].provides:
        points, expected = est.estimates(ex.bins, ex.weights), est.expected_count(ex.weights)
    else:
        points, expected = est.estimates(), est.expected_count()
    return np.asarray(points, dtype=float).reshape(-1, 2), float(expected)


class RobotOutputs:
    """The step outputs of one robot node (see the module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        The robot node (publishers are made on it, relative to its namespace).
    agent : Agent
        The robot's agent.
    publish_density, publish_markers : bool
        Publish the ``density`` / ``markers`` outputs where the system declares them.
    """

    def __init__(self, node: Any, agent: Agent, publish_density: bool,
                 publish_markers: bool = True) -> None:
        self.agent = agent
        self.robot_id = agent.robot_id
        scenario = agent.team.scenario
        self.dt = scenario.dt
        self.frame_id = node.params["world_frame_id"]
        self.grid_estimator = "grid_density" in agent.team.parts["estimator"].provides
        self.estimates_pub = node.create_publisher(TargetSet, "estimates",
                                                   publisher_qos("STEP"))
        self.goal_pub = node.create_publisher(PoseStamped, "goal", publisher_qos("STEP"))
        self.team_pub = node.create_publisher(MessageBundle, TEAM_OUTPUTS,
                                              publisher_qos("STEP"))
        #: (absolute topic, face, publisher, memo) of each declared output.
        self.outputs: list[tuple[str, Face, Any, dict[str, Any]]] = []
        for out in declared_outputs(scenario.system, publish_density, publish_markers):
            face = load_face(out)
            pub = node.create_publisher(face.msg_type, out.topic, publisher_qos(out.qos))
            self.outputs.append((robot_topic(self.robot_id, out.topic), face, pub, {}))
        self.kinds = tuple(o.topic for o in declared_outputs(scenario.system, publish_density,
                                                              publish_markers))
        self._own = {t: robot_topic(self.robot_id, t) for t in ("estimates", "goal")}

    def unmatched(self, observers: int) -> list[str]:
        """``/team/outputs`` while it has fewer than ``observers`` readers, else nothing."""
        return ([TEAM_OUTPUTS] if self.team_pub.get_subscription_count() < observers
                else [])

    def publish(self, k: int, decision: Decision) -> None:
        """Publish step ``k``'s outputs (all but the status): one bundle, watched topics."""
        points, expected = robot_estimates(self.agent)
        est = serialize_message(convert.target_set(
            self.robot_id, k, np.arange(len(points)), points, expected, self.dt,
            self.frame_id))
        publish_watched(self.estimates_pub, est)
        pieces = [(self._own["estimates"], est)]
        step = Step(self.agent, k, decision, points, self.dt, self.frame_id)
        for topic, face, pub, memo in self.outputs:
            data = serialize_message(face.build(step, memo))
            publish_watched(pub, data)
            pieces.append((topic, data))
        pose = convert.pose_stamped(decision.goal, k, self.dt, self.frame_id)
        goal = serialize_message(pose)
        publish_watched(self.goal_pub, goal)
        pieces.append((self._own["goal"], goal))
        t = pose.header.stamp
        self.team_pub.publish(pack_cdr(t.sec, t.nanosec, self.frame_id, self.robot_id, k,
                                       pieces))

    def status_fields(self) -> dict[str, Any]:
        """What the status of the step reports of the estimate: bins, mass, dead peers."""
        ex, est = self.agent.exchange, self.agent.estimator
        if self.grid_estimator:
            return {"owned_bins": int(ex.bins.size), "mass": float(np.sum(ex.weights)),
                    "dead_ids": convert.u32(sorted(ex.dead))}
        return {"owned_bins": 0, "mass": float(est.expected_count()),
                "dead_ids": convert.u32(sorted(getattr(ex, "dead", ())))}
