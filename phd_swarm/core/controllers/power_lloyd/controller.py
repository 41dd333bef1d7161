"""Power-diagram Lloyd controllers of Chen, Dames & Park (2021): ``chen_p`` and ``chen_o``.

- ``chen_p`` (Sec. 4.2, "P"): power cells with rho = (PHD mass of the cell)^(-1/2)
  (eq. 14), phi = the PHD.
- ``chen_o`` (Alg. 1, "O"): power cells with rho = (cumulative mass of the cell)^(-1/2)
  (eq. 13); phi = wc (eq. 11) for idle robots (empty scan), the PHD for busy ones
  (lines 12-15).

The power weight computed at the end of step t is used for the partition of step t+1 (Chen
Alg. 1 computes the cell from the weights the robots exchange with their states).

Options (docs/decisions.md, "Power weights"):

- ``rho_cap``: what bounds rho. ``fixed`` (default): ``min(mass^(-1/2), rho_max)``.
  ``nearest_robot``: the paper's uncapped weight (eq. 13-14), guarded at the partition by
  :func:`~phd_swarm.core.controllers.power_lloyd.cumulative.nearest_robot_cap` with a margin of one
  bin, so that every robot keeps its own position in its cell; the partition is the team's, so this
  runs on the central engine only (:class:`~.base.PowerWeightGuard`).
- ``rho_max``: the fixed cap [m]; 0 is the sensing radius with ``rho_cap: fixed`` and no
  fixed cap with ``nearest_robot`` (a value > 0 then caps as well).
- ``cumulative_mode``: the reading of eq. 11
  (:func:`phd_swarm.core.controllers.power_lloyd.cumulative.cumulative_weight`).

``chen_o`` also reports how often a busy robot turns idle on an empty scan while a target
is in its field of view (:func:`switching_figures`, Alg. 1 lines 12-15).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from ... import registry
from ...geometry.centroids import centroid_goal
from ...params import ParamSpec
from ..base import Controller, Decision, Knowledge, PowerWeightGuard
from ..lloyd import REQUIRES
from .cumulative import (
    MODES,
    cell_mass,
    chen_lloyd_weights,
    cumulative_weight,
    nearest_robot_cap,
    power_weight,
)

#: What bounds rho (:data:`RHO_CAP`).
RHO_CAPS = ("fixed", "nearest_robot")

RHO_MAX = ParamSpec("rho_max", 0.0, "chen_p, chen_o: fixed cap on the power weight rho [m]; "
                    "0 is the sensing radius with rho_cap fixed and no fixed cap with "
                    "rho_cap nearest_robot (docs/decisions.md).", low=0.0, high=1e6)
RHO_CAP = ParamSpec("rho_cap", "fixed", "chen_p, chen_o: what bounds rho = mass^(-1/2) "
                    "(Chen eq. 13-14): fixed, rho_max; nearest_robot, the paper's uncapped "
                    "weight with a guard at the partition, rho <= sqrt(D^2 - 2 r D) for D "
                    "the distance to the robot's nearest other robot and r the bin side, "
                    "which keeps every robot in its own cell (central engine only; "
                    "docs/decisions.md).", choices=RHO_CAPS)
CUMULATIVE_MODE = ParamSpec("cumulative_mode", "rate", "chen_o: Chen eq. 11, rate (default) "
                            "or literal reading, or laplace: the rule of succession "
                            "(docs/decisions.md).", choices=MODES)


@dataclass(frozen=True)
class PowerLloydConfig:
    """Resolved options of a power-diagram controller.

    Attributes
    ----------
    rho_max : float
        Cap of rho in the controller [m], > 0 (the map's diagonal for an uncapped weight:
        no two robots in E are farther apart, so the guard alone decides).
    cumulative_mode : str
        Reading of Chen eq. 11.
    rho_cap : str
        One of :data:`RHO_CAPS`.
    margin : float
        Margin m of the ``nearest_robot`` guard [m] (the bin side).
    sensing_radius : float
        Radius of the field of view [m], for :func:`switching_figures`.
    """

    rho_max: float
    cumulative_mode: str = "rate"
    rho_cap: str = "fixed"
    margin: float = 0.0
    sensing_radius: float = 0.0


def setup(scenario: Any, system: Any, **runtime: Any) -> PowerLloydConfig:
    """Resolve ``rho_max`` (0: the sensing radius, or none with the guard) and eq. 11."""
    options = dict(system.options)
    radius = float(scenario.models.detection.radius)
    rho_cap = options.get("rho_cap", "fixed")
    if rho_cap == "nearest_robot":
        env = scenario.grid.env
        rho_max = options["rho_max"] or math.hypot(env.width, env.height)
    else:
        rho_max = options["rho_max"] or radius
    return PowerLloydConfig(float(rho_max), options.get("cumulative_mode", "rate"), rho_cap,
                            float(scenario.grid.resolution), radius)


def power_weight_guard(config: PowerLloydConfig) -> PowerWeightGuard | None:
    """The partition's bound on rho for ``rho_cap: nearest_robot``, else None."""
    if config.rho_cap != "nearest_robot":
        return None
    return PowerWeightGuard("rho_cap: nearest_robot",
                            partial(nearest_robot_cap, margin=config.margin))


