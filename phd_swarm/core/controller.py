"""The controllers: which weight Lloyd's algorithm uses, and the next power weight.

Kinds (chosen in the scenario config):

- ``phd`` (Dames 2020, the "D" method of Chen): Voronoi cells, phi = the PHD (eq. 8).
- ``uniform`` (the coverage baseline of Dames Sec. IV): Voronoi cells, phi = 1.
- ``chen_p`` (Chen Sec. 4.2, "P"): power cells with rho = (PHD mass of the cell)^(-1/2)
  (eq. 14), phi = the PHD.
- ``chen_o`` (Chen Alg. 1, "O"): power cells with rho = (cumulative mass of the cell)^(-1/2)
  (eq. 13); phi = wc for idle robots (empty scan), the PHD for busy ones (lines 12-15).

The power weight computed at the end of step t is used for the partition of step t+1 (Chen
Alg. 1 computes the cell from the weights the robots exchange with their states).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .cumulative import cell_mass, chen_lloyd_weights, cumulative_weight, power_weight
from .grid import Grid
from .lloyd import centroid_goal

KINDS = ("phd", "uniform", "chen_p", "chen_o")


@dataclass(frozen=True)
class ControllerConfig:
    """Controller choice and its parameters.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    rho_max : float
        Cap of the power weight [m] (see :func:`cumulative.power_weight`).
    cumulative_mode : str
        ``rate`` or ``literal`` reading of Chen eq. 11 (``docs/decisions.md``).
    """

    kind: str = "phd"
    rho_max: float = 141.42
    cumulative_mode: str = "rate"

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"controller kind must be one of {KINDS}, got {self.kind!r}")
        if not (np.isfinite(self.rho_max) and self.rho_max > 0):
            raise ValueError(f"controller rho_max must be finite and > 0, got {self.rho_max}")

    @property
    def uses_cumulative(self) -> bool:
        """Whether the robots must carry Chen's alpha and n."""
        return self.kind == "chen_o"

    @property
    def uses_power(self) -> bool:
        """Whether cells are power cells (else Voronoi, rho = 0)."""
        return self.kind in ("chen_p", "chen_o")


def as_controller(controller: ControllerConfig | str, rho_max: float) -> ControllerConfig:
    """``controller`` itself, or a bare kind (``phd``, ...) as a config with ``rho_max``.

    The engines take either; a kind gets the scenario's sensing radius as ``rho_max``.
    """
    if isinstance(controller, str):
        return ControllerConfig(kind=controller, rho_max=rho_max)
    return controller


@dataclass(frozen=True)
class Decision:
    """A robot's goal for the next move and its power weight for the next partition."""

    goal: np.ndarray
    power_weight: float


def decide(config: ControllerConfig, grid: Grid, position: np.ndarray,
           cell: np.ndarray | Callable[[], np.ndarray],
           bins: np.ndarray, phd: np.ndarray, has_measurement: bool,
           alpha: np.ndarray | None = None, count: np.ndarray | None = None) -> Decision:
    """Goal (weighted centroid of the own bins, Dames eq. 8 / Chen eq. 2) and next rho.

    Parameters
    ----------
    config : ControllerConfig
    grid : Grid
    position : np.ndarray, shape (2,)
        Robot position q [m].
    cell : np.ndarray, shape (V, 2), or a callable returning it
        Own cell polygon (fallback centroid when the weight is zero; a callable is called
        only then).
    bins : np.ndarray of int, shape (K,)
        Bins the robot owns.
    phd : np.ndarray, shape (K,)
        Their PHD masses.
    has_measurement : bool
        Whether the robot's latest scan was non-empty (Chen's busy / idle).
    alpha, count : np.ndarray, shape (K,), optional
        Chen's cumulative state of the bins (``chen_o`` only).

    Returns
    -------
    Decision
    """
    kind = config.kind
    if kind == "uniform":
        phi = np.ones(bins.size)
    elif kind == "chen_o":
        if alpha is None or count is None:
            raise ValueError("controller chen_o needs the cumulative state (alpha, count)")
        wc = cumulative_weight(alpha, count, config.cumulative_mode)
        phi = chen_lloyd_weights(has_measurement, phd, wc)
    else:
        phi = phd
    goal = centroid_goal(grid, bins, phi, cell, position)
    if kind == "chen_p":
        rho = power_weight(cell_mass(phd, grid.bin_area, "phd"), config.rho_max)
    elif kind == "chen_o":
        rho = power_weight(cell_mass(wc, grid.bin_area, "cumulative"), config.rho_max)
    else:
        rho = 0.0
    return Decision(goal=np.asarray(goal, dtype=float), power_weight=float(rho))
