"""Robot node: one robot's PHD filter, exchange and controller over ROS topics.

A thin adapter over :class:`phd_swarm.core.agent.Agent`, the one agent step the in-memory
engine runs too, with the parts that ``scenario.system`` names (:mod:`phd_swarm.core.registry`;
for Dames' and Chen's systems the exchange is
:class:`phd_swarm.core.exchange.voronoi_phd.participant.Participant`, Dames Alg. 1-2 with
Chen's cumulative state, and the controllers are those of :mod:`phd_swarm.core.controllers`,
Dames eq. 8, Chen eq. 2-3 and 12-14; for Sung & Tokekar's single robot there is no exchange,
``none``, and every step is done as soon as the scan is in). What it publishes at the end of
a step is what the parts declare (:mod:`phd_swarm.nodes.robot_outputs`: a grid window and
a cell, or Gaussian components, tracks and markers...). Per step k:

1. the world's measurement set Z_r^k arrives on ``measurements`` (with the sensor position
   q^k): the step starts, and the protocol's messages go to the contacts' inboxes
   (``/robot_<j>/inbox``, one message per contact and tick: :mod:`phd_swarm.nodes.inbox`);
2. messages arrive on the own inbox, are checked (:mod:`phd_swarm.nodes.convert`, plus known
   sender, right address, step in range) and fed to the protocol; bad ones are dropped with
   a logged reason and counted (``rejected_messages`` in the status);
3. when the protocol step is done, the controller picks the goal and the next power weight;
   the node publishes its outputs and the goal (one bundle on ``/team/outputs``:
   :class:`~phd_swarm.nodes.robot_outputs.RobotOutputs`) and a ``STEP_DONE`` status on
   ``/team/status``, which is what the world waits for in lockstep mode. Each also goes to
   the robot's own topic (``status``, ``goal``, ``estimates``...) while a reader is
   matched there (:mod:`phd_swarm.nodes.bundle`).

A wall-clock timer (``tick_period``) stands in for the in-memory engine's rounds: if no
new protocol message arrived during a period while the step waits, one round passes
(:meth:`Participant.tick`), and the robot re-sends its state to its contacts as a
keep-alive; after ``timeout_ticks`` rounds the awaited peers not heard from in that time
are declared dead (keep-alives count as heard, not as new).

Liveness is apart from progress: a thread of the node's own publishes a ``WORKING`` status
once per ``tick_period`` while a step is in progress, so a robot that waits on a dead peer,
or whose executor works through a backlog of messages on a loaded machine, is not taken
for dead by the world; it stops when the executor has run no callback for
:data:`HUNG_AFTER` s (or 3 x ``timeout_ticks`` periods, if longer). It goes on between
steps, while the robot waits for the next step's measurement set and team state, for at
most :data:`HUNG_AFTER` s: a reliable sample that DDS lost on the way (to or from the world)
is repaired at the writer's next heartbeat, seconds later, and a robot waiting for that
repair is slow, not dead. Each such status also shows the world's status reader at once
that an earlier sample (the step's ``STEP_DONE``) is missing, so it is re-sent at once.

Membership comes from the world's team state (``/world/robots``: ids, positions, alive
flags), which the robot reads every step: step k starts when both the measurement set and
the team state of step k are in, and the protocol learns from it who died and who came back
(:meth:`Participant.observe_team`); in real time a peer this robot declared dead on silence
is admitted again only at the team's epochs, every ``revive_every`` steps
(:mod:`phd_swarm.nodes.silence`). A robot the world counted dead (it was silent for the
world's ``step_timeout``, or its process was restarted) sees itself dead in a team state;
when the world says it is alive again, it rejoins at that step (:meth:`Participant.rejoin`:
no bins of its own, the step's hand-over gives it its cell's bins). A restarted process
(``scripts/run_robot.sh ID`` again) finds the run in progress from the team states it gets
(the topic is keep-all, transient-local: the history arrives first), ignores the old
steps, reports ``READY``, and the world lets it rejoin at the next step.

Lossy links (fault injection, same option and meaning as the in-memory engine's
``faults``): ``fault_drop`` and ``fault_delay`` route every outgoing protocol message through
a seeded :class:`phd_swarm.core.exchange.faults.FaultyLink`; delayed messages are held back
whole tick periods. The protocol re-sends what a waiting peer lacks when its keep-alive
arrives, so a lost message costs time, not a robot.

At start-up the robot waits for the world's team state to initialise its partition, and for
the world and ``observers`` readers on ``/team/status`` (``observers`` on ``/team/outputs``),
then reports ``READY``. It refuses to
start when another node already publishes this robot id's status (a duplicate robot id).

Once per wall second it reports its health on ``/diagnostics`` (:meth:`RobotNode.health`,
:mod:`phd_swarm.nodes.diagnostics`): state, step lag behind the world, contacts, timeouts,
rejected and dropped messages, dead and revived peers, rejoins.
"""

