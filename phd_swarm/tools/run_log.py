"""A recorded run read back from its MCAP log: the inputs of evaluation and plots.

:func:`load_run` reads, from a log written by the recorder (``run_swarm.sh`` or
``record.sh CONFIG``), everything a step's picture and score need except what the team
estimate is made of (below):

- the run's configuration (the ``phd_swarm.config`` metadata, or a config file);
- per step: the true targets (``/world/truth``), the team state (``/world/robots``: robot
  positions and who is alive), each robot's goal (``/robot_<i>/status``), cell
  (``/robot_<i>/cell``) and scan (``/robot_<i>/measurements``: sensor position and
  measurements), and the live monitor's metrics (``/monitor/metrics``) when recorded.

What the team estimate is made of is what the estimator declares (its observation, read
with the monitor's :class:`~phd_swarm.nodes.observe.TeamReader`, :attr:`RunLog.reader`); it
is streamed, not kept, so memory stays at a few steps whatever the run's length:

- an image (the grid PHD of Dames and Chen): the robots' PHD windows
  (``/robot_<i>/density``) are large (the whole map per step); :meth:`RunLog.team_images`
  yields one team PHD image per step, assembled exactly as the live monitor assembles it
  (windows added in robot-id order);
- any other estimator: :meth:`RunLog.team_estimates` yields per step the robots' own
  estimates (``/robot_<i>/estimates``) and, for the estimator's figures, one view per
  robot built from the outputs it is observed through (e.g. Sung & Tokekar's
  ``components`` and ``tracks``), each message checked as the monitor checks it.

Messages are deserialised with rclpy's C type support (the installed message classes), not
decoded in Python.

A truncated log (recorder killed) is read up to its last complete chunk; steps whose data
is incomplete are dropped from the end, with a warning.
"""

from __future__ import annotations

import logging
import re
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import yaml
from rclpy.serialization import deserialize_message as _rclpy_deserialize

from phd_swarm.config import RunConfig, load_run_config, run_config_from_dict
from phd_swarm.logs.mcap_log import LogError, LogReader, LogRecord, open_log
from phd_swarm.nodes import convert
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.completeness import reporters
from phd_swarm.nodes.observe import TeamReader, add_windows, union
from phd_swarm.sim.scenario import Scenario
from phd_swarm_msgs.msg import (
    CellPolygon,
    DensityGrid,
    MeasurementSet,
    RobotStatus,
    TargetSet,
    TeamMetrics,
    TeamState,
)

logger = logging.getLogger(__name__)

_ROBOT_TOPIC = re.compile(r"^/" + T.ROBOT_PREFIX + r"(\d+)/(status|cell|measurements|density)$")


