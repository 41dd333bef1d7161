"""The measurement update over the robots' bins (Dames 2020 Alg. 2, eq. 4-6).

Each robot sends its measurement set to the robots owning bins in its field of view; then
every measurement set whose field of view meets the own bins is applied, in increasing
robot id: each robot involved sends its partial eta sums over its own bins to the active
robot, which adds the clutter term to the partials (in robot-id order) and returns the
totals; every robot involved then updates its own bins (eq. 4). A field of view inside the
own cell (Remark 1) involves nobody else and sends nothing. The per-bin layer
(:mod:`.layers`) counts the scans that saw each bin.

A field-of-view bin outside every known cell would mean an unknown robot owns it; that is
counted in ``stats['uncovered_fov_bins']``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ...estimators.grid_phd.filter import eta_partial, eta_total, psi_pd, update_weights
from ...geometry.polygons import positions_in_sorted
from ...scan import Scan
from ..base import Envelope
from .cells import LocalPartition, NeighbourCells
from .context import FilterContext
from .errors import ProtocolError
from .layers import BinLayer
from .mailbox import Mailbox
from .messages import EtaPartialMsg, EtaTotalMsg

_log = logging.getLogger("phd_swarm.protocol")


class EtaUpdate:
    """The measurement update of robot ``robot_id`` in one step.

    Parameters
    ----------
    robot_id : int
    ctx : FilterContext
    stats : dict
        The robot's counters (shared).
    step : int
    sensor : np.ndarray, shape (2,)
        The own position [m].
    z : np.ndarray, shape (M, 2)
        The own measurement set [m].

    Attributes
    ----------
    scan_peers : set of int
        Live robots owning bins in the own field of view (the own measurement set goes to
        them; self included when it owns some).
    pending : list of int
        Ascending ids of the active robots whose updates are still to apply.
    partial_sent : set of int
        Active robots the partial eta sums were sent to.
    """

    def __init__(self, robot_id: int, ctx: FilterContext, stats: dict[str, int], step: int,
                 sensor: np.ndarray, z: np.ndarray) -> None:
        self.robot_id = robot_id
        self.ctx = ctx
        self.stats = stats
        self.step = step
        self.sensor = sensor
        self.z = z
        self.scan_peers: set[int] = set()
        self.pending: list[int] = []
        self.partial_sent: set[int] = set()
        #: (active id, positions in the own bins, psi, p_d) of the pending update.
        self._fov_terms: tuple[int, np.ndarray, np.ndarray, np.ndarray] | None = None

    def drop(self, ids: set[int]) -> None:
        """Leave out the robots ``ids`` (declared dead): no scan for them, no update of theirs."""
        self.scan_peers -= ids
        self.pending = [j for j in self.pending if j not in ids]

    def start(self, bins: np.ndarray, view: LocalPartition, cells: NeighbourCells,
              alive: Callable[[np.ndarray], np.ndarray], dead: set[int]) -> list[Envelope]:
        """Alg. 2 lines 4-8: send the measurement set, list the updates to take part in.

        Parameters
        ----------
        bins : np.ndarray of int64, shape (K,)
            The own bins, ascending.
        view : LocalPartition
            This step's partition (who owns the bins of the field of view).
        cells : NeighbourCells
            The contacts' cells (is every field-of-view bin in a known cell).
        alive : callable
            Which robot ids (N,) are not declared dead, bool (N,).
        dead : set of int
            Robots declared dead.
        """
        grid, radius = self.ctx.grid, self.ctx.models.detection.radius
        fov = self.ctx.fov_bins(self.sensor)
        owners = set()
        if fov.size:
            centres = grid.centres_of(fov)
            fov_owners = view.owners(centres)
            owners = set(fov_owners.tolist())
        self.scan_peers = owners - dead
        if fov.size:
            tol = 1e-9 * (grid.env.width + grid.env.height)
            uncovered = cells.uncovered(view.cell, centres, fov_owners, alive, tol)
            if uncovered:
                self.stats["uncovered_fov_bins"] += uncovered
                _log.warning("robot %d: %d field-of-view bins lie in no known cell at step %d",
                             self.robot_id, uncovered, self.step)
        # One measurement set for every peer: a broadcast is one message object.
        scan = Scan(self.robot_id, self.step, self.sensor, self.z)
        out = [Envelope(self.robot_id, int(dst), scan)
               for dst in sorted(self.scan_peers - {self.robot_id})]
        meet = grid.disks_meet(bins, view.positions, radius)
        pending = set(view.ids[alive(view.ids) & meet].tolist())
        # The active robot coordinates its own update even without bins in its field of
        # view (a power cell need not contain its generator).
        if len(self.z) and self.scan_peers - {self.robot_id}:
            pending.add(self.robot_id)
        self.pending = sorted(pending)
        return out

    def missing(self, mail: Mailbox) -> set[int]:
        """Robots the pending update still needs to hear from (empty if none pending)."""
        if not self.pending:
            return set()
        step, me = self.step, self.robot_id
        j = self.pending[0]
        if j != me:
            if j not in mail.box((step, "scan")):
                return {j}
            z = mail.box((step, "scan"))[j].z
            if len(z) and j not in mail.box((step, "total", j)):
                return {j}
            return set()
        if len(self.z) == 0:
            return set()
        return (self.scan_peers - {me}) - set(mail.box((step, "partial", me)))

    def advance(self, bins: np.ndarray, weights: np.ndarray, layer: BinLayer,
                mail: Mailbox) -> list[Envelope]:
        """Alg. 2 lines 9-26 for the lowest pending active ids, as far as messages allow.

        Updates ``weights`` (K,) of the own ``bins`` in place (eq. 4) and the ``layer``;
        the update is complete when :attr:`pending` is empty.

        Raises
        ------
        ProtocolError
            For eta totals that do not match the active robot's measurement set.
        """
        step, me = self.step, self.robot_id
        models = self.ctx.models
        out: list[Envelope] = []
        while self.pending:
            j = self.pending[0]
            if j == me:
                sensor, z = self.sensor, self.z
            else:
                scan = mail.box((step, "scan")).get(j)
                if scan is None:
                    return out
                sensor, z = np.asarray(scan.sensor), np.asarray(scan.z).reshape(-1, 2)
            pos, psi_zx, pd = self._terms(j, bins, sensor, z)
            if len(z) == 0:
                eta = np.empty(0)
            elif j == me:
                partials = mail.box((step, "partial", j))
                if (self.scan_peers - {j}) - set(partials):
                    return out
                mine = eta_partial(psi_zx, weights[pos])
                # The sum over the robots in robot-id order, whatever the arrival order:
                # every run gives the same floats.
                ordered = [mine if k == j else np.asarray(partials[k].values)
                           for k in sorted(set(partials) | {j})]
                eta = eta_total(ordered, models.clutter.intensity(z))
                out.extend(Envelope(me, int(k), EtaTotalMsg(j, step, eta))
                           for k in sorted(self.scan_peers - {j}))
            else:
                if j not in self.partial_sent:
                    self.partial_sent.add(j)
                    out.append(Envelope(me, int(j), EtaPartialMsg(
                        me, j, step, eta_partial(psi_zx, weights[pos]))))
                total = mail.box((step, "total", j)).get(j)
                if total is None:
                    return out
                eta = np.asarray(total.values)
                if eta.shape != (len(z),):
                    raise ProtocolError(f"robot {me}: eta totals of robot {j} have "
                                        f"{eta.shape} values for {len(z)} measurements")
            weights[pos] = update_weights(weights[pos], pd, psi_zx, eta)
            layer.observe(pos, len(z) > 0)
            self.pending.pop(0)
        layer.apply()
        return out

    def _terms(self, j: int, bins: np.ndarray, sensor: np.ndarray,
               z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Own bins in robot j's field of view, psi (eq. 6) and p_d there, for this step.

        Kept for the pending id j, since :meth:`advance` runs again on every message while
        j's update waits; none of them depends on the weights.

        Returns
        -------
        pos : np.ndarray of int64, shape (K_in,)
            Positions in ``bins`` of the bins in the field of view.
        psi_zx : np.ndarray, shape (M, K_in)
            psi of j's measurements at those bins [1/m^2].
        pd : np.ndarray, shape (K_in,)
            p_d of those bins for j's sensor.
        """
        if self._fov_terms is None or self._fov_terms[0] != j:
            grid, models = self.ctx.grid, self.ctx.models
            # fov_positions on the ascending own bins, without checking their order again.
            pos = positions_in_sorted(bins, self.ctx.fov_bins(sensor))
            psi_zx, pd = psi_pd(models, grid.centres_of(bins[pos]), z, sensor)
            self._fov_terms = (j, pos, psi_zx, pd)
        return self._fov_terms[1:]


__all__ = ["EtaUpdate"]