from __future__ import annotations

import sys
import threading
import time
from collections import defaultdict, deque
from typing import Any

import numpy as np
from geometry_msgs.msg import Point
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.serialization import serialize_message

from phd_swarm.config.node_params import ROBOT, SHARED
from phd_swarm.core.agent import Team
from phd_swarm.core.exchange.base import Envelope, ProtocolError
from phd_swarm.core.exchange.faults import FaultyLink, LinkFaults
from phd_swarm.core.scan import Scan
from phd_swarm.nodes import auth, convert, inbox
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.bundle import publish_watched
from phd_swarm.nodes.completeness import ranges
from phd_swarm.nodes.diagnostics import RobotHealth, robot_status
from phd_swarm.nodes.qos import publisher_qos, subscription_qos
from phd_swarm.nodes.reporter import DiagnosticsReporter
from phd_swarm.nodes.robot_outputs import RobotOutputs
from phd_swarm.nodes.ros_params import ParameterError, declare, declare_scenario
from phd_swarm.nodes.silence import SilenceHold
from phd_swarm.nodes.wire import wire_for
from phd_swarm_msgs.msg import InboxMessage, MeasurementSet, RobotStatus, TeamState

#: Wall seconds between a waiting robot's log lines of what it waits for before READY.
READY_LOG_PERIOD = 20.0

#: Wall seconds without any executor callback after which a robot stops saying it is alive.
HUNG_AFTER = 30.0

#: Log the first few rejections of each reason, then every this many.
_LOG_EVERY = 100


