"""World-simulator node: owns time, the true targets, the robots' kinematics and sensors.

A thin adapter over :class:`phd_swarm.sim.world.World` (targets of Dames Sec. IV and Chen
Sec. 4, holonomic robots with a speed limit, Chen eq. 3; the sensor of Dames eq. 9-11).
Per step k it publishes ``/clock`` (t = k dt), the team state (``/world/robots``), the truth
(``/world/truth``), each live robot's pose and measurement set Z_r^k
(``/robot_<r>/pose``, ``/robot_<r>/measurements``) and markers, then collects each robot's
``STEP_DONE`` status (goal g_r) from ``/robot_<r>/status``:

- lockstep (default): step k+1 starts when every live robot has reported step k; a robot
  that has not reported within ``step_timeout`` wall seconds counts as dead (the world
  stops scanning and moving it, and says so in the team state);
- realtime: steps follow a wall-clock timer at ``dt / realtime_factor``; a robot that has
  not reported keeps its last goal.

Before step 0 the world publishes the initial team state and waits (``ready_timeout``) for
every robot's ``READY`` status and for ``observers`` subscribers on the truth. After the last
step it publishes the final team state, keeps spinning ``linger`` seconds so that observers
receive everything, and sets :attr:`finished`.
"""

from __future__ import annotations

import sys
import time

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg
from visualization_msgs.msg import MarkerArray

from phd_swarm.nodes import convert
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.markers import world_markers
from phd_swarm.nodes.param_specs import SHARED, WORLD
from phd_swarm.nodes.params import declare, declare_scenario
from phd_swarm.nodes.qos import publisher_qos, subscription_qos
from phd_swarm.sim.world import World
from phd_swarm_msgs.msg import MeasurementSet, RobotStatus, TargetSet, TeamState


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
    """

    def __init__(self, **kwargs) -> None:
        super().__init__("world", **kwargs)
        self.params = declare(self, SHARED + WORLD)
        self.scenario = declare_scenario(self)
        self.world = World(self.scenario)
        self.frame_id = self.params["world_frame_id"]
        self.dt = self.scenario.dt
        self.ids = [int(i) for i in self.world.robot_ids]
        self.finished = False
        self.dead: set[int] = set()
        self.rejected = 0
        self.ready: set[int] = set()
        self.goals: dict[int, np.ndarray] = {}
        self.reported: set[int] = set()
        self._phase = "waiting"
        self._phase_since = time.monotonic()
        self._started_wall = 0.0
        self._current = -1

        self.clock_pub = self.create_publisher(ClockMsg, T.CLOCK, publisher_qos("CLOCK"))
        self.truth_pub = self.create_publisher(TargetSet, T.WORLD_TRUTH, publisher_qos("STEP"))
        self.team_pub = self.create_publisher(TeamState, T.WORLD_ROBOTS, publisher_qos("STEP"))
        self.markers_pub = self.create_publisher(MarkerArray, T.WORLD_MARKERS,
                                                 publisher_qos("OBSERVATION"))
        self.scan_pubs = {r: self.create_publisher(MeasurementSet,
                                                   T.robot_topic(r, "measurements"),
                                                   publisher_qos("STEP")) for r in self.ids}
        self.pose_pubs = {r: self.create_publisher(PoseStamped, T.robot_topic(r, "pose"),
                                                   publisher_qos("LATCHED")) for r in self.ids}
        for r in self.ids:
            self.create_subscription(RobotStatus, T.robot_topic(r, "status"),
                                     self._make_status_callback(r), subscription_qos("STEP"))
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(0.05, self._on_watchdog, clock=steady)
        if self.params["mode"] == "realtime":
            period = self.dt / self.params["realtime_factor"]
            self._rt_timer = self.create_timer(period, self._on_realtime_tick, clock=steady)
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
        self.clock_pub.publish(ClockMsg(clock=convert.stamp(k, self.dt)))
        if k > 0:
            self._publish_team(k)
        ids, truth = w.truth()
        self.truth_pub.publish(convert.target_set(convert.TEAM_ID, k, ids, truth, len(ids),
                                                  self.dt, self.frame_id))
        positions = w.robot_positions
        for r in self.ids:
            self.pose_pubs[r].publish(convert.pose_stamped(positions[r], k, self.dt,
                                                           self.frame_id))
        for r, z in w.scans().items():
            h = convert.header(k, self.dt, self.frame_id)
            self.scan_pubs[r].publish(MeasurementSet(
                header=h, robot_id=r, step=k, sensor_position=convert.points(positions[r])[0],
                measurements=convert.points(z)))
        if self.params["publish_markers"]:
            self.markers_pub.publish(world_markers(
                convert.stamp(k, self.dt), self.frame_id, positions, w.alive,
                self.scenario.models.detection.radius, truth))
        self._phase = "stepping"
        self._phase_since = time.monotonic()

    # --------------------------------------------------------------- statuses
    def _make_status_callback(self, topic_id: int):
        def callback(msg: RobotStatus) -> None:
            self._on_status(topic_id, msg)
        return callback

    def _on_status(self, topic_id: int, msg: RobotStatus) -> None:
        if msg.robot_id != topic_id:
            self._reject(f"status of robot {msg.robot_id} on robot {topic_id}'s topic")
            return
        if msg.state == RobotStatus.STATE_READY:
            self.ready.add(topic_id)
            return
        if msg.state != RobotStatus.STATE_STEP_DONE:
            self._reject(f"robot {topic_id}: unknown status state {msg.state}")
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
        self.get_logger().info(f"world: done, {k} steps in {wall:.1f} s wall "
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
            observers = self.truth_pub.get_subscription_count()
            everyone = set(self.ids) <= self.ready and observers >= self.params["observers"]
            if not everyone and waited < self.params["ready_timeout"]:
                return
            self._check_duplicates()
            if not everyone:
                self._kill(set(self.ids) - self.ready,
                           f"was not ready within {self.params['ready_timeout']} s")
                if observers < self.params["observers"]:
                    self.get_logger().error(f"world: only {observers} of "
                                            f"{self.params['observers']} observers matched")
            self._started_wall = time.monotonic()
            self._publish_step()
        elif self._phase == "stepping" and self.params["mode"] == "lockstep":
            if waited >= self.params["step_timeout"]:
                self._kill(self._live() - self.reported,
                           f"did not report step {self._current} within "
                           f"{self.params['step_timeout']} s")
                self._maybe_finish_step()
        elif self._phase == "lingering" and waited >= self.params["linger"]:
            for pub in (self.team_pub, self.truth_pub, self.clock_pub):
                pub.wait_for_all_acked(Duration(seconds=5.0))
            self._phase = "finished"
            self.finished = True

    def _on_realtime_tick(self) -> None:
        if self._phase == "stepping":
            self._end_step()

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
