"""The prediction with phantom mass (Dames 2020 Sec. III-B, eq. 3).

Each robot predicts over its own bins expanded by the support of the motion kernel; the
mass that lands on other robots' bins (the phantom particles) is sent to their owners, a
transfer, possibly empty, to every contact whose cell lies within the kernel's reach.
Skipped for static targets (identity kernel, :func:`static_prediction`).

Disagreeing partitions (see :mod:`.handover`): phantom mass for a contact whose cell is out
of reach is dropped by the sender (``stats['unroutable_bins']``), phantom mass handed to a
robot that does not own the bins is dropped by the receiver (``stats['misrouted_bins']``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ...estimators.grid_phd.filter import spread
from ...geometry.polygons import isin_sorted, polygon_distances
from ..base import Envelope
from .cells import LocalPartition, NeighbourCells
from .context import FilterContext
from .handover import misrouted
from .messages import TransferKind, TransferMsg

_log = logging.getLogger("phd_swarm.protocol")


def moves_mass(ctx: FilterContext) -> bool:
    """Whether the motion kernel moves mass between bins (else targets are static)."""
    return ctx.kernel.shape != (1, 1)


def static_prediction(ctx: FilterContext, bins: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Eq. 3 with the identity kernel: p_s w + birth over the own bins, shape (K,)."""
    return ctx.survival[bins] * weights + ctx.birth[bins]


class PhantomExchange:
    """The prediction of robot ``robot_id`` in one step, with the phantom mass exchanged.

    Parameters
    ----------
    robot_id : int
    ctx : FilterContext
    stats : dict
        The robot's counters (shared).

    Attributes
    ----------
    peers : set of int
        Live contacts whose cells lie within the kernel's reach of the own cell: each gets
        a phantom transfer and sends one.
    """

    def __init__(self, robot_id: int, ctx: FilterContext, stats: dict[str, int]) -> None:
        self.robot_id = robot_id
        self.ctx = ctx
        self.stats = stats
        self.peers: set[int] = set()
        #: Predicted mass that stays on the own bins, shape (K,).
        self._own: np.ndarray | None = None

    def drop(self, ids: set[int]) -> None:
        """Stop waiting for the robots ``ids`` (declared dead)."""
        self.peers -= ids

    def send(self, step: int, bins: np.ndarray, weights: np.ndarray, view: LocalPartition,
             cells: NeighbourCells, alive: Callable[[np.ndarray], np.ndarray]
             ) -> list[Envelope]:
        """Eq. 3 over the own ``bins``; the phantom mass for other robots' bins goes to them.

        Parameters
        ----------
        step : int
        bins, weights : np.ndarray, shape (K,)
            The own bins (ascending) and their masses after the hand-over.
        view : LocalPartition
            This step's partition (who owns the bins the mass lands on).
        cells : NeighbourCells
            The contacts' cells (who is within reach).
        alive : callable
            Which robot ids (N,) are not declared dead, bool (N,).
        """
        ctx = self.ctx
        mass = ctx.survival[bins] * weights
        flat, moved = spread(ctx.grid, bins, mass, ctx.kernel)
        mine = isin_sorted(flat, bins)
        own = np.zeros(bins.size)
        own[np.searchsorted(bins, flat[mine])] = moved[mine]
        self._own = own
        self.peers = _within_reach(view.cell, cells, alive, ctx.reach)
        others = ~mine & (moved > 0)
        out_bins: dict[int, np.ndarray] = {}
        if others.any():
            idx = np.flatnonzero(others)
            owners = view.owners(ctx.grid.centres_of(flat[idx]))
            for dst in np.unique(owners):
                dst = int(dst)
                sel = idx[owners == dst]
                if dst not in self.peers:
                    # The own partition gives these bins to a contact whose own cell is not
                    # within reach: the partitions disagree (a neighbour missing from a
                    # contact set, docs/protocol.md). The mass has nowhere to go.
                    self.stats["unroutable_bins"] += int(sel.size)
                    _log.warning("robot %d: phantom mass for %d bins of robot %d, whose cell "
                                 "is not within the motion kernel's reach at step %d; "
                                 "dropped (%.3g targets)", self.robot_id, int(sel.size), dst,
                                 step, float(moved[sel].sum()))
                    continue
                out_bins[dst] = sel
        out = []
        for dst in sorted(self.peers):
            sel = out_bins.get(dst, np.empty(0, dtype=np.int64))
            out.append(Envelope(self.robot_id, int(dst), TransferMsg(
                self.robot_id, dst, step, TransferKind.PHANTOM, flat[sel], moved[sel])))
        return out

    def add(self, step: int, bins: np.ndarray, transfers: dict[int, TransferMsg]) -> np.ndarray:
        """The predicted masses of the own ``bins``: own mass, phantom mass received, birth.

        ``transfers`` are the phantom transfers received, by sender; they are added in
        increasing sender id. Returns shape (K,).
        """
        w = self._own
        assert w is not None
        for src in sorted(transfers):
            msg = transfers[src]
            received = np.asarray(msg.bins, dtype=np.int64)
            if received.size == 0:
                continue
            pos = np.searchsorted(bins, received)
            ok = (pos < bins.size) & (bins[np.minimum(pos, bins.size - 1)] == received)
            weights = np.asarray(msg.weights)
            if not ok.all():
                misrouted(self.stats, self.robot_id, int((~ok).sum()), "phantom bins", step)
                pos, weights = pos[ok], weights[ok]
            np.add.at(w, pos, weights)
        return w + self.ctx.birth[bins]


def _within_reach(cell: np.ndarray, cells: NeighbourCells,
                  alive: Callable[[np.ndarray], np.ndarray], reach: float) -> set[int]:
    """Live senders of ``cells`` whose cells come within ``reach`` [m] of the own ``cell``."""
    peers: set[int] = set()
    if len(cell) == 0:
        return peers
    lo, hi = cell.min(axis=0), cell.max(axis=0)
    # Bounding boxes further apart than the reach cannot hold closer polygons.
    gap = np.maximum(np.maximum(cells.box_lo - hi, lo - cells.box_hi), 0.0)
    near = alive(cells.box_ids) & ~(np.hypot(gap[:, 0], gap[:, 1]) > reach)
    ids = cells.box_ids[near]
    if ids.size == 0:
        return peers
    dist = polygon_distances(cell, cells.cells_of(ids))
    peers.update(ids[dist <= reach].tolist())
    return peers


__all__ = ["PhantomExchange", "moves_mass", "static_prediction"]
