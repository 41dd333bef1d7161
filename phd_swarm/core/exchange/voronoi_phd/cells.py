"""The cells of one step as one robot sees them (Dames 2020 Alg. 1 lines 2-3).

:class:`LocalPartition` is the partition of the robot and the contacts whose states arrived
(the own power/Voronoi cell and who owns a bin,
:func:`~phd_swarm.core.geometry.ownership.assign_bins`: lowest power distance, lowest id
on ties, so all robots agree without a global view).
:class:`NeighbourCells` holds the cells the contacts sent, with their bounding boxes and
radii, for the questions later phases ask of them (whose cell is within reach of phantom
mass, which cell holds a field-of-view bin).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ...geometry.grid import Environment
from ...geometry.ownership import assign_checked, check_generators
from ...geometry.partition import cell_of
from ...geometry.polygons import points_in_any_polygon, points_in_polygon
from .messages import CellMsg, StateMsg, stacked


@dataclass(frozen=True)
class LocalPartition:
    """The robot and the contacts whose states arrived this step, by ascending id.

    Attributes
    ----------
    ids : np.ndarray of int64, shape (N,)
    positions : np.ndarray, shape (N, 2)
        Generators q [m].
    power_weights : np.ndarray, shape (N,)
        rho [m].
    cell : np.ndarray, shape (V, 2)
        The own cell (V = 0 when it is empty).
    neighbours : tuple of int
        Ids of the robots whose cells touch the own one.
    """

    ids: np.ndarray
    positions: np.ndarray
    power_weights: np.ndarray
    cell: np.ndarray
    neighbours: tuple[int, ...]

    @classmethod
    def compute(cls, env: Environment, state: StateMsg,
                states: dict[int, StateMsg]) -> LocalPartition:
        """The own cell from the own ``state`` and the contacts' ``states`` (Alg. 1 line 2)."""
        me = state.robot_id
        order = sorted(set(states) | {me})
        msgs = [state if i == me else states[i] for i in order]
        ids = np.array(order, dtype=np.int64)
        pos = stacked([m.position for m in msgs], 2)
        rho = np.array([m.power_weight for m in msgs], dtype=float)
        poly, rows = cell_of(env, order.index(me), pos, rho)
        return cls(ids, pos, rho, poly, tuple(order[r] for r in rows.tolist()))

    def message(self, state: StateMsg, states: dict[int, StateMsg]) -> CellMsg:
        """The own cell for the contacts (Alg. 1 line 3), with the table of ``states``.

        The table (ids, positions, power weights, cell radii of the states received) tells
        the receivers who their contacts' contacts are.
        """
        table = [states[i] for i in sorted(states)]
        return CellMsg(state.robot_id, state.step, state.position, state.power_weight,
                       self.cell, self.neighbours, tuple(m.robot_id for m in table),
                       stacked([m.position for m in table], 2),
                       np.array([m.power_weight for m in table], dtype=float),
                       np.array([m.cell_radius for m in table], dtype=float))

    def owners(self, points: np.ndarray) -> np.ndarray:
        """Ids of the robots owning the bins with centres ``points`` (K, 2), int64 (K,).

        :func:`~phd_swarm.core.geometry.ownership.assign_bins` of the bin centres (finite by
        construction), with the generators checked once per step.
        """
        q, rho2 = self._generators
        return self.ids[assign_checked(np.asarray(points, dtype=float).reshape(-1, 2), q, rho2)]

    @cached_property
    def _generators(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 2) [m] and squared power weights (N,) [m^2], checked."""
        return check_generators(self.positions, self.power_weights)


@dataclass(frozen=True)
class NeighbourCells:
    """The cells the contacts sent this step.

    Attributes
    ----------
    polygons : dict of int to (np.ndarray (V, 2), tuple of int)
        Each sender's cell and neighbour ids, in arrival order.
    box_ids : np.ndarray of int64, shape (B,)
        Senders of the non-empty cells, in arrival order.
    box_lo, box_hi : np.ndarray, shape (B, 2)
        Their bounding boxes [m].
    radius_ids : np.ndarray of int64, shape (C,)
        Every sender, ascending.
    radii : np.ndarray, shape (C,)
        Their cell radii [m] (largest generator-to-vertex distances).
    """

    polygons: dict[int, tuple[np.ndarray, tuple[int, ...]]]
    box_ids: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    radius_ids: np.ndarray
    radii: np.ndarray

    @classmethod
    def receive(cls, msgs: dict[int, CellMsg]) -> NeighbourCells:
        """The cells of the messages ``msgs`` (by sender, in arrival order)."""
        polygons = {src: (np.asarray(m.vertices).reshape(-1, 2), tuple(m.neighbour_ids))
                    for src, m in msgs.items()}
        ids = np.fromiter(msgs, dtype=np.int64, count=len(msgs))
        # Positions (arrival order) of the non-empty cells, whose vertices in one array give
        # both the radii (as polygons.cell_radii) and the boxes (as polygons.bounding_boxes).
        full = np.array([k for k, (poly, _) in enumerate(polygons.values()) if len(poly)],
                        dtype=np.intp)
        radii = np.zeros(ids.size)
        lo, hi = np.empty((0, 2)), np.empty((0, 2))
        if full.size:
            gens = [m.generator[:2] for m in msgs.values()]
            polys = [p for p, _ in polygons.values()]
            sizes = [len(polys[k]) for k in full.tolist()]
            starts = np.cumsum([0, *sizes[:-1]])
            vertices = np.concatenate([polys[k] for k in full.tolist()])
            q = np.repeat(stacked([gens[k] for k in full.tolist()], 2), sizes, axis=0)
            radii[full] = np.sqrt(np.maximum.reduceat(((vertices - q) ** 2).sum(axis=1),
                                                      starts))
            lo = np.minimum.reduceat(vertices, starts, axis=0)
            hi = np.maximum.reduceat(vertices, starts, axis=0)
        order = np.argsort(ids, kind="stable")
        return cls(polygons, ids[full], lo, hi, ids[order], radii[order])

    def cells_of(self, ids: np.ndarray) -> list[np.ndarray]:
        """The cells of the senders ``ids``, in that order."""
        return [self.polygons[rid][0] for rid in ids.tolist()]

    def neighbours_of(self, rid: int) -> tuple[int, ...]:
        """Neighbour ids robot ``rid`` sent with its cell (none if it sent no cell)."""
        return self.polygons.get(rid, (None, ()))[1]

    def uncovered(self, cell: np.ndarray, points: np.ndarray, owners: np.ndarray,
                  alive: Callable[[np.ndarray], np.ndarray], tol: float) -> int:
        """Number of ``points`` in neither the own ``cell`` nor a live sender's cell.

        ``owners`` (N,) are the ids of the robots owning the ``points`` (N, 2): the cells
        are tried in decreasing number of points owned, so that most points are found in
        the first few cells (the count does not depend on the order).
        """
        covered = points_in_polygon(points, cell, tol) if len(cell) else \
            np.zeros(len(points), dtype=bool)
        if covered.all():
            return 0
        # Only cells whose boxes meet the box of all the points can hold any of them.
        lo, hi = points.min(axis=0), points.max(axis=0)
        near = (alive(self.box_ids) & np.all(self.box_lo <= hi, axis=1)
                & np.all(self.box_hi >= lo, axis=1))
        ids = self.box_ids[near]
        owned = (owners[~covered][:, None] == ids[None, :]).sum(axis=0)
        ids = ids[np.argsort(-owned, kind="stable")]
        covered[~covered] = points_in_any_polygon(points[~covered], self.cells_of(ids), tol)
        return int((~covered).sum())


__all__ = ["LocalPartition", "NeighbourCells"]
