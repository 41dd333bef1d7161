"""Every topic of a phd_swarm run: name, message type and QoS, in one table.

World topics live under ``/world``, the monitor's under ``/monitor``, and each robot's
under its namespace ``/robot_<id>`` (REP 144, DESIGN.md). Robot nodes use relative names
inside their namespace; :func:`robot_topic` gives the absolute name for robot ``id`` (the
world, the monitor, the recorder and peers address a robot's topics that way).

Protocol traffic goes to the receiver's *inbox*: robot ``j`` publishes what it has for
robot ``i`` in a tick as one ``InboxMessage`` on ``/robot_<i>/inbox``, whatever the kinds
(six for Dames', ``rewards`` for Shirsat & Berman's meet-and-merge, ``sat`` for Papaioannou
et al.'s agents; :mod:`phd_swarm.nodes.inbox`). A robot subscribes to its one inbox
whatever the team size and receives exactly the messages addressed to it (O(neighbours)
per step). Inbox topics are reliable and transient-local on
the writer side with a short history, so that a message written by a publisher created a
moment ago (a new contact) still reaches the inbox
once the two match; readers keep a deep queue so a burst is never overwritten.

Health goes to ROS' standard ``/diagnostics`` (absolute, outside every namespace): the
world, each robot and the recorder publish a ``DiagnosticArray`` there once per wall
second (:mod:`phd_swarm.nodes.diagnostics`).

Team topics carry what the observers (world, monitor, recorder) read of every robot, so that
each holds a few readers whatever the team size (:mod:`phd_swarm.nodes.bundle`): robots
write their statuses on ``/team/status`` and the rest of a step's outputs as one
``MessageBundle`` on ``/team/outputs``; the world writes the step's poses and measurement
sets as one bundle on ``/world/outputs``. Each message keeps its per-robot topic name in the
bundle (:attr:`TopicSpec.via` names the team topic that carries it) and the recorder logs it
under that name. The per-robot topics themselves are written for whoever reads them: the
robots read their poses and scans there, a person or RViz2 a robot's outputs.

A robot's other topics are those its system's parts declare (:mod:`phd_swarm.core.outputs`:
:func:`declared_outputs`, :func:`robot_topics`), so a run subscribes to no topic its robots
do not write.

The table is rclpy-free on purpose (QoS as names of :mod:`phd_swarm.nodes.qos` profiles) so
that tools and docs can read it without ROS.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from phd_swarm.core.outputs import Output, system_outputs

#: Namespace prefix of robot ``i``: ``/robot_<i>``.
ROBOT_PREFIX = "robot_"

CLOCK = "/clock"
WORLD_TRUTH = "/world/truth"
WORLD_ROBOTS = "/world/robots"
WORLD_MARKERS = "/world/markers"
MONITOR_METRICS = "/monitor/metrics"
MONITOR_ESTIMATES = "/monitor/estimates"
MONITOR_DENSITY = "/monitor/density"
MONITOR_DENSITY_GRID = "/monitor/density_grid"
MONITOR_MARKERS = "/monitor/markers"
TEAM_STATUS = "/team/status"
TEAM_OUTPUTS = "/team/outputs"
WORLD_OUTPUTS = "/world/outputs"
#: The team topics that carry per-robot topics to the observers; a log holds what they
#: carry under the per-robot names, not them (:mod:`phd_swarm.nodes.team_routes`).
TEAM_TRANSPORT = (WORLD_OUTPUTS, TEAM_STATUS, TEAM_OUTPUTS)
#: The type of ``/team/outputs`` and ``/world/outputs`` (:mod:`phd_swarm.nodes.bundle`).
BUNDLE_TYPE = "phd_swarm_msgs/msg/MessageBundle"
#: Health of the world, each robot and the recorder (ROS' standard diagnostics topic).
DIAGNOSTICS = "/diagnostics"

#: Inbox kinds and the message type each carries inside an InboxMessage.
INBOX = {
    "state": "phd_swarm_msgs/msg/RobotState",
    "cell": "phd_swarm_msgs/msg/CellPolygon",
    "measurements": "phd_swarm_msgs/msg/MeasurementSet",
    "eta_partial": "phd_swarm_msgs/msg/EtaPartial",
    "eta_total": "phd_swarm_msgs/msg/EtaTotal",
    "particles": "phd_swarm_msgs/msg/ParticleTransfer",
    "rewards": "phd_swarm_msgs/msg/RewardSet",
    "sat": "phd_swarm_msgs/msg/SatState",
}


@dataclass(frozen=True)
class TopicSpec:
    """One topic: absolute name, ROS type (``pkg/msg/Type``), QoS profile name, who writes it.

    ``qos`` names a profile of :mod:`phd_swarm.nodes.qos`; ``rate`` says how often it is
    written (for docs/topics.md); ``via`` is the team topic that carries a per-robot
    topic's messages to the observers, or "" (:func:`team_topic`).
    """

    name: str
    type: str
    qos: str
    publisher: str
    rate: str
    via: str = ""


def robot_namespace(robot_id: int) -> str:
    """Namespace of robot ``robot_id``: ``/robot_<id>``."""
    return f"/{ROBOT_PREFIX}{int(robot_id)}"


def robot_topic(robot_id: int, relative: str) -> str:
    """Absolute name of robot ``robot_id``'s topic ``relative`` (e.g. ``inbox``)."""
    return f"{robot_namespace(robot_id)}/{relative}"