class RobotNode(Node):
    """One robot (see the module docstring). Node name ``robot`` in namespace ``/robot_<id>``.

    Parameters
    ----------
    **kwargs
        Passed to :class:`rclpy.node.Node` (``context``, ``namespace``,
        ``parameter_overrides``, ``cli_args``...).

    Raises
    ------
    ParameterError
        For a missing or out-of-range ``robot_id`` or another bad parameter.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__("robot", **kwargs)
        self.params = declare(self, SHARED + ROBOT)
        self.scenario = declare_scenario(self)
        rid = self.params["robot_id"]
        if not 0 <= rid < self.scenario.robots:
            raise ParameterError(f"node {self.get_fully_qualified_name()}: robot_id must be "
                                 f"set to 0..{self.scenario.robots - 1} (the scenario has "
                                 f"{self.scenario.robots} robots), got {rid}")
        self.robot_id = rid
        #: The run's key (auth.py): what this robot sends is signed, what it takes checked.
        self.key = auth.node_key(self)
        self.frame_id = self.params["world_frame_id"]
        self.dt = self.scenario.dt
        self.grid = self.scenario.grid
        self.agent = Team.build(self.scenario,
                                timeout_ticks=self.params["timeout_ticks"]).agent(rid)
        #: The exchange participant (for Dames' protocol: step state, cell, bins, counters;
        #: for ``none``: done at once).
        self.filter = self.agent.exchange
        #: How the exchange's messages travel (inbox kinds, ROS types, conversions).
        self.wire = wire_for(self.agent.team.parts["exchange"])
        self.team_ids: frozenset[int] = frozenset()
        self.initialised = False
        self.ready = False
        self.pending: deque[Scan] = deque()
        self.last_scan_step = -1
        self.counters: dict[str, int] = defaultdict(int)
        self.rejections: dict[str, int] = defaultdict(int)
        self._heard = False
        self._sent = 0
        self._received: dict[int, int] = defaultdict(int)
        self._started = time.monotonic()
        self._ready_logged = self._started
        self._peer_pubs: dict[int, object] = {}
        self._finished = -1
        self._finished_at = time.monotonic()
        #: The world's team states by step: (ids, positions (R, 2), alive flags).
        self.teams: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        #: Counted dead by the world: steps up to ``join_after`` are not this robot's.
        self.evicted = False
        self.join_after = -1
        #: Real time: peers this robot declared dead on silence stay out until an epoch.
        self.silence = SilenceHold(self.params["revive_every"])
        faults = LinkFaults(drop=self.params["fault_drop"], delay=self.params["fault_delay"],
                            max_delay_rounds=self.params["fault_delay_rounds"],
                            seed=self.params["fault_seed"])
        self.link = FaultyLink.for_sender(faults, rid)
        #: Delayed envelopes: [tick periods left, envelope].
        self._held: list[list] = []

        if self.get_namespace() != T.robot_namespace(rid):
            raise ParameterError(f"robot {rid} must run in namespace {T.robot_namespace(rid)}"
                                 f" (peers address it there), not {self.get_namespace()!r}")
        if self.count_publishers("status") > 0:
            raise ParameterError(f"duplicate robot id {rid}: another node already publishes "
                                 f"{self.resolve_topic_name('status')}")
        self.status_pub = self.create_publisher(RobotStatus, "status", publisher_qos("STEP"))
        #: The team's status topic, which the world and the observers read (bundle.py).
        self.team_status_pub = self.create_publisher(RobotStatus, T.TEAM_STATUS,
                                                     publisher_qos("STEP"))
        #: The step outputs the system's parts bring (density, cell, estimates, components...).
        self.outputs = RobotOutputs(self, self.agent, self.params["publish_density"])
        self.create_subscription(MeasurementSet, "measurements", self._on_scan,
                                 subscription_qos("STEP"), raw=True)
        if self.wire.types:
            self.create_subscription(InboxMessage, inbox.INBOX, self._on_envelope,
                                     subscription_qos("INBOX"), raw=True)
        self.create_subscription(TeamState, T.WORLD_ROBOTS, self._on_team,
                                 subscription_qos("STEP"))
        self.create_timer(self.params["tick_period"], self._on_timer,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        #: Liveness (:meth:`_heartbeat`): when the executor last ran a callback, and how
        #: long without one counts as hung.
        self._alive_at = time.monotonic()
        self._hung_after = max(HUNG_AFTER, 3 * self.params["timeout_ticks"]
                               * self.params["tick_period"])
        self._beat_stop = threading.Event()
        self._beat = threading.Thread(target=self._heartbeat, name=f"heartbeat_{rid}",
                                      daemon=True)
        self._beat.start()
        #: Its health on /diagnostics, once per wall second (:meth:`health`).
        self.diagnostics = DiagnosticsReporter(self, self.health, robot_status)
        self.get_logger().info(f"robot {rid}: system {self.scenario.system.label()}, "
                               f"{self.scenario.name}, {self.scenario.robots} robots")

    # ------------------------------------------------------------------ start-up
    def _on_team(self, msg: TeamState) -> None:
        self._alive_at = time.monotonic()
        ids = np.array(msg.robot_ids, dtype=np.int64)
        try:
            pos = convert.xy(msg.positions, "positions")
            alive = np.asarray(msg.alive, dtype=bool)
            if len(pos) != len(ids) or len(alive) != len(ids) \
                    or len(np.unique(ids)) != len(ids):
                raise convert.InvalidMessage("ids, positions and alive flags differ in length "
                                             "or ids repeat")
            if self.robot_id not in ids:
                raise convert.InvalidMessage(f"robot {self.robot_id} is not in the team")
            if not self.initialised:
                self.agent.initialise(ids, pos)
        except (ValueError, convert.InvalidMessage) as exc:
            self._reject("team_state", f"team state from {T.WORLD_ROBOTS}: {exc}")
            return
        k = int(msg.step)
        self.teams[k] = (ids, pos, alive)
        if not alive[int(np.flatnonzero(ids == self.robot_id)[0])] and k > self.join_after:
            if not self.evicted:
                self.get_logger().warning(f"robot {self.robot_id}: the world counts it dead "
                                          f"at step {k}; it rejoins when the world says so")
            self.evicted = True
            self.join_after = k
        if not self.initialised:
            self.team_ids = frozenset(int(i) for i in ids)
            self.initialised = True
            self._prepare_peers()
            self._check_ready()
        self._start_pending()

    def _prepare_peers(self) -> None:
        """Create the publishers to the contacts' inboxes ahead of the step that uses them.

        Discovery and matching of a new publisher take a while (much longer with many
        processes); doing it between steps keeps it off the step's critical path.
        """
        if not self.wire.types:
            return
        for c in getattr(self.filter, "contacts", ()):
            self._peer_publisher(c)

    def _check_ready(self) -> None:
        if self.ready or not self.initialised:
            return
        unmatched = self._unmatched()
        now = time.monotonic()
        waited = now - self._started
        if unmatched and waited < self.params["ready_timeout"]:
            if now - self._ready_logged >= READY_LOG_PERIOD:
                self._ready_logged = now
                self.get_logger().info(f"robot {self.robot_id}: waiting {waited:.0f} s for "
                                       f"{unmatched}")
            return
        if unmatched:
            self.get_logger().error(f"robot {self.robot_id}: not matched within "
                                    f"{self.params['ready_timeout']} s ({unmatched}); going on "
                                    "without them")
        latest = max(self.teams, default=0)
        if latest > 0 and not self.evicted:
            # The run is under way (the team states' history came in): this process was
            # restarted, and the world lets it rejoin after this READY.
            self.evicted = True
            self.join_after = latest
            self.get_logger().warning(f"robot {self.robot_id}: the run is at step {latest}; "
                                      "rejoining the team")
        self.ready = True
        self._publish_status(RobotStatus(header=convert.header(0, self.dt, self.frame_id),
                                         state=RobotStatus.STATE_READY,
                                         robot_id=self.robot_id))
        self._start_pending()

    def _unmatched(self) -> str:
        """What has not matched yet, in words; "" once all have their readers.

        The status needs the world and the observers, the observed outputs (the density
        window of a grid PHD) the observers, and each contact's inbox its robot.
        """
        need = self.params["observers"]
        missing = []
        status = self.team_status_pub.get_subscription_count()
        if status < 1 + need:
            missing.append(f"{T.TEAM_STATUS}: {status} of {1 + need} readers (world and "
                           "observers)")
        for topic in self.outputs.unmatched(need):
            missing.append(f"{topic}: fewer than {need} observers")
        peers = sorted(dst for dst, pub in self._peer_pubs.items()
                       if pub.get_subscription_count() < 1)
        if peers:
            missing.append(f"inboxes of robots {ranges(peers)}")
        return "; ".join(missing)

    # -------------------------------------------------------------------- steps
    def _on_scan(self, data: bytes) -> None:
        """The world's measurement set for this robot, taken as CDR (a raw subscription)."""
        self._alive_at = time.monotonic()
        try:
            scan = convert.decode_scan(data, self.params["max_measurements"], self.key)
            if scan.robot_id != self.robot_id:
                raise convert.InvalidMessage(f"measurement set of robot {scan.robot_id} on "
                                             f"robot {self.robot_id}'s topic")
            if scan.step <= self.last_scan_step or scan.step >= self.scenario.steps:
                raise convert.InvalidMessage(f"step {scan.step} out of range (last "
                                             f"{self.last_scan_step}, steps "
                                             f"{self.scenario.steps})")
        except convert.InvalidMessage as exc:
            self._reject(_kind(exc, "measurements"), f"measurements from the world: {exc}")
            return
        self.last_scan_step = scan.step
        self.pending.append(scan)
        self._start_pending()

    def _start_pending(self) -> None:
        """Start the next step whose measurement set and team state are both in."""
        while self.ready and self.pending and (self.evicted or self.filter.done):
            scan = self.pending[0]
            team = self.teams.get(scan.step)
            if team is None:
                return
            self.pending.popleft()
            ids, pos, alive = team
            if not alive[int(np.flatnonzero(ids == self.robot_id)[0])]:
                continue
            if self.evicted and scan.step <= self.join_after:
                continue  # a step of the team's, from before this robot came back
            try:
                if self.evicted:
                    self.agent.rejoin(scan.step, ids, pos, alive)
                    self.evicted = False
                    self._held.clear()
                    self.get_logger().warning(f"robot {self.robot_id}: rejoined the team at "
                                              f"step {scan.step}")
                else:
                    keep = self.silence.keep_dead(scan.step, ids, alive,
                                                  self.agent.dead_peers)
                    self.agent.observe_team(scan.step, ids, pos, alive, keep_dead=keep)
                self._forget_teams(scan.step)
                self._sent = 0
                out = self.agent.start_step(scan.step, scan.sensor, scan.z)
            except (ProtocolError, ValueError) as exc:
                self._reject("step", f"cannot start step {scan.step}: {exc}")
                return
            self._send(out)
            self._after_progress()
            return

    def _forget_teams(self, step: int) -> None:
        for old in [k for k in self.teams if k < step - 1]:
            del self.teams[old]

    def _on_envelope(self, envelope: bytes) -> None:
        """Take the protocol messages of one envelope (its CDR) in the order they were sent."""
        self._alive_at = time.monotonic()
        try:
            sender, pieces = inbox.unpack_cdr(envelope, self.wire.types, self.key)
        except convert.InvalidMessage as exc:
            self._reject(_kind(exc, "envelope"), f"inbox message: {exc}")
            return
        for kind, data in pieces:
            self._on_inbox(kind, data, sender)

    def _on_inbox(self, kind: str, data: bytes, sender: int) -> None:
        try:
            msg = self.wire.decode(kind, data, self.grid, self.params["max_measurements"])
            self._check_welcome(msg)
            if self.wire.sender(msg) != sender:
                raise convert.InvalidMessage(f"sent by robot {self.wire.sender(msg)} inside "
                                             f"robot {sender}'s inbox message")
        except convert.InvalidMessage as exc:
            self._reject(kind, f"inbox {kind}: {exc}")
            return
        self._received[msg.step] += 1
        if self.evicted:
            return
        # A keep-alive (a repeated state) does not hold this robot's own rounds back.
        if self.agent.receive(msg):
            self._heard = True
        # Also when the step is done: a peer's keep-alive may ask for a re-send.
        self._send(self.agent.advance())
        self._after_progress()

    def _check_welcome(self, msg: Any) -> None:
        src = self.wire.sender(msg)
        if src == self.robot_id:
            raise convert.InvalidMessage(f"sender claims this robot's own id {src} (duplicate "
                                         "robot id?)")
        if src not in self.team_ids:
            raise convert.InvalidMessage(f"unknown robot id {src}; the team is "
                                         f"0..{self.scenario.robots - 1}")
        to = self.wire.addressee(msg)
        if to is not None and to != self.robot_id:
            raise convert.InvalidMessage(f"{type(msg).__name__} addressed to robot {to}")
        if not 0 <= msg.step < self.scenario.steps or msg.step > self.last_scan_step + 2:
            raise convert.InvalidMessage(f"step {msg.step} out of range (current "
                                         f"{self.filter.step}, steps {self.scenario.steps})")

    def _on_timer(self) -> None:
        self._alive_at = time.monotonic()
        if not self.ready:
            self._check_ready()
            return
        self._release_held()
        if self.evicted:
            return
        if self.filter.done:
            self._heard = False
            return
        if self._heard:
            self._heard = False
            return
        self._send(self.agent.tick())
        self._after_progress()

    def _heartbeat(self) -> None:
        """Liveness apart from progress, on a thread of its own (see the module docstring).

        Once per ``tick_period``, while a step is in progress (or the robot waits to
        rejoin), publish a ``WORKING`` status, as long as the executor ran a callback in the
        last :attr:`_hung_after` s: a robot whose executor is busy (a backlog of messages
        on a loaded machine, a wait on a dead peer) is alive; one whose executor hangs is
        not, and the world will count it dead.
        """
        period = self.params["tick_period"]
        while not self._beat_stop.wait(period):
            now = time.monotonic()
            if not self.ready or now - self._alive_at > self._hung_after:
                continue
            if self.evicted:
                step = self.join_after  # still here: the world lets it rejoin
            elif not self.filter.done:
                step = self.filter.step
            elif 0 <= self._finished < self.scenario.steps - 1 \
                    and now - self._finished_at <= self._hung_after:
                step = self._finished  # waiting for the next step's inputs
            else:
                continue
            try:
                self._publish_status(RobotStatus(
                    header=convert.header(max(step, 0), self.dt, self.frame_id),
                    state=RobotStatus.STATE_WORKING, robot_id=self.robot_id,
                    step=max(step, 0)))
            except Exception:  # noqa: BLE001 - the node or context is going away
                return

    def health(self) -> RobotHealth:
        """What the robot reports on ``/diagnostics`` (:mod:`phd_swarm.nodes.diagnostics`)."""
        f = self.filter
        if not self.ready or self.evicted:
            state = "starting" if not self.ready else "counted dead"
        elif not f.done and f.step >= 0:
            state = "stepping"
        else:
            state = "done" if self._finished >= self.scenario.steps - 1 else "ready"
        stats, contacts = f.stats, getattr(f, "contacts", None)
        return RobotHealth(
            self.robot_id, state, step=f.step if state == "stepping" else -1,
            finished=self._finished, world_step=max(self.teams, default=-1),
            counted_dead=self.evicted,
            contacts=None if contacts is None else tuple(int(c) for c in contacts),
            timeouts=int(stats.get("timeouts", 0)), rejected=sum(self.rejections.values()),
            dropped=int(stats.get("dropped", 0)),
            dead_peers=tuple(sorted(int(i) for i in getattr(f, "dead", ()))),
            rejoins=int(stats.get("rejoins", 0)),
            revived_peers=int(stats.get("revived_peers", 0)))

    def destroy_node(self) -> None:
        """Stop the heartbeat thread, then destroy the node."""
        self._beat_stop.set()
        if self._beat.is_alive():
            self._beat.join(timeout=2.0)
        super().destroy_node()

    def _after_progress(self) -> None:
        if self.evicted:
            return
        if self.filter.done and self.filter.step >= 0 and self._finished != self.filter.step:
            self._finish_step()
            self._start_pending()

    def _finish_step(self) -> None:
        f = self.filter
        k = f.step
        self._finished = k
        self._finished_at = time.monotonic()
        for old in [s for s in self._received if s < k]:
            del self._received[old]
        d = self.agent.finish_step()
        self._prepare_peers()
        self.outputs.publish(k, d)
        stats = f.stats
        self._publish_status(RobotStatus(
            header=convert.header(k, self.dt, self.frame_id), state=RobotStatus.STATE_STEP_DONE,
            robot_id=self.robot_id, step=k, goal=Point(x=float(d.goal[0]), y=float(d.goal[1])),
            power_weight=float(d.power_weight), messages_received=self._received.pop(k, 0),
            messages_sent=self._sent, rejected_messages=sum(self.rejections.values()),
            dropped_messages=int(stats.get("dropped", 0)),
            timeouts=int(stats.get("timeouts", 0)), orphan_bins=int(stats.get("orphan_bins", 0)),
            link_dropped=self.link.dropped, link_delayed=self.link.delayed,
            resent=int(stats.get("resent", 0)), duplicates=int(stats.get("duplicates", 0)),
            rejoins=int(stats.get("rejoins", 0)),
            revived_peers=int(stats.get("revived_peers", 0)),
            **self.outputs.status_fields()))

    def _publish_status(self, msg: RobotStatus) -> None:
        """A status on ``/team/status``, and on this robot's ``status`` if it is watched."""
        data = serialize_message(msg)
        self.team_status_pub.publish(data)
        publish_watched(self.status_pub, data)

    # ---------------------------------------------------------------- transport
    def _send(self, envelopes: list[Envelope]) -> None:
        """Publish envelopes to their receivers' inboxes, through the (faulty) link."""
        now, later = self.link.route(envelopes)
        self._publish(now)
        self._held.extend([rounds, env] for rounds, env in later)
        self._sent += len(envelopes)

    def _publish(self, envelopes: list[Envelope]) -> None:
        """One inbox message per receiver, holding its envelopes in order.

        A message sent to several contacts (a state, a cell) is encoded once.
        """
        by_dst: dict[int, list] = {}
        encoded: dict[int, tuple[str, bytes]] = {}
        for env in envelopes:
            piece = encoded.get(id(env.msg))
            if piece is None:
                piece = encoded[id(env.msg)] = (
                    self.wire.kind(env.msg), self.wire.encode(env.msg, self.dt, self.frame_id))
            by_dst.setdefault(env.dst, []).append(piece)
        for dst, pieces in by_dst.items():
            self._peer_publisher(dst).publish(inbox.pack_cdr(self.robot_id, pieces, self.key))

    def _release_held(self) -> None:
        """One tick period passed: publish the delayed envelopes that are due."""
        if not self._held:
            return
        due = []
        for entry in self._held:
            entry[0] -= 1
            if entry[0] <= 0:
                due.append(entry[1])
        self._held = [e for e in self._held if e[0] > 0]
        self._publish(due)

    def _peer_publisher(self, dst: int):
        pub = self._peer_pubs.get(dst)
        if pub is None:
            pub = self.create_publisher(InboxMessage, T.robot_topic(dst, inbox.INBOX),
                                        publisher_qos("INBOX"))
            self._peer_pubs[dst] = pub
        return pub

    def _reject(self, kind: str, reason: str) -> None:
        self.rejections[kind] += 1
        n = sum(self.rejections.values())
        if n <= 10 or n % _LOG_EVERY == 0:
            self.get_logger().warning(f"robot {self.robot_id}: rejected {reason} "
                                      f"({n} rejected so far)")


def _kind(exc: convert.InvalidMessage, kind: str) -> str:
    """The counter a rejection goes to: ``unauthenticated``, or ``kind``."""
    return "unauthenticated" if isinstance(exc, convert.Unauthenticated) else kind


def main(args: list[str] | None = None) -> int:
    """Run one robot node (``python -m phd_swarm.nodes.robot --ros-args ...``)."""
    from phd_swarm.nodes.spin import spin_nodes

    return spin_nodes(lambda: [RobotNode()], args)


if __name__ == "__main__":
    sys.exit(main())
