"""The health of a run on ``/diagnostics``: what each robot, the world and the recorder report.

Every robot, the world and the recorder publish a ``diagnostic_msgs/DiagnosticArray`` on
the absolute topic ``/diagnostics`` once per wall second (:data:`PERIOD`; a steady timer,
so a report never touches what a step computes), holding one ``DiagnosticStatus`` each:
name ``phd_swarm: <who>``, hardware id ``robot_<id>``, ``world`` or ``recorder``, a level,
a one-line message and its numbers as ``KeyValue`` s. The builders here are pure: plain
values in (a :class:`RobotHealth`, :class:`WorldHealth` or :class:`RecorderHealth`, and the
previous report's, to see what grew), a status out; each node reads its state into those
values (its ``health()`` method) and publishes through a
:class:`phd_swarm.nodes.reporter.DiagnosticsReporter`.

Levels (the thresholds are the module constants):

- a robot: ERROR when the world counts it dead, or when it is :data:`LAG_ERROR` steps or
  more behind the world (the world's latest team state minus its last finished step;
  in lockstep a healthy robot is 0 or 1 behind); WARN when :data:`LAG_WARN` or more
  behind, or when its protocol timeouts, rejected messages or dead peers grew since the
  last report; else OK.
- the world: ERROR when the team never became ready (no step was run), or in real time
  when it is :data:`LAG_ERROR` steps or more behind the wall clock; WARN when robots are
  dead, when it rejected statuses since the last report, in real time :data:`LAG_WARN`
  steps behind, or in lockstep when a step has waited on its robots for
  :data:`WAIT_WARN_FRACTION` of ``step_timeout`` or longer (the robots still missing are
  named; at ``step_timeout`` they count as dead); else OK.
- the recorder: ERROR when at least :data:`GAPS_ERROR_FRACTION` of the step messages
  expected so far are missing, WARN when any is; else OK. Gaps are counted by
  :class:`GapCounter` on steps that ended :data:`GAP_SETTLE_S` wall seconds ago (what is
  still on its way is no gap); the recorder's completeness report at close is the
  authoritative one (:mod:`phd_swarm.nodes.completeness`).
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from phd_swarm.nodes import completeness
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.completeness import ranges

#: Wall seconds between two reports of a node.
PERIOD = 1.0

#: Steps behind (a robot: the world's latest step minus its last finished one; the world
#: in real time: the wall clock's step minus the step in progress) at which the level is
#: WARN, and ERROR.
LAG_WARN = 2
LAG_ERROR = 5

#: Lockstep: WARN when a step has waited this fraction of ``step_timeout`` on its robots.
WAIT_WARN_FRACTION = 0.5

#: Recorder: ERROR when this fraction of the step messages expected so far is missing.
GAPS_ERROR_FRACTION = 0.01

#: Recorder: a step counts for gaps once the team state after it is this old [s, wall].
GAP_SETTLE_S = 5.0

#: Names of the status and the hardware id: ``phd_swarm: robot_3``, ``robot_3``.
PREFIX = "phd_swarm"

#: The levels of ``diagnostic_msgs/DiagnosticStatus`` (bytes there) as ints.
OK, WARN, ERROR = (int.from_bytes(level, "little") for level in (
    DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR))

_ROBOT_TOPIC = re.compile(rf"^/{T.ROBOT_PREFIX}(\d+)/(\w+)$")


@dataclass(frozen=True)
class RobotHealth:
    """What a robot reports (see the module docstring).

    Attributes
    ----------
    robot_id : int
    state : str
        ``starting`` (before READY), ``ready`` (waiting for its next step's inputs),
        ``stepping`` (working on ``step``), ``counted dead`` (by the world; it rejoins when
        the world says so) or ``done`` (the run's last step finished).
    step : int
        The step in progress, or -1.
    finished : int
        The last step it finished, or -1.
    world_step : int
        The step of the world's latest team state it has, or -1.
    counted_dead : bool
        Whether the world counts it dead.
    contacts : tuple of int, or None
        The peers it exchanges with, None if its exchange has no contacts.
    timeouts, rejected, dropped, rejoins, revived_peers : int
        Running counters, as in its ``RobotStatus``: protocol timeouts, messages rejected
        by validation, dropped as stale, times it rejoined, peers admitted again.
    dead_peers : tuple of int
        The peers it declared dead.
    """

    robot_id: int
    state: str
    step: int = -1
    finished: int = -1
    world_step: int = -1
    counted_dead: bool = False
    contacts: tuple[int, ...] | None = None
    timeouts: int = 0
    rejected: int = 0
    dropped: int = 0
    dead_peers: tuple[int, ...] = ()
    rejoins: int = 0
    revived_peers: int = 0

    @property
    def lag(self) -> int:
        """Steps behind the world: its latest team state minus the last finished step."""
        return max(self.world_step - self.finished, 0) if self.world_step >= 0 else 0


@dataclass(frozen=True)
class WorldHealth:
    """What the world reports (see the module docstring).

    Attributes
    ----------
    phase : str
        ``waiting`` (for the team), ``stepping``, ``lingering`` (after the last step),
        ``finished`` or ``failed`` (the team never became ready).
    mode : str
        ``lockstep`` or ``realtime``.
    steps_done, steps : int
        Steps finished, and the scenario's number of steps.
    step : int
        The step in progress (-1 before step 0).
    robots, ready : int
        Team size, and robots that reported READY.
    dead : tuple of int
        Robots the world counts dead.
    waiting_for : tuple of int
        Live robots that have not reported the step in progress.
    step_wait_s : float
        Wall seconds the step in progress has lasted.
    step_timeout : float
        The world's ``step_timeout`` [s].
    realtime_lag : float or None
        Real time: steps the world is behind the wall clock; None in lockstep.
    rejected, rejoins : int
        Statuses rejected so far, and rejoins of robots so far.
    """

    phase: str
    mode: str
    steps_done: int
    steps: int
    step: int
    robots: int
    ready: int
    dead: tuple[int, ...] = ()
    waiting_for: tuple[int, ...] = ()
    step_wait_s: float = 0.0
    step_timeout: float = 15.0
    realtime_lag: float | None = None
    rejected: int = 0
    rejoins: int = 0


@dataclass(frozen=True)
class RecorderHealth:
    """What the recorder reports (see the module docstring).

    Attributes
    ----------
    messages, topics : int
        Messages written, topics subscribed.
    last_step : int
        The step of the latest team state recorded, or -1.
    gaps : dict of str to int
        Topic -> step messages missing so far (:class:`GapCounter`).
    expected : int
        Step messages expected so far (those checked for gaps).
    world_writers_pending : int
        World topics still without a writer before the truth is subscribed (start-up).
    rejected : int
        Messages it could not read its step from (recorded all the same), or that a team
        topic carried for no topic of this run (not recorded).
    """

    messages: int
    topics: int
    last_step: int = -1
    gaps: Mapping[str, int] = field(default_factory=dict)
    expected: int = 0
    world_writers_pending: int = 0
    rejected: int = 0

    @property
    def missing(self) -> int:
        """Step messages missing so far."""
        return sum(self.gaps.values())


def _status(who: str, level: int, message: str, values: Sequence[tuple[str, object]]
            ) -> DiagnosticStatus:
    return DiagnosticStatus(level=bytes([level]), name=f"{PREFIX}: {who}", message=message,
                            hardware_id=who,
                            values=[KeyValue(key=k, value=str(v)) for k, v in values])


def _ids(ids: Iterable[int]) -> str:
    return ranges(ids) or "none"


def _grew(now: int, before: int | None) -> bool:
    return before is not None and now > before


def robot_status(h: RobotHealth, previous: RobotHealth | None = None) -> DiagnosticStatus:
    """The status of a robot: its state, lag, contacts and counters, and its level.

    ``previous`` is the health of the last report (None for the first): counters that
    grew since then make it WARN (module docstring).
    """
    p = previous
    level, problems = OK, []
    if h.counted_dead:
        level = ERROR
        problems.append("counted dead by the world")
    if h.lag >= LAG_WARN:
        level = max(level, ERROR if h.lag >= LAG_ERROR else WARN)
        problems.append(f"{h.lag} steps behind the world")
    grown = [name for name, now, before in (
        ("timeouts", h.timeouts, p and p.timeouts),
        ("rejected messages", h.rejected, p and p.rejected))
        if _grew(now, before)]
    new_dead = sorted(set(h.dead_peers) - set(p.dead_peers)) if p is not None else []
    if new_dead:
        grown.append(f"dead peers ({_ids(new_dead)} new)")
    if grown:
        level = max(level, WARN)
        problems.append("more " + ", ".join(grown) + " since the last report")
    doing = {"stepping": f"working on step {h.step}",
             "ready": f"ready for step {h.finished + 1}"}.get(h.state, h.state)
    values = [("state", h.state), ("step", h.step), ("last_finished_step", h.finished),
              ("world_step", h.world_step), ("step_lag", h.lag),
              ("contacts", "n/a" if h.contacts is None else len(h.contacts)),
              ("contact_ids", "n/a" if h.contacts is None else _ids(h.contacts)),
              ("timeouts", h.timeouts), ("rejected_messages", h.rejected),
              ("dropped_messages", h.dropped), ("dead_peers", _ids(h.dead_peers)),
              ("rejoins", h.rejoins), ("revived_peers", h.revived_peers)]
    return _status(f"{T.ROBOT_PREFIX}{h.robot_id}", level, "; ".join([doing, *problems]),
                   values)


def world_status(h: WorldHealth, previous: WorldHealth | None = None) -> DiagnosticStatus:
    """The status of the world: steps, the step it waits on, lag, robots, rejections."""
    level, problems = OK, []
    if h.phase == "failed":
        level = ERROR
        problems.append("the team did not become ready; no step was run")
    lag = h.realtime_lag
    if lag is not None and lag >= LAG_WARN:
        level = max(level, ERROR if lag >= LAG_ERROR else WARN)
        problems.append(f"{lag:.1f} steps behind real time")
    if h.mode == "lockstep" and h.phase == "stepping" \
            and h.step_wait_s >= WAIT_WARN_FRACTION * h.step_timeout:
        level = max(level, WARN)
        problems.append(f"step {h.step} has waited {h.step_wait_s:.1f} s for robots "
                        f"{_ids(h.waiting_for)}")
    if h.dead:
        level = max(level, WARN)
        problems.append(f"robots {_ids(h.dead)} dead")
    if previous is not None and h.rejected > previous.rejected:
        level = max(level, WARN)
        problems.append(f"{h.rejected - previous.rejected} statuses rejected since the "
                        "last report")
    doing = {"waiting": f"waiting for the team: {h.ready} of {h.robots} robots ready",
             "stepping": f"step {h.step} of {h.steps}",
             "lingering": f"done: {h.steps_done} steps",
             "finished": f"done: {h.steps_done} steps",
             "failed": "start-up failed"}.get(h.phase, h.phase)
    values = [("phase", h.phase), ("mode", h.mode), ("steps_done", h.steps_done),
              ("steps", h.steps), ("step", h.step),
              ("waiting_for", _ids(h.waiting_for)), ("step_wait_s", f"{h.step_wait_s:.2f}"),
              ("realtime_lag_steps", "n/a" if lag is None else f"{lag:.2f}"),
              ("robots", h.robots), ("robots_ready", h.ready),
              ("robots_alive", h.robots - len(h.dead)), ("robots_dead", _ids(h.dead)),
              ("rejoins", h.rejoins), ("rejected_messages", h.rejected)]
    return _status("world", level, "; ".join([doing, *problems]), values)


def recorder_status(h: RecorderHealth, previous: RecorderHealth | None = None,
                    shown: int = 8) -> DiagnosticStatus:
    """The status of the recorder: messages written, steps recorded and gaps so far.

    ``shown``: most topics with gaps named in ``gap_topics``.
    """
    missing = h.missing
    level, problems = OK, []
    if missing:
        heavy = missing >= GAPS_ERROR_FRACTION * max(h.expected, 1)
        level = ERROR if heavy else WARN
        gaps = sorted((t for t, n in h.gaps.items() if n), key=lambda t: -h.gaps[t])
        problems.append(f"{missing} of {h.expected} step messages missing so far, on "
                        f"{len(gaps)} topics")
    else:
        gaps = []
    doing = (f"waiting for the world's writers on {h.world_writers_pending} topics"
             if h.world_writers_pending else
             f"{h.messages} messages on {h.topics} topics, step {h.last_step}")
    values = [("messages_written", h.messages), ("topics", h.topics),
              ("last_step", h.last_step), ("steps_recorded", h.last_step + 1),
              ("step_messages_expected", h.expected), ("step_messages_missing", missing),
              ("gap_topics", ", ".join(f"{t} ({h.gaps[t]})" for t in gaps[:shown])
               + (f" and {len(gaps) - shown} more" if len(gaps) > shown else "")),
              ("world_writers_pending", h.world_writers_pending),
              ("rejected_messages", h.rejected)]
    return _status("recorder", level, "; ".join([doing, *problems]), values)


def diagnostic_array(stamp: Time, statuses: Iterable[DiagnosticStatus]) -> DiagnosticArray:
    """The ``DiagnosticArray`` of ``statuses`` stamped ``stamp`` (frame "")."""
    return DiagnosticArray(header=Header(stamp=stamp), status=list(statuses))


def level_of(status: DiagnosticStatus) -> int:
    """A status' level as an int (:data:`OK`, :data:`WARN`, :data:`ERROR`)."""
    level = status.level
    return int.from_bytes(level, "little") if isinstance(level, bytes) else int(level)


class GapCounter:
    """Step messages missing so far, per topic, counted as the run goes (for the recorder).

    The rule of :func:`phd_swarm.nodes.completeness.check` applied step by step: a step k
    is checked once the team state of a later step has been known for :data:`GAP_SETTLE_S`
    wall seconds (so what is still on its way does not count), and each step is checked
    once, so an update costs the topics times the new steps, not the whole run. Messages
    that arrive later take their gap back. The monitor's topics count only once one of
    them holds a message (a run without a monitor has none).

    Parameters
    ----------
    topics : iterable of str
        The run's step topics (:func:`phd_swarm.nodes.completeness.run_step_topics`).
    robots : int
        Team size.
    settle_s : float
        Wall seconds a team state must be known before the steps before it are checked.
    """

    def __init__(self, topics: Iterable[str], robots: int,
                 settle_s: float = GAP_SETTLE_S) -> None:
        self.robots = robots
        self.settle_s = settle_s
        #: (topic, robot or -1, whether a robot's output (alive at k and k+1 expected)).
        self._rules: list[tuple[str, int, bool]] = []
        for name in topics:
            match = _ROBOT_TOPIC.match(name)
            if match is None:
                self._rules.append((name, -1, False))
            elif int(match.group(1)) < robots:
                self._rules.append((name, int(match.group(1)),
                                    match.group(2) not in completeness.ROBOT_INPUTS))
        self._optional = [t for t, _, _ in self._rules
                          if t.startswith(completeness.OPTIONAL_PREFIX)]
        self._seen: list[tuple[float, int]] = []
        self._checked = -1
        self._flags = np.ones(robots, dtype=bool)
        self.expected = 0
        self.missing: set[tuple[str, int]] = set()

    def update(self, recorded: Mapping[str, Iterable[int]],
               team: Mapping[int, np.ndarray], now: float | None = None) -> dict[str, int]:
        """Check the steps settled since the last update; topic -> steps missing so far.

        ``recorded``: topic -> steps recorded (status: ``STEP_DONE`` only); ``team``: step
        -> alive flags (R,) of the team states recorded; ``now``: wall time [s]
        (``time.monotonic()`` by default).
        """
        now = time.monotonic() if now is None else now
        latest = max(team, default=-1)
        if not self._seen or latest > self._seen[-1][1]:
            self._seen.append((now, latest))
        settled = [k for t, k in self._seen if now - t >= self.settle_s]
        upto = max(settled, default=-1) - 1
        self._seen = self._seen[max(len(settled) - 1, 0):]
        monitor = any(recorded.get(t) for t in self._optional)
        for k in range(self._checked + 1, upto + 1):
            here = self._alive(team, k)
            after = self._alive(team, k + 1, here)
            self._flags = here
            for name, r, output in self._rules:
                if r >= 0 and not (here[r] and (after[r] or not output)):
                    continue
                if not monitor and name in self._optional:
                    continue
                self.expected += 1
                if k not in recorded.get(name, ()):
                    self.missing.add((name, k))
        self._checked = max(self._checked, upto)
        self.missing = {(t, k) for t, k in self.missing if k not in recorded.get(t, ())}
        out: dict[str, int] = {}
        for name, _ in self.missing:
            out[name] = out.get(name, 0) + 1
        return out

    def _alive(self, team: Mapping[int, np.ndarray], k: int,
               before: np.ndarray | None = None) -> np.ndarray:
        """Alive flags at step k: its team state's, or the previous step's without one."""
        flags = team.get(k)
        if flags is None:
            return self._flags if before is None else before
        return np.asarray(flags, dtype=bool)[:self.robots]
