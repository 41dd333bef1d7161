"""Who a robot talks to: its contact set K, its neighbours, and the robots it holds for dead.

The contact set K for the next step is symmetric and built from numbers both sides hold:
the neighbours and their neighbours, plus every robot among the contacts and the contacts'
contacts (each cell message relays the sender's table of states) that is close enough to
matter for a cell, a field of view or phantom mass, with a margin for one step of motion
(:meth:`.context.FilterContext.are_contacts`, on the larger of each robot's last two cell
radii, :func:`recent_radii`; the ownership transfers relay this step's). A cell that a
contact's contact would have cut is counted in ``stats['cell_mismatch']``. At the start the
team's configuration is known to all once (:meth:`Membership.take_configuration`).

Membership and rejoining: at the start of a step the transport may give every robot the
world's team state (ids, positions, alive flags), :meth:`Membership.observe_team`. Robots
the world says are dead are declared dead at once (``stats['world_dead']``, no timeouts
spent on them); robots declared dead that the world says are alive are admitted again
(``stats['revived_peers']``) and become contacts when the configuration of the live robots
at that step makes them contacts (the rule of the initial configuration, symmetric in each
pair). A robot that comes back takes its contacts from the same rule
(:meth:`Membership.rejoin`). A robot whose state arrives from a robot that is not its
contact (the contact sets disagree, e.g. after a one-sided death) leaves that state out and
declares the sender dead (``stats['strangers']``); the sender times it out in turn, and at
the next step both admit each other on the same numbers.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from itertools import chain

import numpy as np

from ...geometry.partition import cell_of, partition
from ...geometry.polygons import cell_radius, isin_sorted
from .cells import LocalPartition, NeighbourCells
from .context import FilterContext
from .messages import CellMsg, Message, StateMsg, TransferMsg, stacked

_log = logging.getLogger("phd_swarm.protocol")


@dataclass(frozen=True)
class KnownStates:
    """States of the contacts and the contacts' contacts at one step, by ascending id.

    Attributes
    ----------
    ids : np.ndarray of int64, shape (N,)
    positions : np.ndarray, shape (N, 2)
        Positions q [m].
    power_weights, cell_radii : np.ndarray, shape (N,)
        rho [m] and cell radii [m] (of the previous step's cells).
    """

    ids: np.ndarray
    positions: np.ndarray
    power_weights: np.ndarray
    cell_radii: np.ndarray


class Membership:
    """The contact set, neighbours, own cell radius and dead set of robot ``robot_id``.

    Parameters
    ----------
    robot_id : int
    ctx : FilterContext
    stats : dict
        The robot's counters (shared).
    on_dead : callable
        Called with the set of robots just declared dead, after they left every set here
        (the robot drops them from the step in progress).

    Attributes
    ----------
    dead : set of int
        Robots declared dead.
    contacts : tuple of int
        Ids exchanging states and cells with this robot at the next step (2-hop), ascending.
    neighbours : tuple of int
        Ids of the robots whose cells touch the own one.
    cell_radius : float
        Largest distance from the robot to a vertex of its last cell [m].
    """

    def __init__(self, robot_id: int, ctx: FilterContext, stats: dict[str, int],
                 on_dead: Callable[[set[int]], None]) -> None:
        self.robot_id = robot_id
        self.ctx = ctx
        self.stats = stats
        self._on_dead = on_dead
        self.dead: set[int] = set()
        self.contacts: tuple[int, ...] = ()
        self.neighbours: tuple[int, ...] = ()
        self.cell_radius = 0.0

    # ------------------------------------------------------------ configuration
    def take_configuration(self, ids: np.ndarray, positions: np.ndarray,
                           rho: np.ndarray | None) -> np.ndarray:
        """Radius, neighbours and contacts in a configuration (``ids`` ascending).

        Returns the own cell (V, 2) of the partition (Voronoi for ``rho`` None).
        """
        part = partition(self.ctx.grid.env, positions, rho)
        me = int(np.searchsorted(ids, self.robot_id))
        rho_all = np.zeros(len(ids)) if rho is None else rho
        radius, neighbours, contacts = self._contacts_in(ids, positions, rho_all, part, me)
        self.cell_radius = radius
        self.neighbours = neighbours
        self.contacts = contacts
        return np.asarray(part.cells[me])

    def _configuration_contacts(self, ids: np.ndarray, positions: np.ndarray) -> tuple:
        """The own contacts in the Voronoi configuration of robots ``ids`` (ascending)."""
        part = partition(self.ctx.grid.env, positions)
        me = int(np.searchsorted(ids, self.robot_id))
        return self._contacts_in(ids, positions, np.zeros(len(ids)), part, me)[2]

    def _contacts_in(self, ids: np.ndarray, positions: np.ndarray, rho: np.ndarray, part,
                     me: int) -> tuple[float, tuple[int, ...], tuple[int, ...]]:
        """Cell radius, neighbours and contacts of row ``me`` of a partition of ``ids``.

        The rule of the initial configuration: the neighbours, their neighbours, and every
        robot within :meth:`FilterContext.contact_mask`'s bound (symmetric in each pair).
        """
        radii = np.array([cell_radius(positions[j], part.cells[j]) for j in range(len(ids))])
        neighbours = tuple(int(ids[j]) for j in part.neighbours[me])
        two_hop = set(neighbours)
        for j in part.neighbours[me]:
            two_hop.update(int(ids[k]) for k in part.neighbours[j])
        near = self.ctx.contact_mask(positions[me], rho[me], radii[me], positions, rho, radii)
        two_hop.update(ids[near].tolist())
        two_hop.discard(self.robot_id)
        return float(radii[me]), neighbours, tuple(sorted(two_hop))

    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray | None) -> np.ndarray:
        """Take the world's team state at ``step`` as a robot (re)joining the team.

        The robots the world says are dead are declared dead (without ``on_dead``: there
        is no step in progress), and the neighbours, cell radius and contacts are those of
        the configuration of the live robots (Voronoi cells). Returns the own cell (V, 2).

        Raises
        ------
        ValueError
            For a team state without this robot alive, or repeated ids.
        """
        ids, positions, alive = team_state(ids, positions, alive)
        live = ids[alive]
        if self.robot_id not in live:
            raise ValueError(f"robot {self.robot_id}: the team state of step {step} does not "
                             f"list it alive ({live.tolist()})")
        self.dead = set(ids[~alive].tolist())
        return self.take_configuration(live, positions[alive], None)

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray, keep_dead: frozenset[int] = frozenset()) -> None:
        """Take the world's membership at the start of step ``step``.

        See :meth:`phd_swarm.core.exchange.voronoi_phd.participant.Participant.observe_team`.
        """
        alive = np.asarray(alive, dtype=bool)
        if not self.dead and alive.all():
            return
        ids, positions, alive = team_state(ids, positions, alive)
        gone = set(ids[~alive].tolist()) - self.dead - {self.robot_id}
        if gone:
            self.stats["world_dead"] += len(gone)
            _log.warning("robot %d: the world says %s are dead at step %d; declared dead",
                         self.robot_id, sorted(gone), step)
            self.declare_dead(gone)
        back = (self.dead & set(ids[alive].tolist())) - keep_dead
        if not back or self.robot_id not in ids[alive]:
            return
        self.dead -= back
        self.stats["revived_peers"] += len(back)
        near = set(self._configuration_contacts(ids[alive], positions[alive])) & back
        self.contacts = tuple(sorted(set(self.contacts) | near))
        _log.info("robot %d: %s alive again at step %d; contacts among them: %s",
                  self.robot_id, sorted(back), step, sorted(near))

    # --------------------------------------------------------------------- dead
    def alive(self, ids: np.ndarray) -> np.ndarray:
        """Which of the robot ids ``ids`` (N,) are not declared dead, bool (N,)."""
        if not self.dead:
            return np.ones(len(ids), dtype=bool)
        return ~np.isin(ids, np.fromiter(self.dead, dtype=np.int64, count=len(self.dead)))

    def declare_dead(self, ids: set[int]) -> None:
        """Drop the robots ``ids`` from the contacts and neighbours, for good."""
        self.dead |= ids
        self.contacts = tuple(c for c in self.contacts if c not in ids)
        self.neighbours = tuple(n for n in self.neighbours if n not in ids)
        self._on_dead(ids)

    def reject_strangers(self, states: dict[int, Message], known: set[int], step: int) -> None:
        """Declare dead the senders of ``states`` that are neither ``known`` nor dead.

        A robot that sends its state counts this one as a contact; if this one does not
        count it (the contact sets disagree, e.g. after one of the two declared the other
        dead on lost messages), its state is left out (deleted from ``states``) and it is
        declared dead. It then times this robot out in turn, and at the next step both
        admit each other again on the same numbers (:meth:`observe_team`). Never happens
        while the sets agree.
        """
        strangers = set(states) - known - self.dead
        if not strangers:
            return
        for src in strangers:
            del states[src]
        self.stats["strangers"] += len(strangers)
        _log.warning("robot %d: %s sent states at step %d but are not its contacts (the "
                     "contact sets disagree); declared dead", self.robot_id,
                     sorted(strangers), step)
        self.declare_dead(strangers)

    # ------------------------------------------------------------ the next step
    def known_states(self, states: dict[int, StateMsg],
                     cells: dict[int, CellMsg]) -> KnownStates:
        """States of the contacts and of their contacts, this step (not self, not dead).

        The contact tables relayed in the cells are read in arrival order, later tables
        overriding earlier ones, and the contacts' own states override them all.
        """
        # A table naming only robots whose own states arrived (or self, or the dead) adds
        # nothing: those entries are overridden or dropped below. Skipping such tables
        # first saves converting every table when everybody is everybody's contact.
        covered = set(states) | self.dead | {self.robot_id}
        tables = [m for m in cells.values() if not covered.issuperset(m.contact_ids)]
        # The tables' rows in arrival order, then the states': a dict built from them keeps
        # the row of each robot's last entry.
        entries = [*chain.from_iterable(m.contact_ids for m in tables), *states]
        row = dict(zip(entries, range(len(entries)), strict=True))
        ids = sorted(set(row) - self.dead - {self.robot_id})
        take = np.array([row[i] for i in ids], dtype=np.int64)
        return KnownStates(
            np.array(ids, dtype=np.int64),
            stacked([m.contact_positions for m in tables]
                    + [m.position for m in states.values()], 2)[take],
            stacked([m.contact_power_weights for m in tables]
                    + [[m.power_weight for m in states.values()]])[take],
            stacked([m.contact_cell_radii for m in tables]
                    + [[m.cell_radius for m in states.values()]])[take])

    def check_cell(self, view: LocalPartition, known: KnownStates, state: StateMsg) -> None:
        """Count a cell that the contacts' contacts would cut (a missed neighbour).

        ``stats['cell_mismatch']``; the cell is kept (the next step's contacts hold the
        missed neighbour).
        """
        extra = ~isin_sorted(known.ids, view.ids)
        if not extra.any() or len(view.cell) == 0:
            return
        q, rho_q = state.position, state.power_weight
        # Robot k's half-plane is (x - q) . u_k <= h_k (partition.cells); it cannot cut a
        # cell whose vertices all lie within h_k of q. Most extra robots are far: skip the
        # recomputation when none of them can cut.
        d2 = ((known.positions[extra] - q) ** 2).sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            h = (d2 + rho_q ** 2 - known.power_weights[extra] ** 2) / (2.0 * np.sqrt(d2))
        reach = cell_radius(q, view.cell)
        if np.all(h > reach * (1.0 + 1e-9) + 1e-9):
            return
        ids = np.concatenate([view.ids, known.ids[extra]])
        order = np.argsort(ids, kind="stable")
        ids = ids[order]
        pos = np.concatenate([view.positions, known.positions[extra]])[order]
        rho = np.concatenate([view.power_weights, known.power_weights[extra]])[order]
        poly, _ = cell_of(self.ctx.grid.env, int(np.searchsorted(ids, self.robot_id)), pos,
                          rho)
        if poly.shape != view.cell.shape or not np.allclose(poly, view.cell, atol=1e-9):
            self.stats["cell_mismatch"] += 1
            _log.warning("robot %d: its cell at step %d misses a neighbour known only to "
                         "its contacts", self.robot_id, state.step)

    def finish_step(self, state: StateMsg, view: LocalPartition, cells: NeighbourCells,
                    known: KnownStates, radii: np.ndarray) -> None:
        """Neighbours, cell radius and contacts for the next step (see the module docstring).

        Parameters
        ----------
        state : StateMsg
            The own state of this step (position, power weight, previous cell radius).
        view : LocalPartition
            The own cell of this step.
        cells : NeighbourCells
            The contacts' cells of this step.
        known : KnownStates
            The contacts and the contacts' contacts.
        radii : np.ndarray, shape (N,)
            :func:`recent_radii` of ``known``.
        """
        dead = self.dead
        self.neighbours = tuple(n for n in view.neighbours if n not in dead)
        two_hop = set(self.neighbours)
        for n in self.neighbours:
            two_hop.update(cells.neighbours_of(n))
        self.cell_radius = cell_radius(state.position, view.cell)
        # The larger of the last two radii: a cell can grow fast (a neighbour leaving, a
        # power weight dropping) and shrink back, see docs/protocol.md.
        near = self.ctx.contact_mask(state.position, state.power_weight,
                                     max(state.cell_radius, self.cell_radius), known.positions,
                                     known.power_weights, radii)
        two_hop.update(known.ids[near].tolist())
        two_hop.discard(self.robot_id)
        self.contacts = tuple(sorted(two_hop - dead))


def recent_radii(known: KnownStates, cells: NeighbourCells,
                 transfers: dict[int, TransferMsg]) -> np.ndarray:
    """Larger of the last two cell radii of each known robot [m], shape (N,).

    The previous step's radius comes with the states; this step's from the cells
    received (the contacts) and the radii the ownership transfers relayed (the contacts'
    contacts). A robot nobody relayed (its relay died during the step) keeps the previous
    step's radius only.
    """
    # Every relay of a robot's radius is the same number (the same function of the same
    # cell), so which one is taken does not matter; the first is.
    sources = [(cells.radius_ids.tolist(), cells.radii)]
    sources += [(msg.radius_ids, msg.cell_radii) for msg in transfers.values()
                if len(msg.radius_ids)]
    out = known.cell_radii.copy()
    if known.ids.size == 0 or not any(len(ids) for ids, _ in sources):
        return out
    # A dict built from the rows in reverse keeps the row of each robot's first entry.
    entries = [*chain.from_iterable(ids for ids, _ in sources)]
    first = dict(zip(reversed(entries), range(len(entries) - 1, -1, -1), strict=True))
    take = np.array([first.get(i, -1) for i in known.ids.tolist()], dtype=np.int64)
    hit = take >= 0
    radii = stacked([r for _, r in sources])
    out[hit] = np.maximum(out[hit], radii[take[hit]])
    return out


def sorted_team(ids: np.ndarray, positions: np.ndarray, power_weights: np.ndarray | None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Ids (N,), positions (N, 2) and power weights (N,) or None, by ascending id.

    Raises
    ------
    ValueError
        For repeated ids.
    """
    ids = np.asarray(ids, dtype=np.int64)
    order = np.argsort(ids, kind="stable")
    ids, positions = ids[order], np.asarray(positions, dtype=float).reshape(-1, 2)[order]
    rho = None if power_weights is None else np.asarray(power_weights, float)[order]
    if len(np.unique(ids)) != len(ids):
        raise ValueError(f"robot ids must be unique, got {ids.tolist()}")
    return ids, positions, rho


def team_state(ids: np.ndarray, positions: np.ndarray, alive: np.ndarray | None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A team state by ascending id: ids (R,), positions (R, 2), alive flags (R,)."""
    n = len(np.asarray(ids).reshape(-1))
    alive = np.ones(n, dtype=bool) if alive is None else np.asarray(alive, dtype=bool)
    positions = np.asarray(positions, dtype=float).reshape(-1, 2)
    if alive.shape != (n,) or positions.shape != (n, 2):
        raise ValueError(f"a team state needs one position and one alive flag per id: "
                         f"{n} ids, positions {positions.shape}, alive {alive.shape}")
    order = np.argsort(np.asarray(ids, dtype=np.int64).reshape(-1), kind="stable")
    ids, positions, _ = sorted_team(ids, positions, None)
    return ids, positions, alive[order]


__all__ = ["KnownStates", "Membership", "recent_radii", "sorted_team", "team_state"]