@dataclass
class StepRecord:
    """What the log says about one step k (all positions in metres, world frame).

    Attributes
    ----------
    step : int
    truth : np.ndarray, shape (N, 2)
        True target positions.
    truth_ids : np.ndarray of int, shape (N,)
    robots : dict of int to np.ndarray (2,)
        Position of every robot in the team state of step k.
    alive : frozenset of int
        Robots alive at step k.
    goals : dict of int to np.ndarray (2,)
        Goal each robot reported at the end of step k.
    cells : dict of int to np.ndarray (V, 2)
        The latest cell polygon of each robot computed for step <= k.
    scans : dict of int to (np.ndarray (2,), np.ndarray (M, 2))
        Each robot's sensor position and measurement set of step k.
    monitor : dict or None
        The live monitor's metrics of step k (``ospa``, ``cardinality_estimated``, ...).
    """

    step: int
    truth: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    truth_ids: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    robots: dict[int, np.ndarray] = field(default_factory=dict)
    alive: frozenset[int] = frozenset()
    goals: dict[int, np.ndarray] = field(default_factory=dict)
    cells: dict[int, np.ndarray] = field(default_factory=dict)
    scans: dict[int, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    monitor: dict[str, float] | None = None


class TeamEstimate(NamedTuple):
    """A step's team estimate for a system whose robots extract their own (not a grid PHD).

    Attributes
    ----------
    step : int
    estimates : np.ndarray, shape (K, 2)
        The union of the robots' estimates, in robot-id order [m].
    expected : float
        The sum of the robots' expected numbers of targets.
    views : list of EstimatorView
        Each robot's components and tracks, in robot-id order, for the estimator's
        ``figures`` hook (empty if the system publishes neither).
    reporters : tuple of int
        The robots whose outputs make up the step (every output kind), ascending.
    """

    step: int
    estimates: np.ndarray
    expected: float
    views: list[Any]
    reporters: tuple[int, ...]


@dataclass
class RunLog:
    """A run read from its log (see the module docstring).

    Attributes
    ----------
    path : Path
        The MCAP file.
    config : RunConfig
        The run's configuration.
    steps : dict of int to StepRecord
        The steps with truth and a team state, ascending.
    truncated : bool
        True if the log has no valid footer (writer killed).
    """

    path: Path
    config: RunConfig
    steps: dict[int, StepRecord]
    truncated: bool

    @property
    def scenario(self) -> Scenario:
        """The run's scenario."""
        return self.config.scenario

    @property
    def controller(self) -> str:
        """The robots' controller (``phd``, ``uniform``, ``chen_p``, ``chen_o``, ...)."""
        return self.config.scenario.system.controller

    @cached_property
    def reader(self) -> TeamReader:
        """How the monitor read the robots of this run (the estimator's observation)."""
        return TeamReader(self.scenario.system)

    @property
    def grid_phd(self) -> bool:
        """Whether the team estimate is a PHD image (the monitor's rule), not the robots'."""
        return bool(self.reader.image)

    @property
    def step_inputs(self) -> tuple[str, ...]:
        """The robot output kinds a step is made of, as the monitor waits for them.

        The window topic of an image (``("density",)`` for a grid PHD); else ``estimates``
        and the outputs the estimator is observed through (``components``...).
        """
        return self.reader.inputs

    def paths(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Each robot's path: its steps (S,) and positions (S, 2) in the team states."""
        out: dict[int, tuple[list[int], list[np.ndarray]]] = defaultdict(lambda: ([], []))
        for k, rec in self.steps.items():
            for rid, q in rec.robots.items():
                out[rid][0].append(k)
                out[rid][1].append(q)
        return {rid: (np.array(ks, dtype=np.int64), np.array(qs).reshape(-1, 2))
                for rid, (ks, qs) in sorted(out.items())}

    def team_images(self, steps: Iterable[int] | None = None
                    ) -> Iterator[tuple[int, np.ndarray, int]]:
        """Yield ``(k, image, windows)`` per step: the team PHD (ny, nx) and how many windows.

        A step is complete when the windows of every robot alive at k and k+1 have been
        read (the monitor's rule); the rest are yielded at the end of the log. Windows are
        added in robot-id order, as the monitor adds them, so the image is the monitor's
        bit for bit.

        Raises
        ------
        LogError
            If a window does not fit the scenario's grid or holds bad numbers.
        """
        wanted = None if steps is None else set(steps)
        grid = self.scenario.grid
        pending: dict[int, dict[int, DensityGrid]] = defaultdict(dict)
        done: set[int] = set()
        kind = self.reader.image
        topics = [T.robot_topic(r, kind) for r in range(self.scenario.robots)]

        def assemble(k: int) -> tuple[int, np.ndarray, int]:
            windows = pending.pop(k)

            def refuse(rid: int, exc: convert.InvalidMessage) -> None:
                raise LogError(f"{self.path}: {kind} window of robot {rid} at step {k}: "
                               f"{exc}") from None

            done.add(k)
            return k, add_windows(grid, windows, refuse), len(windows)

        with open_log(self.path) as log:
            for rec in log.messages(topics, decode=False):
                msg = deserialize(rec, self.reader.types[kind], self.path)
                k = int(msg.step)
                if k not in self.steps or k in done or (wanted is not None and k not in wanted):
                    continue
                pending[k][int(msg.owner_id)] = msg
                if set(pending[k]) >= self.expected_windows(k):
                    yield assemble(k)
        for k in sorted(pending):
            if pending[k]:
                yield assemble(k)

    def team_estimates(self, steps: Iterable[int] | None = None) -> Iterator[TeamEstimate]:
        """Yield the :class:`TeamEstimate` of each step, for a system without a grid PHD.

        A robot reports step k when its every output kind (:attr:`step_inputs`) of step k
        has been read; a step is complete when every robot alive at k and k+1 reported (the
        monitor's rule); the rest are yielded at the end of the log, with the robots that
        reported. Estimates are joined and expected counts added in robot-id order, as the
        monitor does, so the step scores to the monitor's numbers bit for bit.

        Raises
        ------
        LogError
            Naming the topic and step, if a message fails the monitor's checks (non-finite
            positions or expected count, mixtures or tracks that
            :mod:`~phd_swarm.nodes.faces.gaussian_mixture` refuses).
        """
        wanted = None if steps is None else set(steps)
        kinds = self.step_inputs
        topics = {T.robot_topic(r, kind): (r, kind) for r in range(self.scenario.robots)
                  for kind in kinds}
        pending: dict[int, dict[int, dict[str, Any]]] = defaultdict(lambda: defaultdict(dict))
        done: set[int] = set()

        def reported(k: int) -> set[int]:
            return {r for r, got in pending[k].items() if len(got) == len(kinds)}

        with open_log(self.path) as log:
            for rec in log.messages(list(topics), decode=False):
                rid, kind = topics[rec.topic]
                msg = deserialize(rec, self.reader.types[kind], self.path)
                k = int(msg.step)
                if k not in self.steps or k in done or (wanted is not None and k not in wanted):
                    continue
                pending[k][rid][kind] = self._checked(rec.topic, kind, msg)
                if reported(k) >= self.expected_windows(k):
                    done.add(k)
                    yield self._team_estimate(k, pending.pop(k))
        for k in sorted(pending):
            got = {r: pending[k][r] for r in sorted(reported(k))}
            if got:
                yield self._team_estimate(k, got)

    def _checked(self, topic: str, kind: str, msg: Any) -> Any:
        """A robot output read and checked as the monitor reads it; LogError otherwise."""
        try:
            return self.reader.read(kind, msg)
        except convert.InvalidMessage as exc:
            raise LogError(f"{self.path}: {topic} at step {int(msg.step)}: {exc}") from None

    def _team_estimate(self, k: int, robots: dict[int, dict[str, Any]]) -> TeamEstimate:
        """Join the read outputs ``robots`` (robot -> kind -> value) of step k, by robot id.

        Only the robots with every output kind count (the monitor's rule).
        """
        kinds = self.reader.inputs
        full = {r: robots[r] for r in sorted(robots) if len(robots[r]) == len(kinds)}
        estimates, expected = union(full)
        return TeamEstimate(k, estimates, expected, self.reader.views(full), tuple(full))

    def expected_windows(self, k: int) -> frozenset[int]:
        """Robots whose windows make up step k: alive at k and at k+1 (the monitor's rule)."""
        later = self.steps.get(k + 1)
        return reporters(self.steps[k].alive, None if later is None else later.alive)

    def absences(self) -> list[dict[str, int | None]]:
        """The spans of steps in which a robot was out of the team, from the team states.

        One entry per span: ``robot``, ``first`` and ``last`` (the steps the world counted
        it dead, ``/world/robots``' ``alive``) and ``rejoined`` (the step it was alive again,
        None if it never was). A robot whose link was cut, or whose process died, shows
        here; the steps of the robots that stayed are unaffected.
        """
        out: list[dict[str, int | None]] = []
        known = [k for k in sorted(self.steps) if self.steps[k].robots]
        for rid in range(self.scenario.robots):
            first = None
            for k in known:
                if rid not in self.steps[k].alive:
                    if first is None:
                        first = k
                    last = k
                elif first is not None:
                    out.append({"robot": rid, "first": first, "last": last, "rejoined": k})
                    first = None
            if first is not None:
                out.append({"robot": rid, "first": first, "last": last, "rejoined": None})
        return sorted(out, key=lambda a: (a["first"], a["robot"]))

    def map_layer_images(self, steps: Iterable[int]) -> dict[int, np.ndarray]:
        """The exchange's map layer as an image after each of ``steps`` (none: empty).

        Rebuilt from the scans in the log by the exchange's ``map_layer`` hook, with every
        layer the exchange can carry (Chen's cumulative density wc, eq. 9-11, for
        ``voronoi_phd``: every scan of step k adds one observation to each bin of its
        field of view and one reward if it holds a measurement; the counts are integers,
        so the order of the scans does not matter and the team state is the union of the
        robots').
        """
        exchange = self.scenario.system.parts()["exchange"]
        layer = None if exchange.map_layer is None else exchange.map_layer(
            self.scenario, exchange.provides)
        wanted = sorted(set(steps))
        out: dict[int, np.ndarray] = {}
        if layer is None or not wanted:
            return out
        for k in sorted(self.steps):
            if k > wanted[-1]:
                break
            scans = self.steps[k].scans
            layer.observe(scans[rid] for rid in sorted(scans))
            if k in wanted:
                image = layer.image()
                if image is None:
                    return {}
                out[k] = image
        return out


def config_from_log(path: Path, metadata: dict[str, dict[str, str]]) -> RunConfig:
    """The run config stored in a log's ``phd_swarm.config`` metadata (LogError if none)."""
    record = metadata.get("phd_swarm.config")
    if not record or "params_yaml" not in record:
        raise LogError(f"{path}: the log holds no run configuration (phd_swarm.config "
                       "metadata; it was recorded without CONFIG); pass the run's config "
                       "file with --config")
    source = record.get("source") or "config"
    try:
        return run_config_from_dict(yaml.safe_load(record["params_yaml"]),
                                    f"{path} (config recorded from {source})")
    except (ValueError, yaml.YAMLError) as exc:
        raise LogError(f"{path}: the recorded configuration is not valid: {exc}") from None


def deserialize(rec: LogRecord, cls: type, path: Path) -> Any:
    """``rec``'s CDR bytes as an installed message of class ``cls`` (rclpy's C type support).

    Raises
    ------
    LogError
        Naming the topic and type, when the bytes do not fit the installed definition (a
        log recorded with another version of the message, e.g. before a field was added).
    """
    try:
        return _rclpy_deserialize(rec.data, cls)
    except Exception as exc:  # rclpy raises RMWError (not exported) for a bad buffer
        raise LogError(f"{path}: a {rec.ros_type} message on {rec.topic} does not fit the "
                       f"installed definition of that type (a log recorded by another "
                       f"version of phd_swarm?): {exc}") from None


def _measurement_set(log: LogReader, rec: LogRecord, path: Path,
                     legacy: dict[str, Callable[[bytes], Any]]) -> Any:
    """A recorded ``MeasurementSet``, read by the installed type.

    A log recorded before its ``mac`` field (issue 40) is read by the definition recorded
    in it.
    """
    if rec.topic not in legacy:
        try:
            return deserialize(rec, MeasurementSet, path)
        except LogError:
            legacy[rec.topic] = log.recorded_decoder(rec.topic)
    try:
        return legacy[rec.topic](rec.data)
    except Exception as exc:  # mcap_ros2's decoders raise struct, index, value errors
        raise LogError(f"{path}: a {rec.ros_type} message on {rec.topic} cannot be read by "
                       f"its recorded definition either: {exc}") from None


def _xy(points, what: str, path: Path, k: int) -> np.ndarray:
    try:
        return convert.xy(points, what)
    except convert.InvalidMessage as exc:
        raise LogError(f"{path}: step {k}: {exc}") from None


def load_run(path: str | Path, config: str | Path | None = None) -> RunLog:
    """Read a run's log (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The MCAP log.
    config : str or Path, optional
        The run's config file, for logs recorded without one (it replaces the recorded
        configuration if both exist).

    Raises
    ------
    LogError
        If the file is missing, not a ROS 2 MCAP log, holds no configuration, or holds no
        complete step.
    ValueError
        If ``config`` is not a valid config file.
    """
    path = Path(path)
    with open_log(path) as log:
        metadata = log.metadata()
        run_config = (load_run_config(config) if config is not None
                      else config_from_log(path, metadata))
        n_robots = run_config.scenario.robots
        steps: dict[int, StepRecord] = {}

        def at(k: int) -> StepRecord:
            return steps.setdefault(k, StepRecord(k))

        cells: dict[int, list[tuple[int, np.ndarray]]] = defaultdict(list)
        legacy: dict[str, Callable[[bytes], Any]] = {}
        team_seen: set[int] = set()
        truth_seen: set[int] = set()
        topics = [T.WORLD_TRUTH, T.WORLD_ROBOTS, T.MONITOR_METRICS]
        topics += [T.robot_topic(r, kind) for r in range(n_robots)
                   for kind in ("status", "cell", "measurements")]
        for rec in log.messages(topics, decode=False):
            if rec.topic == T.WORLD_TRUTH:
                m = deserialize(rec, TargetSet, path)
                r = at(int(m.step))
                r.truth = _xy(m.positions, "truth positions", path, m.step)
                r.truth_ids = np.asarray(m.ids, dtype=np.int64)
                truth_seen.add(int(m.step))
            elif rec.topic == T.WORLD_ROBOTS:
                m = deserialize(rec, TeamState, path)
                r = at(int(m.step))
                pos = _xy(m.positions, "robot positions", path, m.step)
                r.robots = {int(i): pos[j] for j, i in enumerate(m.robot_ids)}
                r.alive = frozenset(int(i) for i, a in zip(m.robot_ids, m.alive, strict=True)
                                    if a)
                team_seen.add(int(m.step))
            elif rec.topic == T.MONITOR_METRICS:
                m = deserialize(rec, TeamMetrics, path)
                at(int(m.step)).monitor = {
                    "ospa": m.ospa, "ospa_localisation": m.ospa_localisation,
                    "ospa_cardinality": m.ospa_cardinality,
                    "cardinality_true": m.cardinality_true,
                    "cardinality_estimated": m.cardinality_estimated,
                    "expected_cardinality": m.expected_cardinality}
            else:
                match = _ROBOT_TOPIC.match(rec.topic)
                if match is None:
                    continue
                kind = match.group(2)
                if kind == "status":
                    m = deserialize(rec, RobotStatus, path)
                    if m.state == RobotStatus.STATE_STEP_DONE and np.isfinite(m.goal.x) \
                            and np.isfinite(m.goal.y):
                        at(int(m.step)).goals[int(m.robot_id)] = np.array([m.goal.x, m.goal.y])
                elif kind == "cell":
                    m = deserialize(rec, CellPolygon, path)
                    cells[int(m.robot_id)].append(
                        (int(m.step), _xy(m.vertices, "cell vertices", path, m.step)))
                else:
                    m = _measurement_set(log, rec, path, legacy)
                    sensor = np.array([m.sensor_position.x, m.sensor_position.y])
                    at(int(m.step)).scans[int(m.robot_id)] = (
                        sensor, _xy(m.measurements, "measurements", path, m.step))
        truncated = log.truncated

    # Keep the steps the world announced (truth and team state); the final team state
    # (step = steps, after the last move) has no truth and is not a step of its own.
    complete = {k: steps[k] for k in sorted(steps) if k in team_seen and k in truth_seen}
    if not complete:
        raise LogError(f"{path}: no complete step in the log (no /world/truth with its "
                       "/world/robots)")
    for rid, seq in cells.items():
        seq.sort(key=lambda s: s[0])
        i, latest = 0, None
        for k in complete:
            while i < len(seq) and seq[i][0] <= k:
                latest = seq[i][1]
                i += 1
            if latest is not None:
                complete[k].cells[rid] = latest
    if truncated:
        logger.warning("%s: truncated log: %d complete steps read", path, len(complete))
    return RunLog(path, run_config, complete, truncated)

