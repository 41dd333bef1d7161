"""Power-diagram Lloyd controllers of Chen, Dames & Park (2021): ``chen_p`` and ``chen_o``.

- ``chen_p`` (Sec. 4.2, "P"): power cells with rho = (PHD mass of the cell)^(-1/2)
  (eq. 14), phi = the PHD.
- ``chen_o`` (Alg. 1, "O"): power cells with rho = (cumulative mass of the cell)^(-1/2)
  (eq. 13); phi = wc (eq. 11) for idle robots (empty scan), the PHD for busy ones
  (lines 12-15).

The power weight computed at the end of step t is used for the partition of step t+1 (Chen
Alg. 1 computes the cell from the weights the robots exchange with their states).

Options: ``rho_max``, the cap of rho [m] (0: the sensing radius, docs/decisions.md), and
``cumulative_mode``, the reading of eq. 11 (:func:`phd_swarm.core.cumulative.cumulative_weight`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import registry
from ..cumulative import MODES, cell_mass, chen_lloyd_weights, cumulative_weight, power_weight
from ..lloyd import centroid_goal
from ..params import ParamSpec
from .base import Controller, Decision, Knowledge
from .lloyd import REQUIRES

RHO_MAX = ParamSpec("rho_max", 0.0, "chen_p, chen_o: cap on the power weight rho [m]; 0 "
                    "uses the sensing radius (docs/decisions.md).", low=0.0, high=1e6)
CUMULATIVE_MODE = ParamSpec("cumulative_mode", "rate", "chen_o: Chen eq. 11, rate (default) "
                            "or literal reading, or laplace: the rule of succession "
                            "(docs/decisions.md).", choices=MODES)


@dataclass(frozen=True)
class PowerLloydConfig:
    """Resolved options of a power-diagram controller.

    Attributes
    ----------
    rho_max : float
        Cap of rho [m], > 0.
    cumulative_mode : str
        Reading of Chen eq. 11.
    """

    rho_max: float
    cumulative_mode: str = "rate"


def setup(scenario: Any, system: Any, **runtime: Any) -> PowerLloydConfig:
    """Resolve ``rho_max`` (0: the scenario's sensing radius) and the eq. 11 reading."""
    options = dict(system.options)
    rho_max = options["rho_max"] or scenario.models.detection.radius
    return PowerLloydConfig(float(rho_max), options.get("cumulative_mode", "rate"))


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
    """Chen's "O" (Alg. 1): idle robots follow wc, busy ones the PHD; rho from wc (eq. 13)."""

    def __init__(self, config: PowerLloydConfig) -> None:
        self.config = config

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Goal: the centroid weighted by wc (idle) or the PHD (busy); rho from wc."""
        c = knowledge.local
        if c.alpha is None or c.count is None:
            raise ValueError("controller chen_o needs the cumulative state (alpha, count)")
        wc = cumulative_weight(c.alpha, c.count, self.config.cumulative_mode)
        phi = chen_lloyd_weights(len(knowledge.z) > 0, c.phd, wc)
        goal = centroid_goal(c.grid, c.bins, phi, c.cell, knowledge.position)
        rho = power_weight(cell_mass(wc, c.grid.bin_area, "cumulative"), self.config.rho_max)
        return Decision(goal=np.asarray(goal, dtype=float), power_weight=float(rho))


registry.register(
    "controller", "chen_p", lambda config, rid: PowerLloydP(config), setup=setup,
    description="Power-diagram Lloyd, rho from the cell's PHD mass (Chen 2021 eq. 14, 'P').",
    options=(RHO_MAX,), requires=REQUIRES)
registry.register(
    "controller", "chen_o", lambda config, rid: PowerLloydO(config), setup=setup,
    description="Power-diagram Lloyd with Chen's cumulative density (Chen 2021 Alg. 1, 'O').",
    options=(RHO_MAX, CUMULATIVE_MODE), requires=(*REQUIRES, "cumulative"))
