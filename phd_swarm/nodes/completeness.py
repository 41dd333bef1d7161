"""Is a run's log complete? Expected, recorded and missing steps of every step topic.

Every message a step writes carries its step k: the header stamp is the sim time k dt
(:func:`phd_swarm.nodes.convert.header`). So the steps a log holds for a topic are known
without decoding the messages, and what a complete log must hold follows from the world's
team states (``/world/robots``: which robots were alive at each step). With K the last step
of the team states in the log (K = the number of steps once the run finished, since the
world publishes a final team state after the last step):

==========================================  ===================================================
topic                                       expected steps
==========================================  ===================================================
``/clock``, ``/world/robots``               0..K
``/world/truth``, ``/monitor/metrics``,     0..K-1
``/monitor/estimates``, ``/monitor/density``
``/robot_<r>/measurements``, ``pose``       k < K with r alive at k (the world scans it)
``/robot_<r>/status`` (``STEP_DONE``),      k < K with r alive at k and at k+1 (a robot the
``goal``, ``estimates`` and the step        world still counts alive after step k reported
outputs its parts declare (``density``...)  step k); in real time, alive at k..k+W
==========================================  ===================================================

In real time the world does not wait for a report: it counts a silent robot dead only
after ``step_timeout`` wall seconds, W steps later (:func:`verdict_window`), so a robot
counted dead at step k may have stopped reporting at any step from k-W on (its host cut off,
say): its outputs are expected at the steps after which the world still counted it alive
for W steps. In lockstep W = 1: the world waits for every report, and a robot that does not
report step k is dead at k+1.

Only topics whose QoS in :mod:`phd_swarm.nodes.topics` (or in the declaration of an
output, :mod:`phd_swarm.core.outputs`) is ``STEP`` (one message per step,
kept until acknowledged) are checked; inbox traffic and markers are not step topics. A step
whose team state is itself missing takes the alive flags of the previous one. The monitor
is optional (a world, robots and a recorder started by hand make a run without one): when
not one of its topics holds a message, they are listed as :attr:`Completeness.absent`
instead of missing.

rclpy-free: the recorder feeds it stamps as they arrive, :mod:`phd_swarm.tools.evaluate` and
:mod:`phd_swarm.tools.replay` feed it what they read from the log.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from phd_swarm.nodes import topics as T

#: Robot topics written by the world at step k (expected while the robot is alive at k).
ROBOT_INPUTS = ("measurements", "pose")

#: Robot topics written by the robot when it finishes step k, whatever the system: the
#: others are the step outputs its parts declare (:func:`robot_outputs`).
ROBOT_OUTPUTS = ("status", "goal", "estimates")

#: Topics of an optional node: absent rather than missing when none holds a message.
OPTIONAL_PREFIX = "/monitor/"

#: Team topics written once per step and once more after the last step.
TEAM_WITH_FINAL = (T.CLOCK, T.WORLD_ROBOTS)

_ROBOT_TOPIC = re.compile(rf"^/{T.ROBOT_PREFIX}(\d+)/(\w+)$")


def step_of(stamp_ns: int, dt: float) -> int:
    """Step k of a message stamped ``stamp_ns`` [ns of sim time] in a run of period ``dt``."""
    return int(round(stamp_ns / (dt * 1e9)))


def robot_outputs(system: Any, publish_density: bool = True) -> tuple[str, ...]:
    """The step topics a robot of ``system`` writes, in the order of its topic table.

    :data:`ROBOT_OUTPUTS`, and the outputs its parts declare with the ``STEP`` QoS
    (:func:`phd_swarm.nodes.topics.declared_outputs`; ``density`` only with
    ``publish_density``).
    """
    table = T.robot_topics(T.declared_outputs(system, publish_density))
    return tuple(k for k, (_, qos, writer, _) in table.items()
                 if writer == "robot" and qos == "STEP")


def monitor_density(system: Any) -> bool:
    """Whether the monitor of a ``system`` run assembles a team PHD image.

    It does when the estimator's observation has an ``image`` (the grid PHD).
    """
    return bool(system.parts()["estimator"].observation.image)


def step_topics(robots: int, outputs: Iterable[str] = ("density", "cell", *ROBOT_OUTPUTS),
                monitor_density: bool = True) -> list[str]:
    """The step topics of a run of ``robots`` robots, in the order of the topic table.

    ``outputs``: the robots' output kinds (:func:`robot_outputs`; the default is a grid
    system's).
    """
    out = [name for name, (_, qos, *_) in T.TEAM_TOPICS.items()
           if (qos == "STEP" or name == T.CLOCK) and name not in T.TEAM_TRANSPORT]
    if not monitor_density:
        out.remove(T.MONITOR_DENSITY)
    kinds = [k for k in T.ROBOT_TOPICS if k in ROBOT_INPUTS] + list(dict.fromkeys(outputs))
    out += [T.robot_topic(r, k) for r in range(robots) for k in kinds]
    return out


def run_step_topics(rc: Any) -> list[str]:
    """The step topics of the run a :class:`~phd_swarm.config.RunConfig` describes."""
    s = rc.scenario
    return step_topics(s.robots, robot_outputs(s.system, bool(rc.param("robot",
                                                                      "publish_density"))),
                       monitor_density=bool(rc.param("monitor", "publish_density"))
                       and monitor_density(s.system))


@dataclass(frozen=True)
class TopicCompleteness:
    """One topic: how many steps a complete log holds, how many it does, which are missing."""

    expected: int
    recorded: int
    missing: tuple[int, ...]


@dataclass(frozen=True)
class Completeness:
    """Completeness of a log, per step topic (see the module docstring).

    Attributes
    ----------
    steps : int
        K: the last team-state step in the log (the number of steps of a finished run).
    topics : dict of str to TopicCompleteness
        Every step topic checked.
    """

    steps: int
    topics: dict[str, TopicCompleteness] = field(default_factory=dict)
    absent: tuple[str, ...] = ()

    @property
    def expected(self) -> int:
        """Step messages a complete log holds."""
        return sum(t.expected for t in self.topics.values())

    @property
    def recorded(self) -> int:
        """Step messages the log holds (of those expected)."""
        return sum(t.recorded for t in self.topics.values())

    @property
    def missing(self) -> int:
        """Step messages missing."""
        return self.expected - self.recorded

    @property
    def complete(self) -> bool:
        """Whether no step message is missing."""
        return self.missing == 0

    def gaps(self) -> dict[str, tuple[int, ...]]:
        """Topics with missing steps -> those steps."""
        return {name: t.missing for name, t in self.topics.items() if t.missing}

    def to_dict(self) -> dict:
        """A JSON-ready dict: totals, and per topic expected / recorded / missing steps."""
        return {"steps": self.steps, "complete": self.complete, "expected": self.expected,
                "recorded": self.recorded, "missing": self.missing,
                "absent_topics": list(self.absent),
                "topics": {name: {"expected": t.expected, "recorded": t.recorded,
                                  "missing_steps": list(t.missing)}
                           for name, t in self.topics.items()}}

    @classmethod
    def from_dict(cls, data: Mapping) -> Completeness:
        """Inverse of :meth:`to_dict`."""
        return cls(int(data["steps"]), {
            name: TopicCompleteness(int(t["expected"]), int(t["recorded"]),
                                    tuple(int(k) for k in t["missing_steps"]))
            for name, t in data["topics"].items()}, tuple(data.get("absent_topics", ())))

    def describe(self, limit: int = 8) -> str:
        """One line: complete, or how many are missing, naming topics and steps."""
        if self.complete:
            return (f"complete: {self.recorded} of {self.expected} step messages on "
                    f"{len(self.topics)} topics, steps 0..{self.steps - 1}"
                    + (f" (no {', '.join(self.absent)}: no monitor ran)" if self.absent
                       else ""))
        gaps = self.gaps()
        parts = [f"{name} steps {ranges(steps)}" for name, steps in list(gaps.items())[:limit]]
        more = f"; and {len(gaps) - limit} more topics" if len(gaps) > limit else ""
        return (f"INCOMPLETE: {self.missing} of {self.expected} step messages missing on "
                f"{len(gaps)} topics: " + "; ".join(parts) + more)


def ranges(steps: Iterable[int]) -> str:
    """``[1, 2, 3, 7]`` -> ``'1-3, 7'``."""
    out: list[str] = []
    seq = sorted(steps)
    i = 0
    while i < len(seq):
        j = i
        while j + 1 < len(seq) and seq[j + 1] == seq[j] + 1:
            j += 1
        out.append(str(seq[i]) if i == j else f"{seq[i]}-{seq[j]}")
        i = j + 1
    return ", ".join(out)


def reporters(alive_at_k, alive_at_next=None):
    """The robots whose step-k outputs make up step k: alive at k and still at k+1.

    A robot the world counts dead after step k (killed, or silent past its deadline) may or
    may not have reported k, so nothing of it is expected; without a step k+1 (the last
    step) it is those alive at k. The one rule of every check that a step is complete: the
    recorder's and the log check's (boolean arrays over steps), the monitor's and the log
    reader's (sets of ids).

    Parameters
    ----------
    alive_at_k, alive_at_next : frozenset of int, or np.ndarray of bool
        Who was alive at step k and at step k+1 (None: no step k+1).
    """
    return alive_at_k if alive_at_next is None else alive_at_k & alive_at_next


def verdict_window(rc: Any) -> int:
    """Steps W between a robot's last report and the world's verdict on it (module docstring).

    1 in lockstep; in real time ``step_timeout`` in wall steps (``dt / realtime_factor``),
    rounded up, plus 1.
    """
    if rc.param("world", "mode") != "realtime":
        return 1
    wall_dt = rc.scenario.dt / float(rc.param("world", "realtime_factor"))
    return int(np.ceil(float(rc.param("world", "step_timeout")) / wall_dt - 1e-9)) + 1


def reporting(alive: np.ndarray, window: int = 1) -> np.ndarray:
    """Whose step-k outputs are expected, bool (K, R), from alive flags (K + 1, R).

    Alive at k and at every step up to k + ``window`` (the last step K stands for the steps
    after it); with ``window`` 1, :func:`reporters` of each step and the next.
    """
    alive = np.asarray(alive, dtype=bool)
    padded = np.concatenate([alive, np.repeat(alive[-1:], window, axis=0)])
    runs = np.lib.stride_tricks.sliding_window_view(padded, window + 1, axis=0)
    return runs.all(axis=-1)[:alive.shape[0] - 1]


def alive_matrix(team: Mapping[int, np.ndarray], robots: int, steps: int) -> np.ndarray:
    """Alive flags (steps + 1, robots) from the team states ``team`` (step -> flags (R,)).

    A step without a team state takes the previous step's flags (all alive before the
    first).
    """
    out = np.ones((steps + 1, robots), dtype=bool)
    last = np.ones(robots, dtype=bool)
    for k in range(steps + 1):
        flags = team.get(k)
        if flags is not None:
            last = np.asarray(flags, dtype=bool)[:robots]
        out[k] = last
    return out


def check(recorded: Mapping[str, Iterable[int]], team: Mapping[int, np.ndarray], robots: int,
          topics: Iterable[str], window: int = 1) -> Completeness:
    """Completeness of a log (see the module docstring).

    Parameters
    ----------
    recorded : Mapping of str to iterable of int
        Topic -> steps the log holds (for ``status``: the ``STEP_DONE`` steps only).
    team : Mapping of int to np.ndarray of bool, shape (R,)
        Alive flags of each team state in the log, by step.
    robots : int
        Team size R.
    topics : iterable of str
        The step topics to check (:func:`step_topics`, or those the recorder subscribed).
    window : int
        The world's verdict window W in steps (:func:`verdict_window`; 1 in lockstep).
    """
    k_last = max(team, default=0)
    alive = alive_matrix(team, robots, k_last)
    report = reporting(alive, window)
    everything = np.arange(k_last + 1)
    out: dict[str, TopicCompleteness] = {}
    topics = list(topics)
    optional = [t for t in topics if t.startswith(OPTIONAL_PREFIX)]
    absent = tuple(optional) if not any(recorded.get(t) for t in optional) else ()
    for name in topics:
        if name in absent:
            continue
        match = _ROBOT_TOPIC.match(name)
        if name in TEAM_WITH_FINAL:
            want = everything
        elif match is None:
            want = everything[:-1]
        else:
            r, kind = int(match.group(1)), match.group(2)
            if r >= robots:
                continue
            if kind in ROBOT_INPUTS:
                want = np.flatnonzero(alive[:-1, r])
            else:
                want = np.flatnonzero(report[:, r])
        have = np.fromiter(set(recorded.get(name, ())), dtype=np.int64)
        missing = np.setdiff1d(want, have, assume_unique=True)
        out[name] = TopicCompleteness(int(want.size), int(want.size - missing.size),
                                      tuple(int(k) for k in missing))
    return Completeness(k_last, out, absent)
