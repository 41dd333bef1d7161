"""World-simulator node: owns time, the true targets, the robots' kinematics and sensors.

A thin adapter over :class:`phd_swarm.sim.world.World` (targets of Dames Sec. IV and Chen
Sec. 4, holonomic robots with a speed limit, Chen eq. 3; the sensor of Dames eq. 9-11).
Per step k it publishes ``/clock`` (t = k dt), the team state (``/world/robots``), the truth
(``/world/truth``), each live robot's pose and measurement set Z_r^k
(``/robot_<r>/pose``, written while a reader is matched, ``/robot_<r>/measurements``; the
observers get them all as one bundle on ``/world/outputs``, :mod:`phd_swarm.nodes.bundle`)
and markers, then collects each
robot's ``STEP_DONE`` status (goal g_r) from ``/team/status``, one reader for the team:

- lockstep (default): step k+1 starts when every live robot has reported step k. Liveness
  is apart from progress: a robot working on a step, or waiting for the next one's inputs,
  sends a ``WORKING`` status once per ``tick_period`` (its protocol's own period), and only
  a robot from which *nothing* was heard for ``step_timeout`` wall seconds counts as dead
  (the world stops scanning and moving it, and says so in the team state). A robot blocked
  on a dead peer keeps saying it is alive until its protocol times that peer out, so it is
  never taken for dead; the config check keeps ``step_timeout`` >= 3 ``tick_period`` s. A
  robot counted dead that is heard from again (it was only slow, or its process was
  restarted and reports ``READY``) is alive again from the next step (it rejoins,
  :mod:`phd_swarm.nodes.robot`); a ``READY`` from a robot the world counts alive mid-run
  means its process restarted: it is counted dead at once and rejoins at the next step;
- realtime: steps follow a wall-clock timer at ``dt / realtime_factor``; a robot that has
  not reported keeps its last goal, and one not heard from at all for ``step_timeout``
  counts as dead (and may rejoin, as in lockstep).

Before step 0 the world publishes the initial team state and waits for every robot's
``READY`` status and for ``observers`` subscribers on the truth, logging how many are ready
every few seconds. It waits as long as the team is still coming up: ``ready_timeout``
counts from the last robot (or observer) that became ready. If it runs out, the world does
not step with part of the team: it logs an error naming the missing robots and the likely
cause (no process seen in the graph, or running but not ready), sets :attr:`exit_code` to
:data:`EXIT_NOT_READY` and :attr:`finished`. After the last step it publishes the final
team state, keeps spinning ``linger`` seconds so that observers receive everything, and
sets :attr:`finished`.

Once per wall second it reports its health on ``/diagnostics`` (:meth:`WorldNode.health`,
:mod:`phd_swarm.nodes.diagnostics`): steps done, the step it waits on and for whom, its lag
behind real time, robots alive and dead, statuses rejected.
"""

from __future__ import annotations

import sys
import time

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock as ClockMsg
from visualization_msgs.msg import MarkerArray

from phd_swarm.config.node_params import SHARED, WORLD
from phd_swarm.nodes import auth, bundle, convert
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.completeness import ranges
from phd_swarm.nodes.diagnostics import WorldHealth, world_status
from phd_swarm.nodes.markers import marker_size, world_markers_cdr
from phd_swarm.nodes.qos import publisher_qos, subscription_qos
from phd_swarm.nodes.reporter import DiagnosticsReporter
from phd_swarm.nodes.ros_params import declare, declare_scenario
from phd_swarm.sim.world import World
from phd_swarm_msgs.msg import (
    MeasurementSet,
    MessageBundle,
    RobotStatus,
    TargetSet,
    TeamState,
)

#: Exit code of a world whose team never became ready (nothing was run).
EXIT_NOT_READY = 3

#: The end of the world's log line when the team is ready and step 0 begins, and the start
#: of its line at the end (run_swarm times the stepping between them).
READY_LINE = "observers ready after"
DONE_LINE = "world: done"

