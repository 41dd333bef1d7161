"""The central engine: the team's filter and controllers computed as one, for sweeps.

The distributed filter (Dames 2020 Alg. 1-2) computes the centralised grid PHD filter's team
PHD (eq. 3-6), up to the rounding of sums taken in another order
(``test/engines/test_distributed.py``): what each robot holds is the team PHD over its own
cell. So a run of the papers' algorithms can be computed without the protocol, as the
papers' own simulations are: one
:class:`~phd_swarm.core.estimators.grid_phd.central.CentralPhdFilter` over the whole map, one
partition of the bins (the power diagram of Chen eq. 12-13, or the Voronoi diagram of Dames
eq. 7 when every power weight is 0), and each robot's controller (the same registered
controller objects and generators the agents have, :mod:`phd_swarm.core.controllers`) on its
own cell, bins and masses. It runs the systems whose estimator has a central form
(``grid_phd``) and whose exchange partitions the map (``voronoi_phd``); other systems run on
the distributed engine. What the exchange's robots carry per bin besides the PHD, when the
controller asks for it (Chen's cumulative state, eq. 9-10), is kept over the whole map by
the exchange's ``map_layer`` hook: its counts are whole numbers, so they are exactly those
the robots carry.

One step k, as in :class:`~phd_swarm.engines.distributed.DistributedEngine`:

1. the world gives each live robot its measurement set Z^k at its position q^k;
2. the cells of q^k with the power weights of the previous decisions partition the bins
   (ties to the lower robot id, as in :func:`~phd_swarm.core.geometry.ownership.assign_bins`); a
   controller that declares a bound on the weights at the partition
   (:class:`~phd_swarm.core.controllers.base.PowerWeightGuard`, e.g. ``chen_o`` with
   ``rho_cap: nearest_robot``) has it applied to them first, at q^k;
3. the filter predicts (eq. 3; per cell when the motion kernel is convolved by FFT, see
   :meth:`~phd_swarm.core.estimators.grid_phd.central.CentralPhdFilter.predict_cells`)
   and updates with the sets in increasing robot id (eq. 4-6, Alg. 2 line 10); the map
   layer counts the scans (Chen eq. 9-10: one observation of the bins in a scan's field of
   view, and a reward there if it holds a measurement); each robot decides its goal and
   next power weight on its own bins;
4. the world moves the robots toward their goals and the targets, to step k+1.

What it leaves out is what only the protocol has: messages, failures and the counters of
partitions that disagree (a missed neighbour, docs/protocol.md). It runs a step several
times faster than the distributed engine; ``test/engines/test_central.py`` shows that
both give the same team PHD and the same robot paths.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from phd_swarm.core.agent import Team, robot_generator
from phd_swarm.core.controllers.base import CellDensity, Knowledge
from phd_swarm.core.geometry.ownership import bin_owners
from phd_swarm.core.geometry.partition import cell_of
from phd_swarm.core.scan import Scan
from phd_swarm.sim.scenario import Scenario
from phd_swarm.sim.world import World


class CentralEngine:
    """Run a scenario with one central filter and the robots' controllers, in one process.

    Parameters
    ----------
    scenario : Scenario
        Map, models, team, targets, duration, seed, and the system (``scenario.system``).
    controller : str, optional
        Shorthand for ``scenario.with_system(controller=...)``.

    Raises
    ------
    ValueError
        If the system has no central form (see the module docstring).
    """

    def __init__(self, scenario: Scenario, controller: str | None = None) -> None:
        if controller is not None:
            scenario = scenario.with_system(controller=controller)
        self.scenario = scenario
        self.grid = scenario.grid
        team = Team.build(scenario)
        central = team.parts["estimator"].central
        if central is None or "cell" not in team.parts["exchange"].provides:
            raise ValueError(f"the central engine needs an estimator with a central form and "
                             f"an exchange that partitions the map; system "
                             f"{scenario.system.label()} has "
                             f"{scenario.system.estimator}/{scenario.system.exchange}: use "
                             f"the distributed engine")
        self.world = World(scenario)
        self.filter = central(scenario)
        ids = self.world.robot_ids
        self.controllers = [team.make("controller", int(i)) for i in ids]
        self.rngs = [robot_generator(scenario.seed, int(i)) for i in ids]
        self.power_weights = np.zeros(len(ids))
        hook = team.parts["controller"].power_weight_guard
        self._guard = None if hook is None else hook(team.setups["controller"])
        self._figures = team.parts["controller"].figures
        self._live_rows: list[int] = []
        layer = team.parts["exchange"].map_layer
        #: The exchange's per-bin state over the map (None: it carries none).
        self.layer = None if layer is None else layer(scenario,
                                                      team.parts["controller"].requires)
        self.owners = np.empty(0, dtype=np.int64)
        self._generators = (np.empty((0, 2)), np.empty(0))
        self.goals = np.empty((0, 2))

    @property
    def step_index(self) -> int:
        """Index of the next step to run."""
        return self.world.step_index

    def step(self) -> None:
        """Run one full step (scan, filter, partition and control, world motion)."""
        world, grid = self.world, self.grid
        k = world.step_index
        scans = world.scans()
        ids = world.robot_ids
        positions = world.robot_positions
        empty = np.empty((0, 2))
        ordered = [Scan(int(rid), k, positions[r], scans.get(int(rid), empty))
                   for r, rid in enumerate(ids.tolist()) if int(rid) in scans]
        rho = self.power_weights.copy()
        if self._guard is not None:
            rho = self._guard.bound(positions, rho)
        self._generators = (positions.copy(), rho)
        self.owners = bin_owners(grid, positions, rho)
        order = np.argsort(self.owners, kind="stable")
        starts = np.searchsorted(self.owners[order], np.arange(len(ids) + 1))
        self.filter.predict_cells([order[starts[r]:starts[r + 1]] for r in range(len(ids))])
        self.filter.update_all(ordered)
        if self.layer is not None:
            self.layer.observe((scan.sensor, scan.z) for scan in ordered)
        w = self.filter.weights.reshape(-1)
        goals = {}
        goal_rows = np.empty((len(ids), 2))
        self._live_rows = []
        for r, rid in enumerate(ids.tolist()):
            rid = int(rid)
            if rid not in scans:
                goal_rows[r] = positions[r]
                continue
            self._live_rows.append(r)
            bins = order[starts[r]:starts[r + 1]]
            # The polygon is only needed where the weights of the bins are all 0 (the
            # centroid's fallback): computed then.
            local = CellDensity(grid, partial(self.cell, r), bins, w[bins],
                                **({} if self.layer is None else self.layer.of(bins)))
            d = self.controllers[r].decide(Knowledge(rid, k, positions[r], scans[rid], local),
                                           self.rngs[r])
            goals[rid] = d.goal
            goal_rows[r] = d.goal
            self.power_weights[r] = d.power_weight
        self.goals = goal_rows
        world.apply_goals(goals)
        world.advance()

    def cell(self, row: int) -> np.ndarray:
        """The cell polygon (V, 2) of the robot in ``row`` at the last step.

        A power cell (Chen eq. 12-13), or a Voronoi cell (Dames eq. 7) when every power
        weight is 0; (0, 2) if empty.
        """
        positions, rho = self._generators
        return cell_of(self.scenario.grid.env, row, positions, rho)[0]

    def run(self, steps: int | None = None) -> None:
        """Run ``steps`` steps (default: the rest of the scenario)."""
        n = self.scenario.steps - self.world.step_index if steps is None else steps
        for _ in range(n):
            self.step()

    def counters(self) -> dict[str, int]:
        """Protocol counters: none (there is no protocol), for the engines' one interface."""
        return {}

    def figures(self, truth: np.ndarray, ids: np.ndarray | None = None) -> dict[str, float]:
        """The controller's per-step figures (its ``figures`` hook), or none.

        ``figures(controllers, truth)`` hook of the controller part, given the
        controllers of the robots that decided at the last step (e.g. ``chen_o``'s count
        of busy robots that turned idle with a target in view,
        :func:`~phd_swarm.core.controllers.power_lloyd.controller.switching_figures`). The central
        form of the estimator is the grid PHD's, which has no figures of its own.
        """
        if self._figures is None:
            return {}
        return self._figures([self.controllers[r] for r in self._live_rows], truth)

    def team_weights(self) -> np.ndarray:
        """The team PHD as an image (ny, nx)."""
        return np.array(self.filter.weights)
