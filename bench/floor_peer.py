"""One process of the floor benchmark (bench/floor.py): a robot, the stepper or an observer.

Usage (bench/floor.py starts these; by hand only to debug one)::

    python bench/floor_peer.py robot|stepper|observer --index I --robots N --steps S
        [--contacts 16] [--phases 3] [--envelope-bytes 1000] [--bundle-bytes 8000]
        [--world-bytes 1000] [--status-bytes 200] [--observers 1] [--no-clock]
        [--send inbox|outbox]

The message pattern of a lockstep team with no work done (issue 39). Every message is a
``std_msgs/UInt8MultiArray`` of the given size published as CDR bytes, and every
subscription is raw, so no Python message object is built on either side; its first data
bytes say (sender, step, phase). Topics and QoS are the real ones
(:mod:`phd_swarm.nodes.qos`):

- ``stepper`` (the world): for step k, a ``/clock`` tick (a real
  ``rosgraph_msgs/Clock``, unless ``--no-clock``), one team state on ``/world/robots``
  and one measurement set per robot on ``/robot_<r>/measurements``; step k + 1 when every
  robot's status of step k is in. After the last step, and when told ``stop`` on stdin, one team
  state of step S: the end for everyone.
- ``robot`` r: step k starts when its team state and measurement set are in; in each of
  ``--phases`` phases it sends one envelope to each contact's ``/robot_<c>/inbox`` (its
  contacts: r +- 1 .. r +- contacts / 2 on a ring, :func:`contacts`) and waits for its
  contacts' envelopes of that phase; then it publishes a status on ``/team/status`` and a
  bundle on ``/team/outputs``. With ``--send outbox`` it sends each phase's envelope once,
  on its own ``/robot_<r>/outbox``, which its contacts read (one writer and ``contacts``
  readers per robot: the same bytes reach every contact, as a state or a cell does).
- ``observer`` (the monitor): reads ``/team/status`` and ``/team/outputs``.

Robots and observers run on sim time (``use_sim_time``, as the real runs' configs have
it; not with ``--no-clock``): rclpy's time source reads every tick.

Prints JSON lines on stdout: ``{"waiting": "<what has not matched>"}`` every 2 s until
every writer has its readers, then ``{"ready": <unix time>}``. The stepper then waits for
``go`` on stdin, steps, prints ``{"waiting": "step k: no status from robots [...]"}`` when
a step takes over 10 s, ``{"done": ..., "wall_s": ..., "step_ms": [...]}`` after the last
step, and waits for ``stop``. A robot prints ``{"steps_done": n}`` at the end, an observer
``{"statuses": n, "bundles": n}`` once it has them all (at most 5 s later). The executor
and spin loop are those of :func:`phd_swarm.nodes.spin.spin_nodes` (rclpy's EventsExecutor
unless ``PHD_SWARM_EXECUTOR=single``), repeated here because that module imports the whole
package (numpy, scipy), which a floor process should not carry.
"""

from __future__ import annotations

import argparse
import faulthandler
import json
import os
import signal
import struct
import sys
import threading
import time
from collections import Counter
from dataclasses import dataclass

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from rclpy.clock import Clock as RosClock
from rclpy.clock import ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future
from rclpy.timer import Timer
from rosgraph_msgs.msg import Clock
from std_msgs.msg import UInt8MultiArray

from phd_swarm.nodes.qos import CLOCK, INBOX_PUB, INBOX_SUB, STEP_PUB, STEP_SUB

# The real topic names (phd_swarm.nodes.topics, not imported: it brings numpy and scipy).
WORLD_ROBOTS = "/world/robots"
TEAM_STATUS = "/team/status"
TEAM_OUTPUTS = "/team/outputs"
CLOCK_TOPIC = "/clock"

