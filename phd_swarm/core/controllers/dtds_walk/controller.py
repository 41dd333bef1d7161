"""Shirsat & Berman's random walk on the spatial grid: the controller ``dtds_walk``.

Each robot performs the DTDS Markov chain of Sec. III on a square grid of nodes over the
map (:class:`~phd_swarm.core.controllers.dtds_walk.grid_graph.GridGraph`): at every step it moves
from its node i to a node of N(i) ∪ {i}, each with probability 1 / (d_i + 1) (eq. 4), drawn from
the robot's own generator. The goal of a decision is the position of the next node; the world
moves the robot at most ``robot_max_speed * dt`` toward it, so a move must fit in one
step (checked at set-up). A robot that is not on a node (its start, unless the scenario
places robots on the grid with ``robot_start_grid``) first heads for its nearest node,
without a draw.

Options: ``grid_spacing`` (the cell side [m]) and ``grid_neighbours`` (4: moves along
the axes; 8: also the diagonals; the paper does not say which).

Reference: A. Shirsat and S. Berman, "Decentralized multi-target tracking with multiple
quadrotors using a PHD filter", AIAA SciTech 2021, Sec. II-III, eq. 1-4, Algorithm 1
step 1.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ... import registry
from ...params import ParamSpec
from ..base import Controller, Decision, Knowledge
from .grid_graph import GridGraph

#: A robot is on a node when it is this close to it [m] (the world lands robots exactly).
ON_NODE = 1e-9

GRID_SPACING = ParamSpec(
    "grid_spacing", 1.0,
    "dtds_walk: side of the square grid's cells [m], the distance between neighbouring "
    "nodes (Shirsat & Berman Sec. II); robot_max_speed * dt must cover one move.",
    low=1e-3, high=1e4)
GRID_NEIGHBOURS = ParamSpec(
    "grid_neighbours", 4,
    "dtds_walk: moves of the random walk (eq. 4), 4 (along the axes) or 8 (with the "
    "diagonals); the paper does not say which.", low=4, high=8)


def _option(spec: ParamSpec, options: dict[str, Any]) -> Any:
    return spec.check(options.get(spec.name, spec.default), "system.options")


def setup(scenario: Any, system: Any, **runtime: Any) -> GridGraph:
    """The team's grid graph over ``scenario.env``, shared by every robot's walk.

    Raises
    ------
    ValueError
        For an option out of range (``system.options: grid_spacing: ...``), a
        ``grid_neighbours`` other than 4 or 8, or a robot that cannot make the longest
        move (the spacing, or its diagonal) in one step of ``robot_max_speed * dt``; the
        message names both lengths.
    """
    options = dict(getattr(system, "options", ()) or ())
    spacing = _option(GRID_SPACING, options)
    neighbours = _option(GRID_NEIGHBOURS, options)
    if neighbours not in (4, 8):
        raise ValueError(f"system.options: grid_neighbours: expected 4 or 8, "
                         f"got {neighbours}")
    env = scenario.env
    graph = GridGraph(env.xmin, env.ymin, env.xmax, env.ymax, spacing, neighbours)
    speed, dt = float(scenario.robot_max_speed), float(scenario.dt)
    reach = speed * dt
    longest = graph.longest_move
    if reach < longest * (1.0 - 1e-9):
        kind = "the diagonal of a cell" if neighbours == 8 else "one grid spacing"
        raise ValueError(
            f"dtds_walk: a robot moves at most robot_max_speed * dt = {speed:g} m/s x "
            f"{dt:g} s = {reach:g} m per step, shorter than the longest move of the walk, "
            f"{kind}: {longest:g} m (grid_spacing {spacing:g} m, grid_neighbours "
            f"{neighbours}); set robot_max_speed >= {longest / dt:g} m/s or a smaller "
            f"grid_spacing")
    return graph


class DtdsWalk(Controller):
    """One robot's random walk on the grid (Shirsat & Berman eq. 4).

    Parameters
    ----------
    graph : GridGraph
        From :func:`setup`, shared by the team.
    """

    def __init__(self, graph: GridGraph) -> None:
        self.graph = graph
        #: The goal of the last decision [m]; None before the first.
        self.goal: np.ndarray | None = None

    def next_node(self, position: np.ndarray, rng: np.random.Generator) -> int:
        """The node the robot goes to next (its index).

        A draw of eq. 4 from the node the robot stands on (within :data:`ON_NODE`) with
        ``rng``; off the grid, its nearest node, without a draw.
        """
        x, y = np.asarray(position, dtype=float).reshape(2).tolist()
        node = self.graph.node_of_point(x, y)
        nx, ny = self.graph.positions[node].tolist()
        if math.hypot(nx - x, ny - y) > ON_NODE:
            return node
        return int(self.graph.step(rng, np.array([node]))[0])

    def decide(self, knowledge: Knowledge, rng: np.random.Generator) -> Decision:
        """Goal: the position of the next node (eq. 4); power weight 0."""
        node = self.next_node(knowledge.position, rng)
        self.goal = self.graph.positions[node].copy()
        return Decision(goal=self.goal.copy(), power_weight=0.0)

    def planned_path(self) -> np.ndarray:
        """The goal of the last decision, one waypoint [m], shape (1, 2); none before."""
        if self.goal is None:
            return np.empty((0, 2))
        return self.goal.reshape(1, 2).copy()


registry.register(
    "controller", "dtds_walk", lambda graph, rid: DtdsWalk(graph), setup=setup,
    description="Random walk on a square grid of nodes, each move to a neighbour or staying "
                "with probability 1 / (d_i + 1) (Shirsat & Berman 2021, eq. 4).",
    options=(GRID_SPACING, GRID_NEIGHBOURS), provides=("grid_walk",))
