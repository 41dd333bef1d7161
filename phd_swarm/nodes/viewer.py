"""The live view's feeder (node ``viewer``): what a run publishes for viewers, sent to Rerun.

An observer like the monitor: it reads topics and publishes nothing; robots never talk to
it. Every ``discover_period`` wall seconds it looks at the graph and subscribes (raw CDR,
reliable and volatile, so it matches every writer and asks none for history) to each new
topic of a type it draws (:mod:`phd_swarm.nodes.view_scene` turns the messages into
shapes):

- ``visualization_msgs/MarkerArray``: the world's robots, fields of view and targets, the
  monitor's cells, goals, estimates, grid walk and meetings, and whatever markers a
  system's robots declare (ellipses and track ids, reward sets, squares by mode, plans);
- ``phd_swarm_msgs/DensityGrid`` and ``nav_msgs/OccupancyGrid``: heat maps. The team's
  grids (under ``/monitor``) are drawn as they are. The robots' grids of one name are
  composed into one team layer per step, the bin-wise maximum of the robots' windows of
  that step, drawn once the robots that sent it have moved on (:class:`_Composer`): for
  the grid PHD's windows
  (each bin owned by one robot, 0 elsewhere) that is the team PHD, for search maps the
  team's most recent search. Robots' grids whose name the monitor also publishes are not
  read (the team's is), nor an occupancy grid ``X_grid`` beside a density grid ``X``;
- ``phd_swarm_msgs/TeamState`` (``/world/robots``): each robot's trail;
- ``phd_swarm_msgs/TeamMetrics``: OSPA and its parts, the cardinalities and the robots
  alive and reporting against time.

With ``observe_world`` the viewer is one of the world's observers (``run_swarm.sh --view``
counts it in the world's ``observers``): it reads ``/world/truth`` only once it reads the
world's team state and markers and every reader it has made has matched a writer (the
monitor's and the robots' topics exist before the world starts), so a lockstep world
starts step 0 only when the view can draw every step (as the recorder does for the log).

Each message is logged at its header's stamp on the ``sim_time`` timeline, so a live run,
a replayed log (``scripts/replay.sh LOG --view``) and the saved ``.rrd`` all have the same
time slider. Entities are the topic names under ``/view/map`` (the world frame, y up on
the screen), and ``/metrics/...``. Messages that cannot be decoded are counted and
warned about once per topic, never drawn.

Rerun gets the view through a gRPC proxy (``rerun_url``), the one
:mod:`phd_swarm.tools.view_server` starts on 127.0.0.1, and/or an ``.rrd`` file
(``save_path``). Parameters: docs/parameters.md; the view: docs/view.md.
"""

from __future__ import annotations

import sys
from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from nav_msgs.msg import OccupancyGrid
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from visualization_msgs.msg import MarkerArray

from phd_swarm.config.node_params import VIEWER
from phd_swarm.nodes import cdr
from phd_swarm.nodes import view_scene as scene
from phd_swarm.nodes.ros_params import declare
from phd_swarm_msgs.msg import DensityGrid, TargetSet, TeamMetrics, TeamState

#: Reader QoS: reliable and volatile (compatible with every writer of ours and most others),
#: deep enough that a replay sent as fast as it can be loses nothing while the view draws.
VIEW_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)

#: The 2-D view's root (screen, y down) and the world frame below it (y up).
ROOT, MAP = "/view", "/view/map"

#: Draw order of each kind of shape (higher on top).
DRAW_ORDER = {"image": -10.0, "trails": 5.0, "lines": 10.0, "points": 20.0, "labels": 30.0}

#: The world's topics the viewer must read before it counts as the world's observer.
WORLD_ROBOTS, WORLD_MARKERS = "/world/robots", "/world/markers"
WORLD_DRAWN = (WORLD_ROBOTS, WORLD_MARKERS)
WORLD_TRUTH = "/world/truth"

#: Message types drawn -> the message class.
DRAWN_TYPES = {
    "visualization_msgs/msg/MarkerArray": MarkerArray,
    "phd_swarm_msgs/msg/DensityGrid": DensityGrid,
    "nav_msgs/msg/OccupancyGrid": OccupancyGrid,
    "phd_swarm_msgs/msg/TeamState": TeamState,
    "phd_swarm_msgs/msg/TeamMetrics": TeamMetrics,
}