class PowerLloydP(Controller):
    """Chen's "P": phi = the PHD, rho from the cell's PHD mass (eq. 14)."""

    def __init__(self, config: PowerLloydConfig) -> None:
        self.config = config

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Goal: the PHD-weighted centroid; next rho = min(mass^(-1/2), rho_max)."""
        c = knowledge.local
        goal = centroid_goal(c.grid, c.bins, c.phd, c.cell, knowledge.position)
        rho = power_weight(cell_mass(c.phd, c.grid.bin_area, "phd"), self.config.rho_max)
        return Decision(goal=np.asarray(goal, dtype=float), power_weight=float(rho))


class PowerLloydO(Controller):
    """Chen's "O" (Alg. 1): idle robots follow wc, busy ones the PHD; rho from wc (eq. 13).

    Attributes
    ----------
    busy : bool
        Whether the last scan held a measurement (Alg. 1 line 12).
    turned_idle : bool
        Whether the robot was busy at the step before the last and idle at the last.
    position : np.ndarray, shape (2,), or None
        Where the last scan was taken [m].
    step : int
        The last step decided (-1 before the first).
    """

    def __init__(self, config: PowerLloydConfig) -> None:
        self.config = config
        self.busy = False
        self.turned_idle = False
        self.position: np.ndarray | None = None
        self.step = -1

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Goal: the centroid weighted by wc (idle) or the PHD (busy); rho from wc."""
        c = knowledge.local
        if c.alpha is None or c.count is None:
            raise ValueError("controller chen_o needs the cumulative state (alpha, count)")
        busy = len(knowledge.z) > 0
        self.turned_idle = self.busy and not busy
        self.busy = busy
        self.position = np.asarray(knowledge.position, dtype=float)
        self.step = knowledge.step
        wc = cumulative_weight(c.alpha, c.count, self.config.cumulative_mode)
        phi = chen_lloyd_weights(busy, c.phd, wc)
        goal = centroid_goal(c.grid, c.bins, phi, c.cell, knowledge.position)
        rho = power_weight(cell_mass(wc, c.grid.bin_area, "cumulative"), self.config.rho_max)
        return Decision(goal=np.asarray(goal, dtype=float), power_weight=float(rho))


def switching_figures(controllers: Sequence[PowerLloydO],
                      truth: np.ndarray) -> dict[str, float]:
    """How often a busy "O" robot turns idle with a target in view (Alg. 1 lines 12-15).

    A busy robot steers by the PHD; one empty scan makes it idle, and it steers by wc at
    once, up to v dt away. With p_D = 0.8 and a clutter mean of 0.287 per scan, a scan
    with one target in view is empty with probability 0.2 exp(-0.287) = 0.15. Counted
    over the robots that decided at the latest step (the live ones):

    - ``busy_robots``: robots whose scan held a measurement;
    - ``turned_idle``: robots busy at the step before and idle now;
    - ``turned_idle_in_view``: of those, robots with a true target within the sensing
      radius of where the empty scan was taken.

    Summed over a run, ``turned_idle_in_view[k] / busy_robots[k-1]`` is the chance per
    step that a busy robot leaves a target it can still see.

    Parameters
    ----------
    controllers : sequence of PowerLloydO
        The live robots' controllers, after their decisions of the step.
    truth : np.ndarray, shape (N, 2)
        The true targets the step's scans were taken of [m].

    Returns
    -------
    dict of str to float
        The three counts.
    """
    live = [c for c in controllers if c.position is not None]
    latest = max((c.step for c in live), default=-1)
    live = [c for c in live if c.step == latest]
    x = np.asarray(truth, dtype=float).reshape(-1, 2)
    turned = [c for c in live if c.turned_idle]
    in_view = sum(1 for c in turned if x.size and np.any(
        np.sum((x - c.position) ** 2, axis=1) <= c.config.sensing_radius ** 2))
    return {"busy_robots": float(sum(c.busy for c in live)),
            "turned_idle": float(len(turned)), "turned_idle_in_view": float(in_view)}


registry.register(
    "controller", "chen_p", lambda config, rid: PowerLloydP(config), setup=setup,
    description="Power-diagram Lloyd, rho from the cell's PHD mass (Chen 2021 eq. 14, 'P').",
    options=(RHO_MAX, RHO_CAP), requires=REQUIRES, power_weight_guard=power_weight_guard)
registry.register(
    "controller", "chen_o", lambda config, rid: PowerLloydO(config), setup=setup,
    description="Power-diagram Lloyd with Chen's cumulative density (Chen 2021 Alg. 1, 'O').",
    options=(RHO_MAX, RHO_CAP, CUMULATIVE_MODE), requires=(*REQUIRES, "cumulative"),
    power_weight_guard=power_weight_guard, figures=switching_figures)