#: Topics in every robot's namespace whatever the system, by relative name: (type, QoS,
#: writer, rate). The rest of a robot's topics are its system's declared outputs
#: (:func:`robot_topics`).
ROBOT_TOPICS = {
    "measurements": ("phd_swarm_msgs/msg/MeasurementSet", "STEP", "world", "once per step"),
    "pose": ("geometry_msgs/msg/PoseStamped", "STEP", "world", "once per step"),
    "goal": ("geometry_msgs/msg/PoseStamped", "STEP", "robot", "once per step"),
    "status": ("phd_swarm_msgs/msg/RobotStatus", "STEP", "robot", "once per step"),
    "estimates": ("phd_swarm_msgs/msg/TargetSet", "STEP", "robot", "once per step"),
    "inbox": ("phd_swarm_msgs/msg/InboxMessage", "INBOX", "peers",
              "per tick with protocol traffic, one per contact"),
}

def team_topic(relative: str, writer: str) -> str:
    """The team topic that carries a robot's topic ``relative`` (written by ``writer``).

    ``status`` travels on :data:`TEAM_STATUS`, the world's per-robot topics on
    :data:`WORLD_OUTPUTS`, a robot's other outputs on :data:`TEAM_OUTPUTS`; the inbox on
    none (only its robot reads it).
    """
    if relative == "status":
        return TEAM_STATUS
    return {"world": WORLD_OUTPUTS, "robot": TEAM_OUTPUTS}.get(writer, "")


def declared_outputs(system: Any, publish_density: bool = True,
                     publish_markers: bool = True) -> tuple[Output, ...]:
    """The outputs the parts of ``system`` declare, without those switched off.

    ``publish_density`` switches off the density window in both its forms (``density`` and
    the viewers' ``density_grid``), ``publish_markers`` the ``markers``.
    """
    off = {"density": not publish_density, "density_grid": not publish_density,
           "markers": not publish_markers}
    return system_outputs(system.parts(), [t for t, o in off.items() if o])


def output_rate(output: Output) -> str:
    """How often an output is written, for the topic table."""
    return "once per step" if output.per_step else "once per step, for viewers"


def robot_topics(outputs: Iterable[Output] = ()) -> dict[str, tuple[str, str, str, str]]:
    """A robot's topics: :data:`ROBOT_TOPICS` and ``outputs`` (before the inbox)."""
    own = dict(ROBOT_TOPICS)
    inbox = own.pop("inbox")
    for o in outputs:
        own[o.topic] = (o.type, o.qos, "robot", output_rate(o))
    own["inbox"] = inbox
    return own


#: Team-wide topics: (type, QoS, writer, rate).
TEAM_TOPICS = {
    CLOCK: ("rosgraph_msgs/msg/Clock", "CLOCK", "world", "once per step"),
    WORLD_TRUTH: ("phd_swarm_msgs/msg/TargetSet", "STEP", "world", "once per step"),
    WORLD_ROBOTS: ("phd_swarm_msgs/msg/TeamState", "STEP", "world",
                   "once per step, and once after the last"),
    WORLD_MARKERS: ("visualization_msgs/msg/MarkerArray", "OBSERVATION", "world",
                    "once per step"),
    WORLD_OUTPUTS: (BUNDLE_TYPE, "STEP", "world",
                    "once per step: every robot's pose and measurement set"),
    TEAM_STATUS: ("phd_swarm_msgs/msg/RobotStatus", "STEP", "robots",
                  "once per robot and step, and at READY / while WORKING"),
    TEAM_OUTPUTS: (BUNDLE_TYPE, "STEP", "robots",
                   "once per robot and step: its goal, estimates and system's outputs"),
    MONITOR_METRICS: ("phd_swarm_msgs/msg/TeamMetrics", "STEP", "monitor", "once per step"),
    MONITOR_ESTIMATES: ("phd_swarm_msgs/msg/TargetSet", "STEP", "monitor",
                        "once per step"),
    MONITOR_DENSITY: ("phd_swarm_msgs/msg/DensityGrid", "STEP", "monitor",
                      "once per step (parameter publish_density)"),
    MONITOR_DENSITY_GRID: ("nav_msgs/msg/OccupancyGrid", "LATCHED", "monitor",
                           "once per step, for viewers (parameter publish_density)"),
    MONITOR_MARKERS: ("visualization_msgs/msg/MarkerArray", "OBSERVATION", "monitor",
                      "once per step"),
    DIAGNOSTICS: ("diagnostic_msgs/msg/DiagnosticArray", "OBSERVATION",
                  "world, robots, recorder", "1 Hz per node (wall clock)"),
}


def run_topics(robot_ids: list[int] | range, outputs: Iterable[Output] = ()
               ) -> list[TopicSpec]:
    """Every topic of a run with robots ``robot_ids`` declaring ``outputs``, team first."""
    out = [TopicSpec(name, *spec) for name, spec in TEAM_TOPICS.items()]
    table = robot_topics(outputs)
    for rid in robot_ids:
        out.extend(TopicSpec(robot_topic(rid, rel), *spec, via=team_topic(rel, spec[2]))
                   for rel, spec in table.items())
    return out
