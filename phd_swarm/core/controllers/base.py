"""The controller role: where a robot goes next, from what it knows.

A controller is one object per robot, made by its registry entry
(:mod:`phd_swarm.core.registry`), so it may keep state from step to step (a planner's
path, a random walk's node). At the end of each step the agent
(:class:`phd_swarm.core.agent.Agent`) calls :meth:`Controller.decide` with what the robot
knows (:class:`Knowledge`) and the robot's own seeded generator, and moves toward the
returned goal (the world bounds the step, Chen eq. 3).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry.grid import Grid


@dataclass(frozen=True)
class Decision:
    """A robot's goal for the next move and its power weight for the next partition.

    Attributes
    ----------
    goal : np.ndarray, shape (2,)
        Where the robot heads [m], world frame; it moves at most one step toward it.
    power_weight : float
        rho of the robot's generator in the next step's power diagram [m] (Chen eq. 12);
        0 for Voronoi cells and for systems without a partition.
    """

    goal: np.ndarray
    power_weight: float = 0.0


@dataclass(frozen=True)
class PowerWeightGuard:
    """A bound on the power weights, applied where the team's partition is computed.

    A controller part whose options need one declares the hook
    the part's ``power_weight_guard(setup) -> PowerWeightGuard | None`` hook (None: no bound).
    The central engine applies ``bound`` to the robots' weights at their positions before
    each partition; a robot of the distributed protocol knows only its contacts' states,
    not the positions the bound needs, so :class:`~phd_swarm.core.agent.Agent` refuses a
    system that declares one.

    Attributes
    ----------
    option : str
        The option that asks for the bound, for errors (e.g. ``rho_cap: nearest_robot``).
    bound : callable
        ``bound(positions (R, 2), rho (R,)) -> rho' (R,)`` [m], rows ordered by robot id.
    """

    option: str
    bound: Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class CellDensity:
    """What a robot of a partitioned grid-PHD system knows of its own cell.

    Provided by the ``grid_density`` + ``cell`` capabilities (the grid PHD estimator with
    the Voronoi exchange, or the central engine's team filter and partition).

    Attributes
    ----------
    grid : Grid
        The bin grid.
    cell : np.ndarray, shape (V, 2), or a callable returning it
        The robot's cell polygon; a callable is called only if needed (the centroid's
        fallback when every weight is 0).
    bins : np.ndarray of int, shape (K,)
        Flat indices of the bins the robot owns.
    phd : np.ndarray, shape (K,)
        Their PHD masses (expected targets per bin).
    alpha, count : np.ndarray, shape (K,), or None
        Chen's cumulative state of the bins (rewards and observations, eq. 9-10), when the
        controller asks for it (a controller that requires ``cumulative``).
    """

    grid: Grid
    cell: np.ndarray | Callable[[], np.ndarray]
    bins: np.ndarray
    phd: np.ndarray
    alpha: np.ndarray | None = None
    count: np.ndarray | None = None


@dataclass(frozen=True)
class Knowledge:
    """What a robot knows at the end of step k, for its controller.

    Attributes
    ----------
    robot_id : int
    step : int
        The step just finished.
    position : np.ndarray, shape (2,)
        The robot's position q^k [m].
    z : np.ndarray, shape (M, 2)
        Its own measurement set Z^k [m] (M may be 0).
    local : object
        What the estimator and exchange provide (e.g. :class:`CellDensity`); its type is
        given by the parts' capabilities (:mod:`phd_swarm.core.registry`).
    estimator : object
        The robot's estimator (:class:`~phd_swarm.core.estimators.base.Estimator`, or what
        the part makes), for controllers that plan on the belief itself.
    """

    robot_id: int
    step: int
    position: np.ndarray
    z: np.ndarray
    local: Any = None
    estimator: Any = None


class Controller(ABC):
    """Decides a robot's next goal (one instance per robot; may keep state).

    What it needs of the estimator and the exchange (e.g. a grid density over a cell, Chen's
    cumulative layer) is declared with its registry entry (``requires``).
    """

    @abstractmethod
    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """The goal for the next move (and the next power weight).

        Parameters
        ----------
        knowledge : Knowledge
            What the robot knows at the end of the step.
        rng : np.random.Generator
            The robot's own generator (seeded from the scenario seed and the robot id);
            the only source of randomness a controller may use.
        """

    def planned_path(self) -> np.ndarray:
        """The waypoints the robot will visit next, in order, for display [m].

        Read-only: it changes nothing the controller decides. The default is no path;
        planners that keep one (e.g. Sung & Tokekar's, :mod:`.sung_planners`) override it.

        Returns
        -------
        np.ndarray, shape (P, 2)
            World frame; P may be 0 (no plan, or before the first :meth:`decide`).
        """
        return np.empty((0, 2))
