"""Recorder: writes every phd_swarm topic of a run to an MCAP log, as rosbag2 would.

Subscriptions are ``raw=True``: the callback gets the CDR bytes that arrived and hands them
to :class:`phd_swarm.logs.mcap_log.LogWriter` without deserialising, so a message costs a
clock read and an append to the current chunk (DESIGN.md "MCAP logs").

Topics
    With ``params_file`` set, the recorder loads that run config and subscribes at once to
    every topic of :func:`phd_swarm.nodes.topics.run_topics` for the scenario's team (the
    outputs its system's parts declare, so no reader waits on a topic nobody writes), with
    the table's reader QoS (keep-all for the step topics, so the reader never drops a
    message it has not handed over; others deepened to :data:`MIN_TABLE_DEPTH`); the world
    and the robots count it among their ``observers`` before step 0. With ``wait_for_world``
    (the default) the truth comes last: the world counts the recorder by its truth
    subscription, so the recorder subscribes to it only once each of the world's other
    topics (clock, team state, markers, every robot's pose and measurement set) has matched
    a writer here, and logs every few seconds how many it still waits for. Then step 0
    cannot begin before every world writer reaches the log (at 50 robot processes the
    recorder matched the world's last writers late, or not at all, while the run went on).
    The protocol inboxes
    (``/robot_<n>/inbox``, most of a run's messages) only with ``record_inboxes``. With
    ``discover`` on, it also polls the graph every 0.5 s (wall time) and subscribes to new
    topics ``/clock``, ``/diagnostics`` and under ``/world/``, ``/monitor/`` and
    ``/robot_<n>/``: with that table
    QoS if the topic is in the table (robot topics match by their relative name) and its
    publishers' offers are compatible with it, else adapted to the offers as rosbag2 does
    (reliable if every publisher is, transient-local if every publisher is; depth 100;
    reliable and volatile while no publisher is known).
Completeness
    With ``params_file`` set, the recorder notes the step of every step-topic message (from
    its stamp, no decoding; for statuses only ``STEP_DONE``) and the alive flags of every
    team state. At close it checks them (:mod:`phd_swarm.nodes.completeness`: expected,
    recorded and missing steps per topic), logs the verdict (an error naming the topics and
    steps when anything is missing) and stores the report as metadata
    ``phd_swarm.completeness``, where ``run_swarm`` and ``evaluate`` read it.
Health
    Once per wall second it reports on ``/diagnostics`` (:meth:`Recorder.health`): messages
    written, the last step recorded, step messages missing so far per topic
    (:class:`phd_swarm.nodes.diagnostics.GapCounter`). It records the other nodes' reports,
    not its own (each would change the next one's count of messages written).
Times
    ``log_time`` is the wall-clock time [ns since the Unix epoch] at which the callback
    ran. ``publish_time`` is the message's own stamp when its first field is a
    ``std_msgs/Header`` or a ``builtin_interfaces/Time`` (``/clock``): bytes 4-12 of the
    CDR, read with one ``struct`` call, i.e. *sim time* [ns] for every phd_swarm message;
    for the other types (``MarkerArray``) it is the receive time. rosbag2 puts the DDS
    source timestamp there, which an rclpy callback only gets with a message-info argument,
    and the EventsExecutor of rclpy 7.1 fails on such callbacks.
Metadata
    ``phd_swarm.config`` (``params_yaml``: the params file text, ``source``: its path) and
    ``phd_swarm.run`` (``scenario``, ``seed``, ``robots``) when ``params_file`` is set;
    ``phd_swarm.recorder`` (``output``, ``compression``, ``chunk_size``, ``discover``,
    ``record_inboxes``); ``phd_swarm.completeness`` at close.
Shutdown
    :meth:`Recorder.close` (called by :func:`main` on Ctrl-C / SIGTERM) finishes the file
    with its summary and footer, writes rosbag2's ``metadata.yaml`` beside it (so that
    ``ros2 bag info`` and rosbag2 readers open the run directory) and logs how many messages
    it wrote. A recorder killed with SIGKILL leaves every finished chunk readable
    (:mod:`phd_swarm.logs.mcap_log`).
"""