#: Wall seconds between start-up progress lines.
READY_LOG_PERIOD = 5.0


class WorldNode(Node):
    """The world simulator (node ``world``); see the module docstring.

    Attributes
    ----------
    world : World
        The simulated world (its ``step_index`` is the next step to publish).
    finished : bool
        True once the last step is done and the linger time has passed.
    dead : set of int
        Robots the world counts as dead (no report in time).
    rejected : int
        Statuses rejected (bad numbers, wrong id, unexpected step).
    exit_code : int
        0, or :data:`EXIT_NOT_READY` when the team did not become ready.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__("world", **kwargs)
        self.params = declare(self, SHARED + WORLD)
        self.scenario = declare_scenario(self)
        self.world = World(self.scenario)
        self.frame_id = self.params["world_frame_id"]
        #: The run's key (auth.py): the measurement sets are signed with it.
        self.key = auth.node_key(self)
        self.dt = self.scenario.dt
        self.ids = [int(i) for i in self.world.robot_ids]
        self.finished = False
        self.dead: set[int] = set()
        self.rejected = 0
        self.ready: set[int] = set()
        self.goals: dict[int, np.ndarray] = {}
        self.reported: set[int] = set()
        self.exit_code = 0
        #: Wall time (monotonic) at which each robot was last heard from (any status).
        self.heard: dict[int, float] = {}
        #: Dead robots heard from again: alive from the next step. And rejoins so far.
        self.returning: set[int] = set()
        self.rejoins: dict[int, int] = {}
        self._revived: dict[int, float] = {}
        self._phase = "waiting"
        self._phase_since = time.monotonic()
        self._ready_progress = (0, self._phase_since)
        self._ready_logged = self._phase_since
        self._started_wall = 0.0
        self._current = -1
        #: The dead set the last team state announced (logged when it changes).
        self._announced_dead: set[int] = set()

        self.clock_pub = self.create_publisher(ClockMsg, T.CLOCK, publisher_qos("CLOCK"))
        self.truth_pub = self.create_publisher(TargetSet, T.WORLD_TRUTH, publisher_qos("STEP"))
        self.team_pub = self.create_publisher(TeamState, T.WORLD_ROBOTS, publisher_qos("STEP"))
        self.markers_pub = self.create_publisher(MarkerArray, T.WORLD_MARKERS,
                                                 publisher_qos("OBSERVATION"))
        self.scan_pubs = {r: self.create_publisher(MeasurementSet,
                                                   T.robot_topic(r, "measurements"),
                                                   publisher_qos("STEP")) for r in self.ids}
        self.pose_pubs = {r: self.create_publisher(PoseStamped, T.robot_topic(r, "pose"),
                                                   publisher_qos("STEP")) for r in self.ids}
        self.outputs_pub = self.create_publisher(MessageBundle, T.WORLD_OUTPUTS,
                                                 publisher_qos("STEP"))
        self._topics = {r: (T.robot_topic(r, "pose"), T.robot_topic(r, "measurements"))
                        for r in self.ids}
        self._known = frozenset(self.ids)
        self.create_subscription(RobotStatus, T.TEAM_STATUS, self._on_team_status,
                                 subscription_qos("STEP"))
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(0.05, self._on_watchdog, clock=steady)
        if self.params["mode"] == "realtime":
            period = self.dt / self.params["realtime_factor"]
            self._rt_timer = self.create_timer(period, self._on_realtime_tick, clock=steady)
        #: Its health on /diagnostics, once per wall second (:meth:`health`).
        self.diagnostics = DiagnosticsReporter(self, self.health, world_status)
        self._publish_team(0)
        self.get_logger().info(f"world: {self.scenario.name}, {len(self.ids)} robots, "
                               f"{self.scenario.steps} steps of {self.dt} s, "
                               f"{self.params['mode']} mode, seed {self.scenario.seed}")

    # ------------------------------------------------------------- publishing
    def _publish_team(self, step: int) -> None:
        alive = self.world.alive
        self.team_pub.publish(TeamState(header=convert.header(step, self.dt, self.frame_id),
                                        step=step, robot_ids=convert.u32(self.ids),
                                        positions=convert.points(self.world.robot_positions),
                                        alive=[bool(a) for a in alive]))

    def _publish_step(self) -> None:
        w = self.world
        k = w.step_index
        self._current = k
        self.reported = set()
        for r in sorted(self.returning):
            w.revive(r)
            self.dead.discard(r)
            self._revived[r] = time.monotonic()
            self.rejoins[r] = self.rejoins.get(r, 0) + 1
            self.get_logger().warning(f"world: robot {r} rejoins the team at step {k}")
        self.returning.clear()
        self.clock_pub.publish(ClockMsg(clock=convert.stamp(k, self.dt)))
        if k > 0:
            self._publish_team(k)
        if self.dead != self._announced_dead:
            # A change of membership, once per change: the team state of step k says so.
            self._announced_dead = set(self.dead)
            self.get_logger().info(f"world: step {k} begins with {len(self._live())} robots; "
                                   f"dead: {ranges(sorted(self.dead)) or 'none'}")
        ids, truth = w.truth()
        self.truth_pub.publish(convert.target_set(convert.TEAM_ID, k, ids, truth, len(ids),
                                                  self.dt, self.frame_id))
        positions = w.robot_positions
        pieces = []
        for r in self.ids:
            pose = serialize_message(convert.pose_stamped(positions[r], k, self.dt,
                                                          self.frame_id))
            # Nobody in the run reads a robot's pose topic: written while watched.
            bundle.publish_watched(self.pose_pubs[r], pose)
            pieces.append((self._topics[r][0], pose))
        h = convert.header(k, self.dt, self.frame_id)
        for r, z in w.scans().items():
            scan = convert.encode_scan(k, self.dt, self.frame_id, r, positions[r], z, self.key)
            self.scan_pubs[r].publish(scan)
            pieces.append((self._topics[r][1], scan))
        # The observers' copy: one sample for the whole team (bundle.py).
        self.outputs_pub.publish(bundle.pack_cdr(h.stamp.sec, h.stamp.nanosec, self.frame_id,
                                                 bundle.WORLD, k, pieces))
        if self.params["publish_markers"]:
            self.markers_pub.publish(world_markers_cdr(
                convert.stamp(k, self.dt), self.frame_id, positions, w.alive,
                self.scenario.models.detection.radius, truth,
                size=marker_size(self.scenario.env)))
        self._phase = "stepping"
        self._phase_since = time.monotonic()

    # --------------------------------------------------------------- statuses
    def _on_team_status(self, msg: RobotStatus) -> None:
        if msg.robot_id not in self._known:
            self._reject(f"status of robot {msg.robot_id} on {T.TEAM_STATUS}: no robot of "
                         "this run")
            return
        self._on_status(msg.robot_id, msg)

    def _on_status(self, topic_id: int, msg: RobotStatus) -> None:
        if msg.state not in (RobotStatus.STATE_READY, RobotStatus.STATE_STEP_DONE,
                             RobotStatus.STATE_WORKING):
            self._reject(f"robot {topic_id}: unknown status state {msg.state}")
            return
        self.heard[topic_id] = time.monotonic()
        if msg.state == RobotStatus.STATE_READY and self._phase == "stepping" \
                and topic_id not in self.dead:
            self._kill({topic_id}, "restarted (it reported READY again)")
            if self.params["mode"] == "lockstep":
                self._maybe_finish_step()
        if topic_id in self.dead and self._phase in ("stepping", "waiting") \
                and topic_id not in self.returning:
            self.returning.add(topic_id)
            self.get_logger().warning(f"world: robot {topic_id} is back; it rejoins at the "
                                      "next step")
        if msg.state == RobotStatus.STATE_READY:
            self.ready.add(topic_id)
            return
        if msg.state != RobotStatus.STATE_STEP_DONE:
            return
        goal = np.array([msg.goal.x, msg.goal.y])
        if not np.all(np.isfinite(goal)):
            self._reject(f"robot {topic_id}: non-finite goal at step {msg.step}")
            return
        if topic_id in self.dead:
            return
        self.goals[topic_id] = goal
        if msg.step == self._current:
            self.reported.add(topic_id)
            if self.params["mode"] == "lockstep":
                self._maybe_finish_step()

    def _reject(self, reason: str) -> None:
        self.rejected += 1
        self.get_logger().warning(f"world: rejected {reason}")

    # ------------------------------------------------------------------ steps
    def _live(self) -> set[int]:
        return {r for r in self.ids if r not in self.dead}

    def _maybe_finish_step(self) -> None:
        if self._phase == "stepping" and self._live() <= self.reported:
            self._end_step()

    def _end_step(self) -> None:
        w = self.world
        w.apply_goals({r: g for r, g in self.goals.items() if r not in self.dead})
        if self.params["mode"] == "lockstep":
            self.goals = {}
        w.advance()
        if w.done:
            self._finish_run()
        else:
            self._publish_step()

    def _finish_run(self) -> None:
        k = self.world.step_index
        self.clock_pub.publish(ClockMsg(clock=convert.stamp(k, self.dt)))
        self._publish_team(k)
        wall = time.monotonic() - self._started_wall
        self.get_logger().info(f"{DONE_LINE}, {k} steps in {wall:.1f} s wall "
                               f"({k * self.dt / max(wall, 1e-9):.2f} x real time); dead "
                               f"robots: {sorted(self.dead) or 'none'}")
        self._phase = "lingering"
        self._phase_since = time.monotonic()

    def _kill(self, robots: set[int], why: str) -> None:
        for r in sorted(robots):
            self.dead.add(r)
            self.world.kill(r)
            self.get_logger().error(f"world: robot {r} {why}; it counts as dead")

    def _on_watchdog(self) -> None:
        waited = time.monotonic() - self._phase_since
        if self._phase == "waiting":
            self._wait_for_team()
        elif self._phase == "stepping":
            self._kill_silent()
        elif self._phase == "lingering" and waited >= self.params["linger"]:
            for pub in (self.team_pub, self.truth_pub, self.clock_pub):
                pub.wait_for_all_acked(Duration(seconds=5.0))
            self._phase = "finished"
            self.finished = True

    def _kill_silent(self) -> None:
        """Count dead the live robots not heard from for ``step_timeout`` wall seconds.

        Lockstep: of those that have not reported the current step, silent since the step
        began. Real time: any live robot silent since stepping began, for ``step_timeout``
        or two step periods, whichever is longer (a late robot that still sends statuses
        keeps its last goal, a silent one is taken out and may rejoin).
        """
        timeout = self.params["step_timeout"]
        now = time.monotonic()
        lockstep = self.params["mode"] == "lockstep"
        since = self._phase_since if lockstep else self._started_wall
        if not lockstep:
            # An idle robot is heard once per step (its report): allow two step periods.
            timeout = max(timeout, 2.0 * self.dt / self.params["realtime_factor"])
        if now - since < timeout:
            return
        waiting = self._live() - self.reported if lockstep else self._live()
        silent = {r for r in waiting
                  if now - max(self.heard.get(r, 0.0), since, self._revived.get(r, 0.0))
                  >= timeout}
        if silent:
            self._kill(silent, f"did not report step {self._current} and was not heard from "
                               f"for {timeout} s")
            if lockstep:
                self._maybe_finish_step()

    def _wait_for_team(self) -> None:
        """Start step 0 once the team is ready; give up honestly if it stops coming up."""
        now = time.monotonic()
        observers = self.truth_pub.get_subscription_count()
        need = self.params["observers"]
        count = len(self.ready) + min(observers, need)
        if count > self._ready_progress[0]:
            self._ready_progress = (count, now)
        if set(self.ids) <= self.ready and observers >= need:
            self._check_duplicates()
            self.get_logger().info(f"world: all {len(self.ids)} robots and {need} "
                                   f"{READY_LINE} {now - self._phase_since:.1f} s")
            self._started_wall = now
            self._publish_step()
            return
        missing = sorted(set(self.ids) - self.ready)
        if now - self._ready_logged >= READY_LOG_PERIOD:
            self._ready_logged = now
            self.get_logger().info(f"world: waiting for the team: {len(self.ready)} of "
                                   f"{len(self.ids)} robots ready, {min(observers, need)} of "
                                   f"{need} observers")
        timeout = self.params["ready_timeout"]
        if now - self._ready_progress[1] < timeout:
            return
        self._check_duplicates()
        seen = [r for r in missing if self.count_publishers(T.robot_topic(r, "status")) > 0]
        unseen = [r for r in missing if r not in seen]
        causes = []
        if unseen:
            causes.append(f"robots {ranges(unseen)} are not in the ROS graph: their processes "
                          "did not start, exited (see their logs), or were not discovered "
                          "(with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST only 32 DDS "
                          "participants per host find each other; use the repository's "
                          "Fast DDS profile, run_swarm.sh --dds profile, the default above "
                          "30 processes, or --robots-per-process)")
        if seen:
            causes.append(f"robots {ranges(seen)} run but did not report READY: they wait "
                          "for the team state, their contacts' inboxes or the observers to "
                          "match (see their logs)")
        if observers < need:
            causes.append(f"only {observers} of {need} observers (monitor, recorder) "
                          "subscribed to the truth")
        self.get_logger().error(
            f"world: start-up failed: {len(self.ready)} of {len(self.ids)} robots ready and "
            f"nothing new for {timeout:g} s; "
            + (f"missing robots {ranges(missing)}; " if missing else "")
            + "; ".join(causes) + ". No step was run.")
        self.exit_code = EXIT_NOT_READY
        self._phase = "failed"
        self.finished = True

    def _on_realtime_tick(self) -> None:
        if self._phase == "stepping":
            self._end_step()

    def health(self) -> WorldHealth:
        """What the world reports on ``/diagnostics`` (:mod:`phd_swarm.nodes.diagnostics`).

        In real time its lag is the steps the wall clock's timer has called for since step 0
        minus the steps done.
        """
        now = time.monotonic()
        stepping = self._phase == "stepping"
        mode = self.params["mode"]
        lag = None
        if mode == "realtime" and stepping:
            period = self.dt / self.params["realtime_factor"]
            lag = max((now - self._started_wall) / period - self.world.step_index, 0.0)
        return WorldHealth(
            self._phase, mode, steps_done=self.world.step_index, steps=self.scenario.steps,
            step=self._current if stepping else -1, robots=len(self.ids),
            ready=len(self.ready), dead=tuple(sorted(self.dead)),
            waiting_for=tuple(sorted(self._live() - self.reported)) if stepping else (),
            step_wait_s=now - self._phase_since if stepping else 0.0,
            step_timeout=self.params["step_timeout"], realtime_lag=lag,
            rejected=self.rejected, rejoins=sum(self.rejoins.values()))

    def _check_duplicates(self) -> None:
        for r in self.ids:
            n = self.count_publishers(T.robot_topic(r, "status"))
            if n > 1:
                self.get_logger().error(f"world: duplicate robot id {r}: {n} nodes publish "
                                        f"{T.robot_topic(r, 'status')}")


def main(args: list[str] | None = None) -> int:
    """Run the world node (``python -m phd_swarm.nodes.world --ros-args ...``)."""
    from phd_swarm.nodes.spin import spin_nodes

    return spin_nodes(lambda: [WorldNode()], args)


if __name__ == "__main__":
    sys.exit(main())