def blueprint() -> Any:
    """The view's layout: the map on the left; OSPA, targets and robots against time."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(origin=ROOT, name="map"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="/metrics/ospa", name="OSPA [m]"),
                rrb.TimeSeriesView(origin="/metrics/cardinality", name="targets"),
                rrb.TimeSeriesView(origin="/metrics/robots", name="robots"),
            ),
            column_shares=[3, 2],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed"),
    )


def drawn_topics(graph: Mapping[str, Sequence[str]]) -> dict[str, str]:
    """The topics of ``graph`` (topic -> its types) the view draws, with the type drawn.

    Every topic of a type of :data:`DRAWN_TYPES`, except (module docstring): an occupancy
    grid ``X_grid`` beside a density grid ``X``; a robot's grid whose name the monitor
    also publishes; team states other than ``/world/robots``.
    """
    out = {}
    for topic, types in sorted(graph.items()):
        kind = next((t for t in types if t in DRAWN_TYPES), None)
        if kind is None:
            continue
        if kind == "nav_msgs/msg/OccupancyGrid" and topic.endswith("_grid") and \
                "phd_swarm_msgs/msg/DensityGrid" in graph.get(topic[:-5], ()):
            continue        # the density grid beside it is drawn, exact
        robot = _robot_relative(topic)
        if robot and kind in ("phd_swarm_msgs/msg/DensityGrid",
                              "nav_msgs/msg/OccupancyGrid") and f"/monitor/{robot[1]}" in graph:
            continue        # the team's grid of that name is drawn instead
        if kind == "phd_swarm_msgs/msg/TeamState" and topic != WORLD_ROBOTS:
            continue
        out[topic] = kind
    return out


def _robot_relative(topic: str) -> tuple[str, str] | None:
    """``/robot_3/search_map`` -> ("robot_3", "search_map"); None for other topics."""
    parts = topic.strip("/").split("/")
    if len(parts) == 2 and parts[0].startswith("robot_") and parts[0][6:].isdigit():
        return parts[0], parts[1]
    return None


class _Composer:
    """The robots' windows of one grid topic, composed per step (bin-wise maximum).

    Step k is drawn once every robot that sent a window of step k has sent a later one, or
    once any window of step k + 2 or later arrives (a robot two steps behind is left out);
    a window of a step already drawn is counted in :attr:`late` and not drawn.
    """

    def __init__(self) -> None:
        self.steps: dict[int, dict[str, tuple[np.ndarray, int, int]]] = defaultdict(dict)
        self.stamps: dict[int, float] = {}
        self.latest: dict[str, int] = {}
        self.drawn_up_to = -1
        self.late = 0
        self.grid: tuple[float, float, float] | None = None

    def add(self, robot: str, grid: dict[str, Any], stamp: float
            ) -> list[tuple[float, scene.Shape]]:
        """Take ``robot``'s window; return the finished steps' layers, (stamp, shape) each."""
        values, _, res = scene.density_values(grid)
        k = int(grid["step"])
        if k <= self.drawn_up_to:
            self.late += 1
            return []
        self.grid = (float(grid["x_min"]), float(grid["y_min"]), res)
        self.steps[k][robot] = (values, int(grid["origin_row"]), int(grid["origin_col"]))
        self.stamps[k] = stamp
        self.latest[robot] = max(self.latest.get(robot, -1), k)
        newest = max(self.latest.values())
        ready = [s for s in sorted(self.steps)
                 if newest >= s + 2 or all(self.latest[r] > s for r in self.steps[s])]
        return self.finish(ready)

    def finish(self, steps: list[int] | None = None) -> list[tuple[float, scene.Shape]]:
        """The team layers of ``steps`` (every pending step if None), in step order."""
        out = []
        for k in sorted(self.steps if steps is None else steps):
            windows = list(self.steps.pop(k).values())
            rows = max(r + v.shape[0] for v, r, _ in windows)
            cols = max(c + v.shape[1] for v, _, c in windows)
            team = np.zeros((rows, cols))
            for v, r, c in windows:
                view = team[r:r + v.shape[0], c:c + v.shape[1]]
                np.maximum(view, v, out=view)
            x_min, y_min, res = self.grid
            out.append((self.stamps.pop(k), scene.grid_image(team, (x_min, y_min), res, "")))
            self.drawn_up_to = max(self.drawn_up_to, k)
        return out


class ViewerNode(Node):
    """The live view's feeder (node ``viewer``); see the module docstring.

    Parameters
    ----------
    recording : rerun.RecordingStream or None
        Where to log (tests pass their own); by default one made from the parameters.
    **kwargs
        Passed to :class:`rclpy.node.Node`.

    Attributes
    ----------
    counts : dict
        Messages drawn per topic.
    rejected : dict
        Messages that could not be decoded, per topic.
    steps : set of int
        Steps of the team states drawn.
    """

    def __init__(self, recording: Any = None, **kwargs: Any) -> None:
        super().__init__("viewer", **kwargs)
        self.params = declare(self, VIEWER)
        self.rec = recording if recording is not None else self._recording()
        self.counts: dict[str, int] = defaultdict(int)
        self.rejected: dict[str, int] = defaultdict(int)
        self.steps: set[int] = set()
        self._trails = scene.Trails(self.params["trail_steps"])
        self._composers: dict[str, _Composer] = defaultdict(_Composer)
        self._subs: dict[str, Any] = {}
        self._truth: Any = None
        self.rec.send_blueprint(blueprint())
        import rerun as rr

        self._rr = rr
        # The world frame: x east, y north, so y is flipped on the screen.
        self.rec.log(MAP, rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)
        self._timer = self.create_timer(self.params["discover_period"], self.discover,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.discover()

    def _recording(self) -> Any:
        import rerun as rr

        rec = rr.RecordingStream("phd_swarm")
        sinks = []
        if self.params["rerun_url"]:
            sinks.append(rr.GrpcSink(self.params["rerun_url"]))
        if self.params["save_path"]:
            sinks.append(rr.FileSink(self.params["save_path"]))
        if sinks:
            rec.set_sinks(*sinks)
        rec.send_recording_name(self.params["recording_name"])
        return rec

    # -- the graph ----------------------------------------------------------------------

    def discover(self) -> None:
        """Subscribe to every new topic of a drawn type (see the module docstring)."""
        graph = {name: types for name, types in self.get_topic_names_and_types()}
        for topic, kind in drawn_topics(graph).items():
            if topic in self._subs:
                continue
            handler = self._handler(topic, kind)
            self._subs[topic] = self.create_subscription(
                DRAWN_TYPES[kind], topic, handler, VIEW_QOS, raw=True)
        if self.params["observe_world"] and self._truth is None and \
                all(t in self._subs for t in WORLD_DRAWN) and \
                all(sub.get_publisher_count() > 0 for sub in self._subs.values()):
            # Now the world may count the viewer (module docstring); the truth is not drawn
            # (the world's markers show the targets).
            self._truth = self.create_subscription(TargetSet, WORLD_TRUTH,
                                                   lambda _: None, VIEW_QOS, raw=True)

    def _handler(self, topic: str, kind: str) -> Callable[[bytes], None]:
        msg_class = DRAWN_TYPES[kind]
        draw = {
            "visualization_msgs/msg/MarkerArray": self._markers,
            "phd_swarm_msgs/msg/DensityGrid": self._density,
            "nav_msgs/msg/OccupancyGrid": self._occupancy,
            "phd_swarm_msgs/msg/TeamState": self._team,
            "phd_swarm_msgs/msg/TeamMetrics": self._metrics,
        }[kind]

        def on_message(data: bytes) -> None:
            try:
                msg = cdr.decode(msg_class, data)
                draw(topic, msg)
            except (cdr.CdrError, ValueError, KeyError, TypeError) as exc:
                self.rejected[topic] += 1
                if self.rejected[topic] == 1:
                    self.get_logger().warning(f"{topic}: cannot draw a message ({exc}); "
                                              "counting the others silently")
                return
            self.counts[topic] += 1

        return on_message

    # -- drawing ------------------------------------------------------------------------

    def _at(self, seconds: float) -> None:
        self.rec.set_time("sim_time", duration=seconds)

    def _log(self, path: str, shape: scene.Shape, order: str | None = None) -> None:
        rr = self._rr
        entity = f"{path}/{shape.path}".rstrip("/") if shape.path else path
        draw_order = DRAW_ORDER.get(order or shape.kind)
        if shape.kind == "clear":
            self.rec.log(entity, rr.Clear(recursive=True))
        elif shape.kind == "points":
            self.rec.log(entity, rr.Points2D(shape.positions, radii=shape.radii,
                                             colors=shape.colours, draw_order=draw_order))
        elif shape.kind == "lines":
            self.rec.log(entity, rr.LineStrips2D(shape.strips, radii=shape.radii,
                                                 colors=shape.colours,
                                                 draw_order=draw_order))
        elif shape.kind == "labels":
            self.rec.log(entity, rr.Points2D(shape.positions, radii=0.01,
                                             colors=shape.colours, labels=shape.labels,
                                             show_labels=True, draw_order=draw_order))
        elif shape.kind == "image":
            self.rec.log(entity, rr.Image(shape.rgba, color_model="RGBA",
                                          draw_order=draw_order),
                         rr.Transform3D(translation=[*shape.origin, 0.0],
                                        scale=[shape.resolution, shape.resolution, 1.0]))

    def _markers(self, topic: str, msg: dict[str, Any]) -> None:
        markers = msg["markers"]
        if not markers:
            return
        if topic == WORLD_MARKERS:
            # Trails as wide as the robots' spheres say (they scale with the map).
            robots = [m for m in markers if m["ns"] == "robots" and m["scale"][0] > 0]
            if robots:
                self._trails.radius = 0.5 * scene.TRAIL_WIDTH * float(robots[0]["scale"][0])
        self._at(scene.stamp_seconds(markers[0]["header"]))
        for shape in scene.marker_shapes(msg):
            self._log(MAP + topic, shape)

    def _density(self, topic: str, msg: dict[str, Any]) -> None:
        stamp = scene.stamp_seconds(msg["header"])
        robot = _robot_relative(topic)
        if robot is None:
            values, origin, res = scene.density_values(msg)
            self._at(stamp)
            self._log(MAP + topic, scene.grid_image(values, origin, res, ""))
            return
        for when, shape in self._composers[robot[1]].add(robot[0], msg, stamp):
            self._at(when)
            self._log(f"{MAP}/team/{robot[1]}", shape)

    def _occupancy(self, topic: str, msg: dict[str, Any]) -> None:
        self._at(scene.stamp_seconds(msg["header"]))
        self._log(MAP + topic, scene.occupancy_image(msg, ""))

    def _team(self, topic: str, msg: dict[str, Any]) -> None:
        self._at(scene.stamp_seconds(msg["header"]))
        self.steps.add(int(msg["step"]))
        shape = self._trails.add(msg["robot_ids"], np.asarray(msg["positions"])[:, :2])
        self._log(f"{MAP}/trails", shape, order="trails")

    def _metrics(self, topic: str, msg: dict[str, Any]) -> None:
        self._at(scene.stamp_seconds(msg["header"]))
        for entity, value in scene.metric_scalars(msg).items():
            self.rec.log(f"/metrics/{entity}", self._rr.Scalars(value))

    @property
    def robots(self) -> int:
        """Robots whose trails are drawn."""
        return self._trails.robots

    def close(self) -> None:
        """Draw the robots' last composed grids and flush the recording."""
        for name, composer in self._composers.items():
            for when, shape in composer.finish():
                self._at(when)
                self._log(f"{MAP}/team/{name}", shape)
        self.rec.flush()
        self.get_logger().info(
            f"view: {sum(self.counts.values())} messages drawn from {len(self.counts)} "
            f"topics, {len(self.steps)} steps, {self.robots} robots"
            + (f"; {sum(self.rejected.values())} not drawable" if self.rejected else ""))


def main(args: list[str] | None = None) -> int:
    """Run the viewer (``python -m phd_swarm.nodes.viewer --ros-args -p rerun_url:=...``)."""
    from phd_swarm.nodes.spin import spin_nodes

    return spin_nodes(lambda: [ViewerNode()], args)


if __name__ == "__main__":
    sys.exit(main())