from __future__ import annotations

import json
import re
import struct
import sys
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.logging import get_logger
from rclpy.node import Node
from rclpy.qos import QoSProfile

from phd_swarm.config import load_run_config
from phd_swarm.config.node_params import RECORDER, SHARED
from phd_swarm.logs.bag_metadata import write_bag_metadata
from phd_swarm.logs.mcap_log import LogError, LogWriter
from phd_swarm.logs.qos_yaml import qos_yaml
from phd_swarm.logs.schemas import DefinitionNotFoundError
from phd_swarm.nodes import cdr, completeness
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.diagnostics import GapCounter, RecorderHealth, recorder_status
from phd_swarm.nodes.qos import publisher_qos, subscription_qos
from phd_swarm.nodes.record_topics import (
    accepts,
    adapted_qos,
    message_class,
    reader_qos,
    starts_with_stamp,
    table_spec,
)
from phd_swarm.nodes.reporter import DiagnosticsReporter
from phd_swarm.nodes.ros_params import ParameterError, declare
from phd_swarm.nodes.step_sets import StepSet, Timeline
from phd_swarm.nodes.team_routes import TeamRoutes, status_state
from phd_swarm_msgs.msg import RobotStatus, TeamState

#: Topics the graph poll records: /clock, /diagnostics and everything under /world,
#: /monitor, /robot_<n>.
RECORDED = re.compile(r"^(?:/clock$|/diagnostics$|/world/|/monitor/|/robot_\d+/)")

#: Graph poll period [s] (wall time).
DISCOVER_PERIOD = 0.5

#: At close, while step messages are missing: stop waiting for them after this many
#: seconds without a new message [s], and after this many in all [s].
SETTLE_QUIET = 1.0
SETTLE_MAX = 10.0

#: Period of the check for the world's writers [s] (wall time), and of its progress lines.
WORLD_CHECK_PERIOD = 0.2
WORLD_LOG_PERIOD = 5.0

_INBOX_TOPIC = re.compile(rf"^/{T.ROBOT_PREFIX}\d+/inbox$")
_STAMP_LE = struct.Struct("<iI")
_STAMP_BE = struct.Struct(">iI")


