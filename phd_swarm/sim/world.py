"""The simulated world: ground-truth targets, holonomic robots and their sensors.

One time step k of a run (Dames 2020 Sec. II-C and IV; Chen et al. 2021 Alg. 1):

1. the robots are at q^k and the targets at X^k; :meth:`World.scans` gives each live robot
   its measurement set Z_r^k (the scenario's sensor, :mod:`phd_swarm.core.sensors`);
2. the stack updates its filters and computes each robot's goal g_r (the weighted centroid
   of its cell, Dames eq. 8);
3. :meth:`World.apply_goals` moves each robot at most ``robot_max_speed * dt`` straight
   towards its goal (Chen eq. 3), giving q^{k+1};
4. :meth:`World.advance` moves the targets by ``dt``, giving X^{k+1}, and increments the
   step counter and the clock.

Random streams. Three independent generators are derived from the scenario's seed with
``np.random.SeedSequence(seed).spawn(3)``, in this order:

0. robot start positions (one ``random((R, 2))`` call at construction, or, with the
   scenario's ``robot_start_grid``, one ``integers`` call for the (R, 2) node indices);
1. targets (the initial population, then every :meth:`World.advance`);
2. the sensor (every :meth:`World.scans`, robots in id order).

So the target trajectories do not depend on the team size or on how often the robots scan,
and the start positions of robots 0..R-1 do not depend on the targets. A world is
reproducible bit for bit from its scenario (seed included) and the sequence of calls.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from phd_swarm.core.geometry.centroids import next_position, step_length
from phd_swarm.sim.scenario import STREAMS, Scenario
from phd_swarm.sim.targets import Targets, make_targets

__all__ = ["STREAMS", "World", "start_positions"]


def start_positions(scenario: Scenario, rng: np.random.Generator) -> np.ndarray:
    """The robots' start positions q^0, shape (R, 2) [m], drawn from ``rng``.

    Uniform in ``scenario.robot_start_box``; with ``scenario.robot_start_grid`` = g,
    uniform among the nodes ``(env.xmin + i g, env.ymin + j g)`` inside the box (the
    nodes of :class:`~phd_swarm.core.controllers.dtds_walk.grid_graph.GridGraph` with spacing g, to
    the bit), independently per robot (Shirsat & Berman Sec. VI).
    """
    if scenario.robot_start_grid is None:
        box = np.asarray(scenario.robot_start_box, dtype=float)
        return box[:2] + rng.random((scenario.robots, 2)) * (box[2:] - box[:2])
    (x0, x1), (y0, y1) = scenario.start_grid_ranges()
    index = rng.integers([x0, y0], [x1 + 1, y1 + 1], size=(scenario.robots, 2))
    origin = np.array([scenario.env.xmin, scenario.env.ymin], dtype=float)
    return origin + index * float(scenario.robot_start_grid)


class World:
    """Ground truth and robot kinematics of one run of ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        The run's settings.
    rng : np.random.Generator, optional
        If given, the three streams are ``rng.spawn(3)`` instead of being derived from
        ``scenario.seed``; ``World(s, np.random.default_rng(s.seed))`` is the same world
        as ``World(s)``.

    Attributes
    ----------
    scenario : Scenario
        The settings.
    targets : Targets
        The true target population X^k, of the scenario's kind
        (:func:`~phd_swarm.sim.targets.make_targets`).
    step_index : int
        k, the number of :meth:`advance` calls so far.
    """

    def __init__(self, scenario: Scenario, rng: np.random.Generator | None = None) -> None:
        self.scenario = scenario
        if rng is None:
            children = np.random.SeedSequence(scenario.seed).spawn(len(STREAMS))
            streams = [np.random.default_rng(c) for c in children]
        else:
            streams = rng.spawn(len(STREAMS))
        start_rng, self._target_rng, self._sensor_rng = streams
        self._positions = start_positions(scenario, start_rng)
        self._alive = np.ones(scenario.robots, dtype=bool)
        self._d_step = step_length(scenario.robot_max_speed, scenario.dt)
        self._lo = np.array([scenario.env.xmin, scenario.env.ymin])
        self._hi = np.array([scenario.env.xmax, scenario.env.ymax])
        self.targets: Targets = make_targets(self._target_rng, scenario)
        self.step_index = 0
        sensor = scenario.system.parts()["sensor"]
        self._simulate = sensor.simulate
        # A sensor that identifies targets is handed their ids (disk_labelled).
        self._simulate_labelled = sensor.simulate_labelled
        #: Robot id -> the labels of its last scan, (M,) int64, 0 for clutter; filled only
        #: by a sensor that identifies targets (:mod:`phd_swarm.core.sensors.disk_labelled`).
        self.scan_labels: dict[int, np.ndarray] = {}
        #: What the sensor part's set-up made of the scenario (``disk``: a ``DiskSensor``).
        self._sensor_model = sensor.setup(scenario, scenario.system)

    @property
    def robot_positions(self) -> np.ndarray:
        """Positions q of all robots, dead ones included, shape (R, 2) [m] (a copy)."""
        return self._positions.copy()

    @property
    def robot_ids(self) -> np.ndarray:
        """Robot ids ``0..R-1``, shape (R,); row r of :attr:`robot_positions` is robot r."""
        return np.arange(self.scenario.robots)

    @property
    def alive(self) -> np.ndarray:
        """Which robots are alive, shape (R,) bool (a copy)."""
        return self._alive.copy()

    @property
    def time(self) -> float:
        """Simulated time ``step_index * dt`` [s]."""
        return self.step_index * self.scenario.dt

    @property
    def done(self) -> bool:
        """True once :attr:`step_index` has reached ``scenario.steps``."""
        return self.step_index >= self.scenario.steps

    def truth(self) -> tuple[np.ndarray, np.ndarray]:
        """True target set X^k: ids (N,) int64 and positions (N, 2) [m], both copies."""
        return self.targets.ids.copy(), self.targets.positions.copy()

    def scans(self) -> dict[int, np.ndarray]:
        """Measurement sets Z_r^k of the live robots at their current positions.

        Robots are visited in id order, each drawing from the sensor stream with
        the ``simulate`` of the scenario's sensor, given what the sensor part's set-up made
        (``disk``: :func:`~phd_swarm.core.sensors.disk.simulate_scan`, Dames eq. 9-11 with
        ``scenario.models``). Dead robots get no entry and consume no random numbers. A
        sensor that identifies targets (``simulate_labelled``) is also given the targets'
        ids, and the labels of the scans are left in :attr:`scan_labels`.

        Returns
        -------
        dict of int to np.ndarray
            Robot id -> measurements, shape (M, 2) [m] (detections, then clutter).
        """
        x = self.targets.positions
        simulate, model = self._simulate, self._sensor_model
        if self._simulate_labelled is None:
            return {int(r): simulate(self._sensor_rng, model, self._positions[r], x)
                    for r in np.flatnonzero(self._alive)}
        ids = self.targets.ids
        out, self.scan_labels = {}, {}
        for r in np.flatnonzero(self._alive):
            out[int(r)], self.scan_labels[int(r)] = self._simulate_labelled(
                self._sensor_rng, model, self._positions[r], x, ids)
        return out

    def apply_goals(self, goals: Mapping[int, np.ndarray]) -> None:
        """Move each live robot towards its goal, at most ``robot_max_speed * dt`` (Chen eq. 3).

        A robot within reach lands on its goal
        (:func:`~phd_swarm.core.geometry.centroids.next_position`); the new position is clipped
        into E, so a goal outside E is approached along the straight line and then slid along the
        boundary. Robots without a goal and dead robots stay where they are.

        Parameters
        ----------
        goals : Mapping of int to np.ndarray
            Robot id -> goal g, shape (2,) [m].

        Raises
        ------
        ValueError
            For an id that is not a robot, or a goal that is not two finite numbers.
        """
        for rid, goal in goals.items():
            r = self._check_id(rid)
            if not self._alive[r]:
                continue
            q = next_position(self._positions[r], goal, self._d_step)
            self._positions[r] = np.clip(q, self._lo, self._hi)

    def advance(self) -> None:
        """Move the targets by ``dt`` (X^k -> X^{k+1}) and increment the step and clock."""
        self.targets.step(self._target_rng, self.scenario.dt)
        self.step_index += 1

    def kill(self, robot_id: int) -> None:
        """Mark a robot dead: from now on it gets no scans and does not move."""
        self._alive[self._check_id(robot_id)] = False

    def revive(self, robot_id: int) -> None:
        """Mark a dead robot alive again: from the next step on it is scanned and moves.

        It starts from where it died (dead robots do not move). Reviving a live robot does
        nothing.
        """
        self._alive[self._check_id(robot_id)] = True

    def _check_id(self, robot_id: int) -> int:
        if (isinstance(robot_id, bool) or not isinstance(robot_id, (int, np.integer))
                or not 0 <= robot_id < self.scenario.robots):
            raise ValueError(f"unknown robot id {robot_id!r}; "
                             f"ids are 0..{self.scenario.robots - 1}")
        return int(robot_id)