#: (sender, step, phase) at the start of a message's data.
HEAD = struct.Struct("<iii")
#: Where the data of a serialised UInt8MultiArray starts: CDR encapsulation (4 bytes), an
#: empty layout (dims length, data_offset), the data's length.
DATA_AT = 16
#: The world's sender id in a message's head.
WORLD = -1
#: The clock of every timer here.
STEADY = RosClock(clock_type=ClockType.STEADY_TIME)
#: Seconds between two ``waiting`` lines.
WAIT_REPORT_S = 2.0
#: Seconds a step may take before the stepper names the robots it waits for.
SLOW_STEP_S = 10.0
#: Seconds an observer waits after the end for statuses and bundles still on their way.
OBSERVER_GRACE_S = 5.0


@dataclass(frozen=True)
class FloorConfig:
    """One process's part: its role and index, and the team's message pattern."""

    role: str
    index: int
    robots: int
    steps: int
    contacts: int = 16
    phases: int = 3
    envelope_bytes: int = 1000
    bundle_bytes: int = 8000
    world_bytes: int = 1000
    status_bytes: int = 200
    observers: int = 1
    clock: bool = True
    #: ``inbox``: an envelope per contact on its inbox; ``outbox``: one on the own outbox.
    send: str = "inbox"


def contacts(robot: int, robots: int, count: int) -> np.ndarray:
    """Robot ``robot``'s contacts on a ring of ``robots``: r +- 1 .. r +- count // 2, sorted.

    Symmetric (j is a contact of i iff i is one of j's), as the real nearest neighbours
    are; fewer than ``count`` when the ring is shorter (all the others at most).
    """
    d = np.arange(1, count // 2 + 1)
    ring = np.unique(np.concatenate([robot + d, robot - d]) % robots)
    return ring[ring != robot]


def payload(size: int) -> bytearray:
    """A serialised UInt8MultiArray of ``size`` bytes in all (room for the head at least)."""
    return bytearray(serialize_message(UInt8MultiArray(data=bytes(max(size - DATA_AT,
                                                                      HEAD.size)))))


def stamp(buf: bytearray, sender: int, step: int, phase: int = 0) -> bytes:
    """``buf`` with its head set to (sender, step, phase), as bytes to publish."""
    HEAD.pack_into(buf, DATA_AT, sender, step, phase)
    return bytes(buf)


def head(data: bytes) -> tuple[int, int, int]:
    """(sender, step, phase) of a message's CDR bytes."""
    return HEAD.unpack_from(data, DATA_AT)


def say(**line: object) -> None:
    """One JSON line on stdout, for the parent."""
    print(json.dumps(line), flush=True)


class FloorProcess(Node):
    """What the three roles share: the ready check and the end."""

    def __init__(self, name: str, cfg: FloorConfig, sim_time: bool = False) -> None:
        super().__init__(name, parameter_overrides=[
            Parameter("use_sim_time", value=sim_time and cfg.clock)])
        self.cfg = cfg
        self.finished = False
        self.ready = False
        self._reported = 0.0
        self._ready_timer = self.every(0.25, self._check_ready)

    def every(self, period: float, callback) -> Timer:
        """A timer on the steady clock (the ROS clock is sim time: still between steps)."""
        return self.create_timer(period, callback, clock=STEADY)

    def unmatched(self) -> list[str]:
        """The writers still short of readers, in words; empty once all are matched."""
        return []

    def on_ready(self) -> None:
        """Called once, when every writer has its readers."""

    def _check_ready(self) -> None:
        missing = self.unmatched()
        if missing:
            now = time.monotonic()
            if now - self._reported >= WAIT_REPORT_S:
                self._reported = now
                say(waiting="; ".join(missing))
            return
        self._ready_timer.cancel()
        self.ready = True
        say(ready=time.time())
        self.on_ready()


def _short(pub, need: int, topic: str) -> list[str]:
    n = pub.get_subscription_count()
    return [f"{topic}: {n} of {need} readers"] if n < need else []


class FloorRobot(FloorProcess):
    """A robot's messages and waits, no work (see the module docstring)."""

    def __init__(self, cfg: FloorConfig) -> None:
        super().__init__(f"floor_robot_{cfg.index}", cfg, sim_time=True)
        r = cfg.index
        self.contacts = contacts(r, cfg.robots, cfg.contacts)
        if cfg.send == "outbox":
            self.inboxes = [self.create_publisher(UInt8MultiArray, f"/robot_{r}/outbox",
                                                  INBOX_PUB)]
            for c in self.contacts:
                self.create_subscription(UInt8MultiArray, f"/robot_{c}/outbox",
                                         self._on_envelope, INBOX_SUB, raw=True)
        else:
            self.inboxes = [self.create_publisher(UInt8MultiArray, f"/robot_{c}/inbox",
                                                  INBOX_PUB) for c in self.contacts]
            self.create_subscription(UInt8MultiArray, f"/robot_{r}/inbox", self._on_envelope,
                                     INBOX_SUB, raw=True)
        self.status_pub = self.create_publisher(UInt8MultiArray, TEAM_STATUS, STEP_PUB)
        self.outputs_pub = self.create_publisher(UInt8MultiArray, TEAM_OUTPUTS, STEP_PUB)
        self.create_subscription(UInt8MultiArray, WORLD_ROBOTS, self._on_team, STEP_SUB,
                                 raw=True)
        self.create_subscription(UInt8MultiArray, f"/robot_{r}/measurements", self._on_scan,
                                 STEP_SUB, raw=True)
        self.envelope = payload(cfg.envelope_bytes)
        self.status = payload(cfg.status_bytes)
        self.bundle = payload(cfg.bundle_bytes)
        self.team_step = self.scan_step = -1
        #: The next step to do, and the one in progress (None between steps) at ``phase``.
        self.next = 0
        self.step: int | None = None
        self.phase = 0
        #: Envelopes heard per (step, phase); a contact may be a phase ahead.
        self.heard: Counter[tuple[int, int]] = Counter()

    def unmatched(self) -> list[str]:
        """Contacts' inboxes without a reader, and the team topics short of readers."""
        need = self.cfg.observers
        if self.cfg.send == "outbox":
            return _short(self.inboxes[0], len(self.contacts), "outbox") \
                + _short(self.status_pub, 1 + need, TEAM_STATUS) \
                + _short(self.outputs_pub, need, TEAM_OUTPUTS)
        no_reader = [int(c) for c, pub in zip(self.contacts, self.inboxes, strict=True)
                     if pub.get_subscription_count() < 1]
        return ([f"inboxes of robots {no_reader}: no reader"] if no_reader else []) \
            + _short(self.status_pub, 1 + need, TEAM_STATUS) \
            + _short(self.outputs_pub, need, TEAM_OUTPUTS)

    def _on_team(self, data: bytes) -> None:
        step = head(data)[1]
        if step >= self.cfg.steps:
            say(steps_done=self.next)
            self.finished = True
            return
        self.team_step = max(self.team_step, step)
        self._start()

    def _on_scan(self, data: bytes) -> None:
        self.scan_step = max(self.scan_step, head(data)[1])
        self._start()

    def _on_envelope(self, data: bytes) -> None:
        _, step, phase = head(data)
        self.heard[step, phase] += 1
        if step == self.step:
            self._advance()

    def _start(self) -> None:
        if self.step is None and min(self.team_step, self.scan_step) >= self.next:
            self.step, self.phase = self.next, 0
            self._send()
            self._advance()

    def _send(self) -> None:
        data = stamp(self.envelope, self.cfg.index, self.step, self.phase)
        for pub in self.inboxes:
            pub.publish(data)

    def _advance(self) -> None:
        """Go through the phases whose envelopes are all in; finish the step after the last."""
        while self.step is not None and self.heard[self.step, self.phase] >= len(self.contacts):
            del self.heard[self.step, self.phase]
            self.phase += 1
            if self.phase < self.cfg.phases:
                self._send()
            else:
                self._finish()

    def _finish(self) -> None:
        k = self.step
        self.status_pub.publish(stamp(self.status, self.cfg.index, k))
        self.outputs_pub.publish(stamp(self.bundle, self.cfg.index, k))
        self.step, self.next = None, k + 1


class FloorStepper(FloorProcess):
    """The world's part: a step's team state and measurement sets, then wait for statuses."""

    def __init__(self, cfg: FloorConfig) -> None:
        super().__init__("floor_stepper", cfg)
        self.team_pub = self.create_publisher(UInt8MultiArray, WORLD_ROBOTS, STEP_PUB)
        self.clock_pub = (self.create_publisher(Clock, CLOCK_TOPIC, CLOCK) if cfg.clock
                          else None)
        self.scan_pubs = [self.create_publisher(UInt8MultiArray, f"/robot_{r}/measurements",
                                                STEP_PUB) for r in range(cfg.robots)]
        self.create_subscription(UInt8MultiArray, TEAM_STATUS, self._on_status, STEP_SUB,
                                 raw=True)
        self.world = payload(cfg.world_bytes)
        self.step = -1
        self.started = 0.0
        self.step_at = 0.0
        self.step_ms: list[float] = []
        #: Robots whose status of the current step is in.
        self.done = np.zeros(cfg.robots, dtype=bool)
        self.commands = {"go": threading.Event(), "stop": threading.Event()}
        threading.Thread(target=self._read_commands, daemon=True).start()
        self._poll = None

    def unmatched(self) -> list[str]:
        """The team state's readers (robots and observers) and the measurement sets'."""
        need = self.cfg.robots + self.cfg.observers
        no_reader = [r for r, pub in enumerate(self.scan_pubs)
                     if pub.get_subscription_count() < 1]
        clock = [] if self.clock_pub is None else _short(self.clock_pub, need, CLOCK_TOPIC)
        return _short(self.team_pub, need, WORLD_ROBOTS) + clock \
            + ([f"measurements of robots {no_reader}: no reader"] if no_reader else [])

    def _read_commands(self) -> None:
        for line in sys.stdin:
            event = self.commands.get(line.strip())
            if event is not None:
                event.set()
        self.commands["stop"].set()  # the parent is gone

    def on_ready(self) -> None:
        """Wait for ``go`` on stdin (a thread reads it; a timer looks)."""
        self._poll = self.every(0.05, self._wait_for_go)

    def _wait_for_go(self) -> None:
        if not self.commands["go"].is_set():
            return
        self._poll.cancel()
        # A slow step is named once a second; cheap next to a step's messages.
        self._poll = self.every(1.0, self._watch)
        self.started = time.monotonic()
        self._publish(0)

    def _publish(self, k: int) -> None:
        self.step, self.step_at = k, time.monotonic()
        self.done[:] = False
        if self.clock_pub is not None:
            # The world's tick: step k at 2 Hz (its CDR, as the world's Clock message).
            self.clock_pub.publish(Clock(clock=Time(sec=k // 2, nanosec=k % 2 * 500_000_000)))
        self.team_pub.publish(stamp(self.world, WORLD, k))
        for r, pub in enumerate(self.scan_pubs):
            pub.publish(stamp(self.world, r, k))

    def _on_status(self, data: bytes) -> None:
        robot, k, _ = head(data)
        if k != self.step or not 0 <= robot < self.cfg.robots:
            return
        self.done[robot] = True
        if not self.done.all():
            return
        now = time.monotonic()
        self.step_ms.append(round((now - self.step_at) * 1e3, 2))
        if k + 1 < self.cfg.steps:
            self._publish(k + 1)
            return
        self.step = self.cfg.steps
        say(done=time.time(), wall_s=now - self.started, step_ms=self.step_ms)
        self._poll.cancel()
        self._poll = self.every(0.05, self._wait_for_stop)

    def _watch(self) -> None:
        if 0 <= self.step < self.cfg.steps and time.monotonic() - self.step_at > SLOW_STEP_S:
            say(waiting=f"step {self.step}: no status from robots "
                        f"{np.flatnonzero(~self.done).tolist()}")

    def _wait_for_stop(self) -> None:
        if self.commands["stop"].is_set():
            self.team_pub.publish(stamp(self.world, WORLD, self.cfg.steps))
            self._poll.cancel()
            self.finished = True


class FloorObserver(FloorProcess):
    """The monitor's part: reads every status and bundle."""

    def __init__(self, cfg: FloorConfig) -> None:
        super().__init__(f"floor_observer_{cfg.index}", cfg, sim_time=True)
        self.counts = {"statuses": 0, "bundles": 0}
        self._end: float | None = None
        self.create_subscription(UInt8MultiArray, TEAM_STATUS, self._on_status, STEP_SUB,
                                 raw=True)
        self.create_subscription(UInt8MultiArray, TEAM_OUTPUTS, self._on_bundle, STEP_SUB,
                                 raw=True)
        self.create_subscription(UInt8MultiArray, WORLD_ROBOTS, self._on_team, STEP_SUB,
                                 raw=True)

    def _on_status(self, data: bytes) -> None:
        self.counts["statuses"] += 1

    def _on_bundle(self, data: bytes) -> None:
        self.counts["bundles"] += 1

    def _on_team(self, data: bytes) -> None:
        if head(data)[1] >= self.cfg.steps and self._end is None:
            # The last bundles may still be on their way (another topic): wait a little.
            self._end = time.monotonic() + OBSERVER_GRACE_S
            self.every(0.05, self._finish)

    def _finish(self) -> None:
        expected = self.cfg.robots * self.cfg.steps
        if min(self.counts.values()) >= expected or time.monotonic() > self._end:
            say(**self.counts)
            self.finished = True


ROLES = {"robot": FloorRobot, "stepper": FloorStepper, "observer": FloorObserver}


def make_executor():
    """The executor of :func:`phd_swarm.nodes.spin.make_executor`, chosen the same way."""
    if os.environ.get("PHD_SWARM_EXECUTOR", "events") == "single":
        from rclpy.executors import SingleThreadedExecutor

        return SingleThreadedExecutor()
    from rclpy.experimental import EventsExecutor

    return EventsExecutor()


def spin(cfg: FloorConfig) -> int:
    """Run one process's node as spin_nodes runs a robot's: until finished or a signal."""
    stop: list[bool] = []
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(True))
    node = None
    try:
        node = ROLES[cfg.role](cfg)
        executor = make_executor()
        executor.add_node(node)
        never = Future()
        while not stop and rclpy.ok() and not node.finished:
            executor.spin_until_future_complete(never, timeout_sec=0.1)
        # The last status and the end's team state reach their readers before the writers go.
        for pub in list(node.publishers):
            pub.wait_for_all_acked(Duration(seconds=2))
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def parse_args(argv: list[str]) -> FloorConfig:
    """The command line (see the module docstring)."""
    p = argparse.ArgumentParser(prog="bench/floor_peer.py")
    p.add_argument("role", choices=sorted(ROLES))
    p.add_argument("--index", type=int, default=0)
    p.add_argument("--robots", type=int, required=True)
    p.add_argument("--steps", type=int, required=True)
    for name, default in (("contacts", 16), ("phases", 3), ("envelope-bytes", 1000),
                          ("bundle-bytes", 8000), ("world-bytes", 1000), ("status-bytes", 200),
                          ("observers", 1)):
        p.add_argument(f"--{name}", type=int, default=default)
    p.add_argument("--no-clock", action="store_true", help="no /clock, no sim time")
    p.add_argument("--send", choices=("inbox", "outbox"), default="inbox")
    a = p.parse_args(argv)
    return FloorConfig(a.role, a.index, a.robots, a.steps, a.contacts, a.phases,
                       a.envelope_bytes, a.bundle_bytes, a.world_bytes, a.status_bytes,
                       a.observers, not a.no_clock, a.send)


if __name__ == "__main__":
    # The parent asks a process that does not exit for its stack (bench/floor.py).
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    sys.exit(spin(parse_args(sys.argv[1:])))