class Recorder(Node):
    """The recorder (node ``recorder``); see the module docstring.

    Parameters
    ----------
    **kwargs
        Passed to :class:`rclpy.node.Node` (``context``, ``parameter_overrides``, ...).

    Raises
    ------
    ParameterError
        For a bad parameter, a ``params_file`` that cannot be loaded or an ``output`` that
        cannot be created.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("recorder", **kwargs)
        self.params = declare(self, SHARED + RECORDER)
        run_config = None
        if self.params["params_file"]:
            try:
                run_config = load_run_config(self.params["params_file"])
            except ValueError as exc:
                raise ParameterError(f"node {self.get_fully_qualified_name()}: parameter "
                                     f"params_file: {exc}") from None
        try:
            self.log = LogWriter(self.params["output"], compression=self.params["compression"],
                                 chunk_size=self.params["chunk_size"])
        except LogError as exc:
            raise ParameterError(f"node {self.get_fully_qualified_name()}: parameter output: "
                                 f"{exc}") from None
        self._subs: dict[str, Any] = {}
        #: True once the log can take no more (:meth:`_stop_recording`): spin_nodes ends
        #: the process with :attr:`exit_code`.
        self.finished = False
        self.exit_code = 0
        #: Messages recorded whose step could not be read (:meth:`_unreadable`).
        self.unreadable = 0
        #: Topics whose messages arrive inside the team topics (team_routes.py).
        self.routes = TeamRoutes(self.get_logger().warning)
        self._skipped: set[str] = set()
        self._inboxes = self.params["record_inboxes"]
        #: Completeness bookkeeping (with a run config): step topic -> steps seen, and
        #: team-state step -> alive flags.
        self._dt_ns = 0.0
        self._robots = 0
        self._window = 1
        self._step_topics: frozenset[str] = frozenset()
        #: A robot's topics by relative name: its system's with a config, else the common.
        self._robot_table: dict[str, tuple[str, ...]] = dict(T.ROBOT_TOPICS)
        #: Both in memory of their gaps and changes (:mod:`phd_swarm.nodes.step_sets`).
        self._steps: dict[str, StepSet] = defaultdict(StepSet)
        self._team: Timeline = Timeline.flags()
        self.report: completeness.Completeness | None = None
        #: Step messages missing so far, for /diagnostics (with a run config).
        self._gaps: GapCounter | None = None
        #: The world's topics that must match a writer before the truth is subscribed.
        self._world_topics: list[str] = []
        self._truth_spec: T.TopicSpec | None = None
        self._world_timer = None
        self._world_since = self._world_logged = time.monotonic()
        self.log.add_metadata("phd_swarm.recorder", {
            "output": str(self.params["output"]),
            "compression": self.params["compression"],
            "chunk_size": str(self.params["chunk_size"]),
            "discover": str(self.params["discover"]).lower(),
            "record_inboxes": str(self._inboxes).lower(),
        })
        if run_config is not None:
            self._record_config(run_config)
        self._timer = None
        if self.params["discover"]:
            self._timer = self.create_timer(DISCOVER_PERIOD, self.discover,
                                            clock=Clock(clock_type=ClockType.STEADY_TIME))
            self.discover()
        #: Its health on /diagnostics, once per wall second (:meth:`health`).
        self.diagnostics = DiagnosticsReporter(self, self.health, recorder_status)
        self.get_logger().info(f"recording {len(self.topics)} topics to {self.log.path}"
                               + (" (discovering more)" if self._timer else ""))

    @property
    def topics(self) -> tuple[str, ...]:
        """Topics recorded so far: subscribed, or carried by a team topic subscribed."""
        return (*(t for t in self._subs if t not in T.TEAM_TRANSPORT), *self.routes.topics)

    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return self.log.message_count

    def _record_config(self, rc: Any) -> None:
        """Store the params file and the run's identity; subscribe to the run's topics."""
        path = self.params["params_file"]
        with open(path) as f:
            self.log.add_metadata("phd_swarm.config", {"params_yaml": f.read(),
                                                       "source": str(rc.source)})
        s = rc.scenario
        self.log.add_metadata("phd_swarm.run", {"scenario": s.name, "seed": str(s.seed),
                                                "robots": str(s.robots)})
        self._dt_ns = s.dt * 1e9
        self._robots = s.robots
        self._window = completeness.verdict_window(rc)
        step_topics = completeness.run_step_topics(rc)
        self._step_topics = frozenset(step_topics)
        self._gaps = GapCounter(step_topics, s.robots)
        outputs = T.declared_outputs(s.system, bool(rc.param("robot", "publish_density")))
        self._robot_table = T.robot_topics(outputs)
        wait = self.params["wait_for_world"]
        specs = T.run_topics(range(s.robots), outputs)
        for spec in specs:  # those the team topics carry first: a channel, no reader
            if spec.via:
                self.route(spec.via, spec.name, spec.type, qos_yaml(publisher_qos(spec.qos)))
        for spec in specs:
            if wait and spec.name == T.WORLD_TRUTH:
                self._truth_spec = spec
            elif spec.via:
                continue
            elif self._inboxes or not _INBOX_TOPIC.match(spec.name):
                self.subscribe(spec.name, spec.type, reader_qos(spec.qos),
                               qos_yaml(publisher_qos(spec.qos)))
                if spec.publisher == "world" and spec.name in self._subs:
                    self._world_topics.append(spec.name)
        if self._truth_spec is not None:
            self._world_timer = self.create_timer(
                WORLD_CHECK_PERIOD, self._check_world,
                clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _check_world(self) -> None:
        """Subscribe to the truth once every world topic matched a writer (see above)."""
        self._world_topics = [t for t in self._world_topics
                              if self._subs[t].get_publisher_count() == 0]
        now = time.monotonic()
        if self._world_topics:
            if now - self._world_logged >= WORLD_LOG_PERIOD:
                self._world_logged = now
                shown = ", ".join(self._world_topics[:4])
                more = len(self._world_topics) - 4
                self.get_logger().info(
                    f"waiting for the world's writers on {len(self._world_topics)} topics "
                    f"({shown}{f' and {more} more' if more > 0 else ''}) before subscribing "
                    f"to {T.WORLD_TRUTH}")
            return
        self.destroy_timer(self._world_timer)
        self._world_timer = None
        spec = self._truth_spec
        self.subscribe(spec.name, spec.type, reader_qos(spec.qos),
                       qos_yaml(publisher_qos(spec.qos)))
        self.get_logger().info(f"the world's writers matched after {now - self._world_since:.1f}"
                               f" s; recording {spec.name}")

    def subscribe(self, topic: str, ros_type: str, qos: QoSProfile,
                  offered_qos_yaml: str = "") -> bool:
        """Record ``topic`` of type ``ros_type`` (``pkg/msg/Type``); False if impossible.

        A type whose Python class or ``.msg`` definition is not installed is skipped with
        one warning. Subscribing twice to a topic does nothing.
        """
        if topic in self._subs:
            return True
        if topic in self._skipped:
            return False
        carries = topic in self.routes.team_topics  # a team topic: no channel of its own
        try:
            msg_class = message_class(ros_type)
            if not carries:
                self.log.add_channel(topic, ros_type, offered_qos_yaml)
        except (ValueError, DefinitionNotFoundError) as exc:
            self._skipped.add(topic)
            self.get_logger().warning(f"not recording {topic} ({ros_type}): {exc}")
            return False
        callback = (self.routes.callback(topic) if carries
                    else self._recording(topic, ros_type))
        self._subs[topic] = self.create_subscription(msg_class, topic, callback, qos, raw=True)
        return True

    def route(self, via: str, topic: str, ros_type: str, offered_qos_yaml: str = "") -> None:
        """Record ``topic``'s messages that arrive inside team topic ``via`` (team_routes.py)."""
        self.log.add_channel(topic, ros_type, offered_qos_yaml)
        self.routes.add(via, topic, self._recording(topic, ros_type))

    def _recording(self, topic: str, ros_type: str) -> Callable[[bytes], None]:
        """What becomes of a message of ``topic``: written, its step noted (step topics)."""
        callback = self._callback(topic, starts_with_stamp(ros_type))
        if topic == T.DIAGNOSTICS:
            callback = self._others(callback)
        if topic in self._step_topics:
            callback = self._step_callback(topic, callback)
        return callback

    def _callback(self, topic: str, stamped: bool) -> Callable[[bytes], None]:
        """The subscription callback of ``topic``: time stamps and bytes to the log."""
        write = self.log.write
        now = time.time_ns

        if not stamped:
            def on_message(data: bytes) -> None:
                t = now()
                try:
                    write(topic, data, t, t)
                except LogError as exc:
                    self._stop_recording(exc)
            return on_message

        def on_stamped(data: bytes) -> None:
            t = now()
            # Odd encapsulation kinds (CDR_LE = 1, PL_CDR_LE = 3, ...) are little-endian.
            try:
                sec, nsec = (_STAMP_LE if data[1] & 1 else _STAMP_BE).unpack_from(data, 4)
                stamp = sec * 1_000_000_000 + nsec if sec >= 0 else t
            except (struct.error, IndexError):  # too short for a stamp: kept, stamped now
                stamp = t
            try:
                write(topic, data, t, stamp)
            except LogError as exc:
                self._stop_recording(exc)
        return on_stamped

    def _stop_recording(self, exc: LogError) -> None:
        """The log takes no more (its disk is full): end the process, with exit code 1.

        Recording on would lose messages silently; a run is what its log says. What was
        written stays readable up to the last complete chunk (docs/ros.md, "Failures").
        """
        if self.finished:
            return
        self.finished = True
        self.exit_code = 1
        self.get_logger().error(f"recording stopped: {exc}; the log keeps every message up "
                                "to its last complete chunk")

    def _others(self, record: Callable[[bytes], None]) -> Callable[[bytes], None]:
        """``record`` without this recorder's own reports (see :meth:`health`)."""
        def on_report(data: bytes) -> None:
            reporter = getattr(self, "diagnostics", None)
            if reporter is None or data not in reporter.sent:
                record(data)
        return on_report

    def _step_callback(self, topic: str, record: Callable[[bytes], None]
                       ) -> Callable[[bytes], None]:
        """``record`` that also notes the message's step (see *Completeness* above)."""
        steps = self._steps[topic]
        dt_ns = self._dt_ns

        def step(data: bytes) -> int:
            sec, nsec = (_STAMP_LE if data[1] & 1 else _STAMP_BE).unpack_from(data, 4)
            return int(round((sec * 1_000_000_000 + nsec) / dt_ns))

        if topic == T.WORLD_ROBOTS:
            def note(data: bytes) -> None:
                msg = cdr.decode(TeamState, data)
                ids, alive = msg["robot_ids"].astype(np.int64), msg["alive"]
                if len(ids) != len(alive):
                    raise ValueError(f"{len(ids)} robot ids, {len(alive)} alive flags")
                flags = np.zeros(self._robots, dtype=bool)
                ok = (ids >= 0) & (ids < self._robots)
                flags[ids[ok]] = alive[ok]
                steps.add(int(msg["step"]))
                self._team[int(msg["step"])] = flags
        elif topic.endswith("/status"):
            def note(data: bytes) -> None:
                if status_state(data) == RobotStatus.STATE_STEP_DONE:
                    steps.add(step(data))
        else:
            def note(data: bytes) -> None:
                steps.add(step(data))

        def on_step(data: bytes) -> None:
            record(data)
            try:
                note(data)
            except (ValueError, IndexError, struct.error) as exc:  # CdrError is a ValueError
                self._unreadable(topic, exc)
        return on_step

    def _unreadable(self, topic: str, exc: Exception) -> None:
        """A message of ``topic`` recorded whose step could not be read: counted, warned."""
        self.unreadable += 1
        if self.unreadable == 1 or self.unreadable % 100 == 0:
            self.get_logger().warning(f"recorded a message on {topic} whose step cannot be "
                                      f"read ({self.unreadable} so far): {exc}")

    def check_completeness(self) -> completeness.Completeness | None:
        """Expected, recorded and missing steps of every step topic recorded so far.

        None without a run config (the step period and team size are unknown).
        """
        if not self._step_topics:
            return None
        topics = [t for t in self.topics if t in self._step_topics]
        if self._truth_spec is not None and self._truth_spec.name not in self._subs:
            topics.append(self._truth_spec.name)  # never subscribed: all of it is missing
        return completeness.check(self._steps, self._team, self._robots, topics, self._window)

    def health(self) -> RecorderHealth | None:
        """What the recorder reports on ``/diagnostics``; None once the log is closed."""
        if self.log.closed:
            return None
        gaps = self._gaps.update(self._steps, self._team) if self._gaps else {}
        return RecorderHealth(
            self.log.message_count, len(self.topics), max(self._team, default=-1), gaps,
            self._gaps.expected if self._gaps else 0,
            len(self._world_topics) if self._world_timer is not None else 0,
            self.unreadable + sum(self.routes.rejected.values()))

    def discover(self) -> None:
        """Subscribe to the recorded topics (:data:`RECORDED`) that appeared in the graph."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self._subs or topic in self._skipped or not RECORDED.match(topic) \
                    or topic in self.routes.topics or T.BUNDLE_TYPE in types \
                    or (not self._inboxes and _INBOX_TOPIC.match(topic)):
                continue
            if len(types) != 1:
                self.get_logger().warning(f"{topic} has several types {types}; recording "
                                          f"{types[0]}")
            offers = [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
            spec = table_spec(topic, self._robot_table)
            if spec is not None and spec[0] == types[0] \
                    and accepts(subscription_qos(spec[1]), offers):
                qos = reader_qos(spec[1])
                offered = offers or [publisher_qos(spec[1])]
            else:
                qos = adapted_qos(offers)
                offered = offers
            if self.subscribe(topic, types[0], qos, "\n".join(map(qos_yaml, offered))):
                self.get_logger().info(f"recording {topic} ({types[0]})")

    def close(self) -> None:
        """Stop recording and finish the file (summary, footer); idempotent.

        Messages that reached a subscription but were not yet taken by the executor (the
        last ones before Ctrl-C) are taken and written first, and while step messages are
        missing the recorder waits a little for the rest (:meth:`_settle`), so a clean stop
        loses nothing that the publishers wrote.
        """
        if self.log.closed:
            return
        self.diagnostics.stop()
        if self._timer is not None:
            self.destroy_timer(self._timer)
        if self._world_timer is not None:
            self.destroy_timer(self._world_timer)
            self._world_timer = None
            waiting = ", ".join(self._world_topics[:4])
            (self.get_logger() if self.context.ok() else get_logger("recorder.close")).error(
                f"closing before the world's writers matched on {len(self._world_topics)} "
                f"topics ({waiting}); {T.WORLD_TRUTH} was not recorded")
        drained = 0
        started = time.monotonic()
        try:
            drained = self._settle()
            settled = time.monotonic() - started
            self.report = self.check_completeness()
            if self.report is not None:
                self.log.add_metadata("phd_swarm.completeness", {
                    "complete": str(self.report.complete).lower(),
                    "missing": str(self.report.missing),
                    "report": json.dumps(self.report.to_dict())})
        finally:
            for sub in self._subs.values():
                self.destroy_subscription(sub)
            self.log.close()
        # After Ctrl-C the context is already shut down and the node's logger could not
        # publish to /rosout; a logger of another name only prints.
        logger = self.get_logger() if self.context.ok() else get_logger("recorder.close")
        try:
            write_bag_metadata(self.log.path)
        except (LogError, OSError) as exc:
            logger.warning(f"no metadata.yaml beside {self.log.path}: {exc}")
        logger.info(f"wrote {self.log.message_count} messages ({drained} taken at close, "
                    f"{settled:.1f} s) on {len(self._subs)} topics to {self.log.path} (closed "
                    f"in {time.monotonic() - started:.1f} s)")
        if self.report is not None:
            (logger.info if self.report.complete else logger.error)(
                f"step messages {self.report.describe()}")

    def _settle(self) -> int:
        """Take what is waiting; while step messages are missing, wait for the rest.

        The step topics are keep-all: what a live publisher wrote and this reader has not
        got yet is still on its way (retransmitted until acknowledged), e.g. a robot's last
        statuses while the recorder was busy with inbox traffic. So while the report has
        gaps, keep taking until nothing new came for :data:`SETTLE_QUIET` s, at most
        :data:`SETTLE_MAX` s. Returns how many messages were taken.
        """
        taken = sum(self._drain(sub) for sub in self._subs.values())
        if not self._step_topics:
            return taken
        start = last = time.monotonic()
        while time.monotonic() - start < SETTLE_MAX:
            report = self.check_completeness()
            if report is None or report.complete:
                break
            time.sleep(0.05)
            got = sum(self._drain(sub) for sub in self._subs.values())
            taken += got
            if got:
                last = time.monotonic()
            elif time.monotonic() - last >= SETTLE_QUIET:
                break
        return taken

    @staticmethod
    def _drain(sub: Any) -> int:
        """Take and record what is waiting in ``sub``; returns how many messages.

        Uses the subscription handle's ``take_message``, as rclpy's executors do; it works
        after the context was shut down, until the subscription is destroyed.
        """
        n = 0
        while True:
            try:
                with sub.handle:
                    taken = sub.handle.take_message(sub.msg_type, sub.raw)
            except RuntimeError:  # InvalidHandle or RCLError: nothing more can be taken
                return n
            if taken is None:
                return n
            sub.callback(taken[0])
            n += 1


def main(args: list[str] | None = None) -> int:
    """Run the recorder (``python -m phd_swarm.nodes.recorder --ros-args -p output:=X``).

    Jazzy's init / spin / ``finally: close, destroy, try_shutdown`` pattern, as
    :func:`phd_swarm.nodes.spin.spin_nodes`, with the EventsExecutor.
    """
    from phd_swarm.nodes.spin import spin_nodes

    return spin_nodes(lambda: [Recorder()], args)


if __name__ == "__main__":
    sys.exit(main())
