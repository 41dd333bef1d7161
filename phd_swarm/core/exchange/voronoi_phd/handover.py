"""Ownership hand-over of bins between robots (Dames 2020 Alg. 1 lines 4-7).

The bins of the previous cell that now belong to another robot go to that robot (a
transfer, possibly empty, to every contact: Alg. 1 sends to the neighbours only, but a
moving cell can pass bins to a neighbour's neighbour); bins arrive from the contacts
likewise. The per-bin layer (:mod:`.layers`) travels with the bins.

Bins that a robot owns but nobody handed to it (those of a dead robot) are re-initialised
to the prior mass ``models.initial_density * bin_area`` (and an empty layer) and counted in
``stats['orphan_bins']``. Bins of the previous cell that the partition gives to a robot that
died during the step (its state arrived, its cell did not) are dropped and counted in
``stats['lost_to_dead']``.

Disagreeing partitions: while the robots' dead sets differ, or when a true neighbour was
missing from a contact set (no local rule can rule that out: a cell can grow by tens of
metres in one step), two robots can disagree on who owns a bin. Bins handed to a robot that
does not own them are then dropped by the receiver (``stats['misrouted_bins']``), a bin that
two robots held arrives twice and its first copy is kept (``stats['duplicate_bins']``), and
the step goes on; the next step's contacts include the missed neighbour.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ...geometry.grid import Grid
from ...geometry.ownership import bins_owned_in_box
from ...geometry.polygons import isin_sorted
from ..base import Envelope
from .cells import LocalPartition
from .context import FilterContext
from .errors import ProtocolError
from .layers import BinLayer, Parcel
from .messages import TransferKind, TransferMsg

_log = logging.getLogger("phd_swarm.protocol")


class HandOver:
    """The ownership hand-over of robot ``robot_id`` in one step.

    Parameters
    ----------
    robot_id : int
    ctx : FilterContext
    stats : dict
        The robot's counters (shared).
    view : LocalPartition
        This step's partition of the robot and its contacts.
    peers : set of int
        The live contacts: every one gets a transfer and sends one.

    Attributes
    ----------
    peers : set of int
        Robots whose transfers are awaited (dead ones are dropped, :meth:`drop`).
    owned : np.ndarray of int64, shape (K,)
        Ascending flat indices of the bins the robot owns after the hand-over.
    """

    def __init__(self, robot_id: int, ctx: FilterContext, stats: dict[str, int],
                 view: LocalPartition, peers: set[int]) -> None:
        self.robot_id = robot_id
        self.ctx = ctx
        self.stats = stats
        self.view = view
        # Alg. 1 sends to the neighbours N(r) only, which assumes that the previous cell
        # overlaps only current neighbours; with moving cells a bin can go to a robot that
        # was and is only a neighbour's neighbour, so transfers go to every contact.
        self.peers = peers
        self.owned = owned_bins(ctx.grid, robot_id, view.cell, view.ids, view.positions,
                                view.power_weights)
        #: The own bins that stay: (bins, weights, layer parcel), until :meth:`take`.
        self._retained: tuple[np.ndarray, np.ndarray, Parcel] | None = None

    def drop(self, ids: set[int]) -> None:
        """Stop waiting for the robots ``ids`` (declared dead)."""
        self.peers -= ids

    def give(self, step: int, bins: np.ndarray, weights: np.ndarray, layer: BinLayer,
             alive: Callable[[np.ndarray], np.ndarray],
             relay: tuple[tuple[int, ...], np.ndarray]) -> list[Envelope]:
        """Alg. 1 lines 4-6: a transfer to every peer with the own bins it now owns.

        Parameters
        ----------
        step : int
        bins, weights : np.ndarray, shape (K_prev,)
            The bins of the previous cell (ascending) and their masses.
        layer : BinLayer
            Their per-bin layer.
        alive : callable
            Which robot ids (N,) are not declared dead, bool (N,).
        relay : (tuple of int, np.ndarray)
            Ids and cell radii of this step's cells received, relayed to every peer.

        Raises
        ------
        ProtocolError
            When a bin goes to a robot that is not a peer (the contact set missed it).
        """
        leaving = ~isin_sorted(bins, self.owned)
        out_bins: dict[int, np.ndarray] = {}
        if leaving.any():
            idx = np.flatnonzero(leaving)
            owners = self.view.owners(self.ctx.grid.centres_of(bins[idx]))
            lost = ~alive(owners)
            if lost.any():
                # The owner died after its state of this step arrived (it is in the
                # partition) and before the hand-over: nobody can take these bins. Their
                # next owner re-initialises them as orphans (see orphan_bins).
                self.stats["lost_to_dead"] += int(lost.sum())
                _log.warning("robot %d: %d bins of its previous cell belong to a robot that "
                             "died during step %d; dropped", self.robot_id, int(lost.sum()),
                             step)
                idx, owners = idx[~lost], owners[~lost]
            for dst in sorted(set(owners.tolist())):
                if dst == self.robot_id:
                    raise ProtocolError(f"robot {self.robot_id}: a bin it does not own maps "
                                        f"back to it at step {step}")
                if dst not in self.peers:
                    raise ProtocolError(
                        f"robot {self.robot_id}: bins of its previous cell belong to robot "
                        f"{dst}, which is not among its contacts (step {step}): robots "
                        f"moved too far in one step for the 2-hop contact set")
                out_bins[dst] = idx[owners == dst]

        def payload(sel: np.ndarray) -> tuple:
            return (bins[sel], weights[sel], *layer.parcel(sel))

        # Most transfers are empty: they share one set of empty arrays.
        empty = payload(np.empty(0, dtype=np.int64))
        out = []
        for dst in sorted(self.peers):
            sel = out_bins.get(dst)
            out.append(Envelope(self.robot_id, int(dst), TransferMsg(
                self.robot_id, dst, step, TransferKind.OWNERSHIP,
                *(empty if sel is None else payload(sel)), *relay)))
        keep = ~leaving
        self._retained = (bins[keep], weights[keep], layer.parcel(keep))
        return out

    def take(self, step: int, transfers: dict[int, TransferMsg],
             layer: BinLayer) -> tuple[np.ndarray, np.ndarray]:
        """Alg. 1 line 7: the own bins after the hand-over, from the retained and received.

        Parameters
        ----------
        step : int
        transfers : dict of int to TransferMsg
            The ownership transfers received, by sender.
        layer : BinLayer
            Rebuilt over the owned bins.

        Returns
        -------
        bins : np.ndarray of int64, shape (K,)
            :attr:`owned`.
        weights : np.ndarray, shape (K,)
            Their masses; the prior mass for orphans.
        """
        owned = self.owned
        w = np.full(owned.size, np.nan)
        assert self._retained is not None
        bins, weights, parcel = self._retained
        placed = []
        if bins.size:
            # The own bins that stayed are owned (give kept exactly those) and come first.
            pos = np.searchsorted(owned, bins)
            w[pos] = weights
            placed.append((pos, parcel))
        # Most transfers are empty: only the others are converted.
        parts = [(np.asarray(msg.bins, dtype=np.int64), np.asarray(msg.weights),
                  (None if msg.alpha is None else np.asarray(msg.alpha),
                   None if msg.count is None else np.asarray(msg.count)))
                 for msg in (transfers[src] for src in sorted(transfers)) if len(msg.bins)]
        for bins, weights, (a, n) in parts:
            pos = np.searchsorted(owned, bins)
            ok = (pos < owned.size) & (owned[np.minimum(pos, owned.size - 1)] == bins)
            if not ok.all():
                # The sender's partition disagrees with the own one: after a death the
                # robots' dead sets can differ for a step, and a neighbour missing from a
                # contact set (docs/protocol.md) changes a partition. Bins sent on another
                # robot's view are dropped (their owner re-initialises them as orphans).
                misrouted(self.stats, self.robot_id, int((~ok).sum()), "bins", step)
            seen = np.zeros(bins.size, dtype=bool)
            seen[ok] = ~np.isnan(w[pos[ok]])
            if seen.any():
                # Two robots held the bin (both owned it in disagreeing partitions of the
                # previous step): the own copy wins, then the lowest sender id.
                self.stats["duplicate_bins"] += int(seen.sum())
                _log.warning("robot %d: %d bins handed to it at step %d were already held; "
                             "the first copy is kept", self.robot_id, int(seen.sum()), step)
            keep = ok & ~seen
            if not keep.all():
                pos, weights = pos[keep], np.asarray(weights)[keep]
                a = None if a is None else np.asarray(a)[keep]
                n = None if n is None else np.asarray(n)[keep]
            w[pos] = weights
            placed.append((pos, (a, n)))
        orphans = np.isnan(w)
        if orphans.any():
            self.stats["orphan_bins"] += int(orphans.sum())
            _log.warning("robot %d: %d bins it now owns were handed over by nobody (a dead "
                         "owner or a missed neighbour) at step %d; re-initialised to the "
                         "prior mass %.3g",
                         self.robot_id, int(orphans.sum()), step, self.ctx.prior_mass)
            w[orphans] = self.ctx.prior_mass
        layer.take_over(owned.size, placed)
        self._retained = None
        return owned, w


def owned_bins(grid: Grid, robot_id: int, cell: np.ndarray, ids: np.ndarray,
               positions: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Ascending flat indices of the bins robot ``robot_id`` owns, int64 (K,).

    Parameters
    ----------
    grid : Grid
    robot_id : int
    cell : np.ndarray, shape (V, 2)
        Its cell among the generators; only the bins of the cell's bounding box, grown by
        one bin, are tested.
    ids : np.ndarray of int64, shape (N,)
        Ids of the generators, ascending (``robot_id`` among them).
    positions : np.ndarray, shape (N, 2)
        Generators q [m].
    rho : np.ndarray, shape (N,)
        Power weights [m].
    """
    if len(cell) == 0:
        return np.empty(0, dtype=np.int64)
    lo = cell.min(axis=0) - grid.resolution
    hi = cell.max(axis=0) + grid.resolution
    env, res = grid.env, grid.resolution
    ix0 = max(int(np.floor((lo[0] - env.xmin) / res)), 0)
    ix1 = min(int(np.ceil((hi[0] - env.xmin) / res)), grid.nx - 1)
    iy0 = max(int(np.floor((lo[1] - env.ymin) / res)), 0)
    iy1 = min(int(np.ceil((hi[1] - env.ymin) / res)), grid.ny - 1)
    me = int(np.searchsorted(ids, robot_id))
    return bins_owned_in_box(grid, me, positions, rho, (iy0, iy1, ix0, ix1))


def misrouted(stats: dict[str, int], robot_id: int, n: int, what: str, step: int) -> None:
    """Count and log ``n`` bins handed to robot ``robot_id`` that it does not own (dropped)."""
    stats["misrouted_bins"] += n
    _log.warning("robot %d: dropped %d %s handed to it that it does not own at step %d "
                 "(the robots' partitions disagree: a death or a missed neighbour)",
                 robot_id, n, what, step)


__all__ = ["HandOver", "misrouted", "owned_bins"]
