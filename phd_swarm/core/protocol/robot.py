"""One robot of the distributed grid PHD filter (Dames 2020 Sec. III) as a state machine.

The robot never calls a transport: :meth:`RobotFilter.start_step`, :meth:`receive`,
:meth:`advance` and :meth:`tick` take messages in and return :class:`Envelope` s addressed to
robots. One step ``t`` runs these phases:

1. ``STATES`` (Alg. 1 line 1): send the state (q, rho) to the contact set K, wait for
   theirs. K is the 2-hop neighbourhood of the previous partition (neighbours and their
   neighbours, learnt from the cells they shared), so a robot exchanges O(neighbours)
   messages, independent of the team size.
2. ``CELLS`` (Alg. 1 lines 2-3): compute the own power/Voronoi cell from the contacts'
   states, send it (with the neighbour ids) to K, wait for theirs.
3. ``TRANSFERS`` (Alg. 1 lines 4-7): hand the bins of the previous cell that now belong to
   another robot to that robot (a transfer, possibly empty, to every contact: Alg. 1 sends
   to the neighbours only, but a moving cell can pass bins to a neighbour's neighbour);
   bins arrive from the contacts likewise.
4. ``PHANTOMS`` (Sec. III-B): predict (eq. 3) over the own bins expanded by the support of
   the motion kernel; the phantom mass that lands on other robots' bins is sent to them (a
   transfer, possibly empty, to every contact whose cell lies within the kernel's reach).
   Skipped for static targets (identity kernel).
5. ``UPDATE`` (Alg. 2): send the own measurement set to the robots owning bins in its field
   of view; then apply every measurement set whose field of view meets the own bins, in
   increasing robot id: send the partial eta sums over the own bins to the active robot,
   which adds the clutter term to the partials (in robot-id order) and returns the totals;
   every robot involved then updates its own bins (eq. 4). A field of view inside the own
   cell (Remark 1) involves nobody else and sends nothing.

Ownership of a bin is the canonical rule of :func:`phd_swarm.core.partition.assign_bins`
(lowest power distance, lowest id on ties) over the robot and its contacts, so all robots
agree on it without a global view. Every sum that combines several robots' numbers is taken
in robot-id order, so the result does not depend on the order messages arrive in.

The contact set K for the next step is symmetric and built from numbers both sides hold:
the neighbours and their neighbours, plus every robot among the contacts and the contacts'
contacts (each cell message relays the sender's table of states) that is close enough to
matter for a cell, a field of view or phantom mass, with a margin for one step of motion
(:meth:`FilterContext.are_contacts`, on the larger of each robot's last two cell radii;
the ownership transfers relay this step's). A cell that a contact's contact would have cut is
counted in ``stats['cell_mismatch']``. At the
start the team's configuration is known to all once (:meth:`RobotFilter.initialise`).
A field-of-view bin outside every known cell would mean an unknown robot owns it; that is
counted in ``stats['uncovered_fov_bins']`` (zero in every test run).

Failures: every wait counts :meth:`tick` s (rounds without progress). A robot that waits
re-sends its state of the step on every tick, a keep-alive, to the peers it waits for
(twice from the second tick of a wait on) and to the peers whose keep-alives it received
lately (they may be waiting for it): a peer that is itself blocked (on a robot that died)
is slow, not dead. The awaited robots from which nothing at all arrived in the last
``timeout_ticks`` rounds of the wait are declared dead (so after ``timeout_ticks + 1``
rounds at the earliest), dropped from every set, and the step goes on with what arrived;
after ``3 x timeout_ticks`` rounds without progress every awaited robot is (a wait that
cannot end). Bins that a robot owns but nobody handed to it (those
of a dead robot) are re-initialised to the prior mass ``models.initial_density *
bin_area`` (and alpha = n = 0) and counted in ``stats['orphan_bins']``. Bins of the previous
cell that the partition gives to a robot that died during the step (its state arrived, its
cell did not) are dropped and counted in ``stats['lost_to_dead']``.

Lost messages: a keep-alive is also a request. A robot keeps the envelopes it sent in the
current and the previous step (not its states). A keep-alive, a state of a step the
receiver has sent messages in that repeats one it holds or comes after it finished that
step, is answered (by the next :meth:`advance`, ``stats['resent']``) with what the
receiver sent that peer in that step and the peer may still miss: a robot sends the
messages of a phase only once it holds the previous phase's from all its contacts, so the
peer's own messages show which phases it is past (:func:`_may_miss`). With nothing to
re-send, a receiver that is itself still in that step answers with its own state, at most
once per round and peer (the peer may lack it, and hears that it is alive). States are
never re-sent as answers otherwise: an answered state could be answered again. So
transports call :meth:`advance` after every :meth:`receive`, also when the step is done. A
message that arrives again is not applied again: the first copy of each (step, kind,
sender) is kept, and the repeat is counted in ``stats['duplicates']``. Any message from a
peer counts as hearing from it. A run without losses has no rounds without progress, hence
no keep-alives and no re-sends: it sends exactly the messages it did before. With every
message arriving in the end and no peer timed out, the result is bit-identical to the
loss-free run (all sums in robot-id order). :mod:`.faults` injects the losses.

Membership and rejoining: at the start of a step the transport may give every robot the
world's team state (ids, positions, alive flags) with :meth:`RobotFilter.observe_team`.
Robots the world says are dead are declared dead at once (``stats['world_dead']``, no
timeouts spent on them); robots declared dead that the world says are alive are admitted
again (``stats['revived_peers']``) and become contacts when the configuration of the live
robots at that step makes them contacts (the rule of :meth:`RobotFilter.initialise`,
symmetric in each pair). A robot that comes back (a restarted process, or one that was
only slow) calls :meth:`RobotFilter.rejoin` with the same team state: it drops its bins and
whatever step it was in, takes its contacts from the same rule, and owns nothing, so the
step's hand-over gives it its bins from their previous owners (``stats['rejoins']``). A
live robot declared dead on lost messages is admitted again the same way at the next step.
A robot whose state arrives from a robot that is not its contact (the contact sets
disagree, e.g. after a one-sided death) leaves that state out and declares the sender dead
(``stats['strangers']``); the sender times it out in turn, and at the next step both admit
each other on the same numbers.

Disagreeing partitions: while the robots' dead sets differ, or when a true neighbour was
missing from a contact set (no local rule can rule that out: a cell can grow by tens of
metres in one step), two robots can disagree on who owns a bin. Bins or phantom mass
handed to a robot that does not own them are then dropped by the receiver
(``stats['misrouted_bins']``), phantom mass for a contact whose cell is out of reach is
dropped by the sender (``stats['unroutable_bins']``), a bin that two robots held arrives
twice and its first copy is kept (``stats['duplicate_bins']``), and the step goes on; the next
step's contacts include the missed neighbour. Every counter stays zero in the runs the
tests compare with the centralised filter.
"""

from __future__ import annotations

import enum
import logging
from collections import defaultdict
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..cumulative import cumulative_update_counts
from ..grid import Grid
from ..models import PhdModels
from ..partition import (
    assign_bins,
    bins_owned_in_box,
    cell_of,
    partition,
    points_in_any_polygon,
    points_in_polygon,
    points_in_polygons,
    stack_polygons,
)
from ..phd_grid import eta_partial, eta_total, psi_pd, spread, update_weights
from .messages import (
    CellMsg,
    Envelope,
    EtaPartialMsg,
    EtaTotalMsg,
    Message,
    ScanMsg,
    StateMsg,
    TransferKind,
    TransferMsg,
)

_log = logging.getLogger("phd_swarm.protocol")

#: Field-of-view disks kept by :meth:`FilterContext.fov_bins`: one per robot of a step,
#: with room for the largest teams (at 0.1 m bins a disk of 5 m is ~60 kB).
_FOV_CACHE_SIZE = 256


class ProtocolError(RuntimeError):
    """An invariant of the distributed filter was violated (a bug or inconsistent views)."""


class Phase(enum.Enum):
    """Where a robot is within a step."""

    IDLE = "idle"
    STATES = "states"
    CELLS = "cells"
    TRANSFERS = "transfers"
    PHANTOMS = "phantoms"
    UPDATE = "update"
    DONE = "done"


@dataclass(frozen=True, eq=False)
class FilterContext:
    """What every robot of a team shares: the grid, the models and derived per-bin arrays.

    Robots in one process (the in-memory engine) may share one context, and then also its
    cache of field-of-view disks (:meth:`fov_bins`); a robot with a context of its own
    computes the same values.

    Attributes
    ----------
    grid : Grid
        The shared grid of bins.
    models : PhdModels
        The filter's models.
    cumulative : bool
        Carry Chen's cumulative state (alpha, n) with the bins.
    timeout_ticks : int
        Rounds without progress before a silent robot is declared dead.
    max_step : float
        Largest distance a robot moves in one step [m] (max speed x dt); sets the margin
        of the contact set.
    """

    grid: Grid
    models: PhdModels
    cumulative: bool = False
    timeout_ticks: int = 3
    max_step: float = 0.0

    @cached_property
    def kernel(self) -> np.ndarray:
        """Motion kernel on the grid."""
        return self.models.motion.kernel(self.grid.resolution)

    @cached_property
    def survival(self) -> np.ndarray:
        """p_s per bin, shape (size,)."""
        return self.models.survival.probability(self.grid)

    @cached_property
    def birth(self) -> np.ndarray:
        """Birth mass per bin, shape (size,)."""
        return self.models.birth.mass(self.grid)

    @property
    def prior_mass(self) -> float:
        """Initial mass of one bin."""
        return self.models.initial_density * self.grid.bin_area

    @cached_property
    def reach(self) -> float:
        """How far phantom mass can land from the bins it left [m]."""
        half = (self.kernel.shape[0] // 2) * self.grid.resolution
        return half * np.sqrt(2.0) + self.grid.resolution

    @property
    def contact_margin(self) -> float:
        """Slack for one step of motion of both robots and their cells [m]."""
        return 2.0 * self.max_step + self.grid.resolution * np.sqrt(2.0)

    def are_contacts(self, q_a: np.ndarray, rho_a: float, radius_a: float,
                     q_b: np.ndarray, rho_b: float, radius_b: float) -> bool:
        """Whether robots a and b must exchange messages next step (symmetric in a and b).

        Evaluated by both robots on the same numbers (positions, power weights and cell
        radii: the larger of the previous step's, sent in the states, and this step's, from
        the cells and relayed by the ownership transfers, see
        :meth:`RobotFilter._recent_radii`), so both agree. With
        R_a, R_b the cell radii (largest generator-to-vertex distances), the pair is kept
        when ``|q_a - q_b| <= 2 max(R_a, R_b) + rho_a + rho_b + max(fov, reach) + margin``:
        this covers power/Voronoi neighbours (a neighbour of a lies within 2 R_a + rho of
        q_a), a field of view meeting the other's cell (within R + fov) and phantom mass or
        bin hand-overs between cells within the kernel's reach, with the margin for the
        next move of both robots and the change of the cell radii.
        """
        q_b = np.asarray(q_b, dtype=float).reshape(1, 2)
        return bool(self.contact_mask(q_a, rho_a, radius_a, q_b, np.array([rho_b], float),
                                      np.array([radius_b], float))[0])

    def contact_mask(self, q_a: np.ndarray, rho_a: float, radius_a: float,
                     q_b: np.ndarray, rho_b: np.ndarray, radius_b: np.ndarray) -> np.ndarray:
        """:meth:`are_contacts` of robot a with each of N robots b at once.

        The same float expression as the pairwise rule, element by element (hypot, then
        the bound summed left to right), so both sides of a pair still agree bit for bit.

        Parameters
        ----------
        q_a : np.ndarray, shape (2,)
            Position of robot a [m].
        rho_a, radius_a : float
            Its power weight and cell radius [m].
        q_b : np.ndarray, shape (N, 2)
            Positions of the robots b [m].
        rho_b, radius_b : np.ndarray, shape (N,)
            Their power weights and cell radii [m].

        Returns
        -------
        np.ndarray of bool, shape (N,)
        """
        q_a = np.asarray(q_a, dtype=float)
        q_b = np.asarray(q_b, dtype=float).reshape(-1, 2)
        d = np.hypot(q_a[0] - q_b[:, 0], q_a[1] - q_b[:, 1])
        bound = (2.0 * np.maximum(radius_a, np.asarray(radius_b, dtype=float)) + rho_a
                 + np.asarray(rho_b, dtype=float)
                 + max(self.models.detection.radius, self.reach) + 2.0 * self.contact_margin)
        return d <= bound

    def fov_bins(self, sensor: np.ndarray) -> np.ndarray:
        """``grid.disk_bins(sensor, detection radius)``, cached by the exact position.

        In one step every robot whose bins meet a field of view needs that disk; robots
        sharing this context (one process) compute each disk once. The key is the position's
        bytes, so a hit returns exactly what :meth:`Grid.disk_bins` would; the arrays are
        read-only. The cache keeps the :data:`_FOV_CACHE_SIZE` most recent disks.
        """
        sensor = np.asarray(sensor, dtype=float).reshape(2)
        key = sensor.tobytes()
        cache = self._fov_cache
        disk = cache.get(key)
        if disk is None:
            disk = self.grid.disk_bins(sensor, self.models.detection.radius)
            disk.setflags(write=False)
            if len(cache) >= _FOV_CACHE_SIZE:
                cache.pop(next(iter(cache), None), None)
            cache[key] = disk
        return disk

    @cached_property
    def _fov_cache(self) -> dict[bytes, np.ndarray]:
        return {}


@dataclass(frozen=True)
class _Known:
    """States of the contacts and the contacts' contacts at one step, by ascending id.

    Attributes
    ----------
    ids : np.ndarray of int64, shape (N,)
    positions : np.ndarray, shape (N, 2)
        Positions q [m].
    power_weights, cell_radii : np.ndarray, shape (N,)
        rho [m] and cell radii [m].
    """

    ids: np.ndarray
    positions: np.ndarray
    power_weights: np.ndarray
    cell_radii: np.ndarray


@dataclass
class _StepData:
    """Per-step scratch of a robot."""

    step: int
    position: np.ndarray
    power_weight: float
    z: np.ndarray
    radius: float = 0.0
    state: StateMsg | None = None
    ids: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    positions: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    weights: np.ndarray = field(default_factory=lambda: np.empty(0))
    cell: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    neighbours: tuple[int, ...] = ()
    cells: dict[int, tuple[np.ndarray, tuple[int, ...]]] = field(default_factory=dict)
    cell_ids: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    cell_lo: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    cell_hi: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    known: _Known | None = None
    fresh_ids: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    fresh_radii: np.ndarray = field(default_factory=lambda: np.empty(0))
    owned: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    transfer_peers: set[int] = field(default_factory=set)
    phantom_peers: set[int] = field(default_factory=set)
    own_spread: np.ndarray | None = None
    scan_peers: set[int] = field(default_factory=set)
    pending: list[int] = field(default_factory=list)
    partial_sent: set[int] = field(default_factory=set)
    fov_terms: tuple[int, np.ndarray, np.ndarray, np.ndarray] | None = None
    observed: np.ndarray | None = None
    rewarded: np.ndarray | None = None


class RobotFilter:
    """The distributed-filter state of robot ``robot_id`` and its protocol.

    Attributes (read them between steps)
    ------------------------------------
    bins : np.ndarray of int64, shape (K,)
        Ascending flat indices of the bins this robot owns.
    weights : np.ndarray, shape (K,)
        Their PHD masses.
    alpha, count : np.ndarray, shape (K,) or None
        Chen's cumulative state of those bins (count = n = 1/beta), when enabled.
    cell : np.ndarray, shape (V, 2)
        Current cell polygon.
    neighbours : tuple of int
        Ids of the robots whose cells touch this one.
    contacts : tuple of int
        Ids this robot exchanges states and cells with at the next step (2-hop).
    dead : set of int
        Robots declared dead.
    stats : dict
        Counters: ``orphan_bins``, ``timeouts``, ``declared_dead`` (peers timed out),
        ``dropped`` (stale or unknown messages), ``duplicates`` (messages that arrived
        again), ``resent`` (answers to keep-alives), ``world_dead``, ``revived_peers``,
        ``rejoins``, ``strangers`` and those of the module docstring. A counter that
        stayed 0 is absent.
    """

    def __init__(self, robot_id: int, ctx: FilterContext) -> None:
        self.robot_id = int(robot_id)
        self.ctx = ctx
        self.bins = np.empty(0, dtype=np.int64)
        self.weights = np.empty(0)
        self.alpha: np.ndarray | None = None
        self.count: np.ndarray | None = None
        self.cell = np.empty((0, 2))
        self.cell_radius = 0.0
        self.neighbours: tuple[int, ...] = ()
        self.contacts: tuple[int, ...] = ()
        self.dead: set[int] = set()
        #: Rounds ticked so far, and the round in which each peer was last heard from.
        self._round = 0
        self._heard: dict[int, int] = {}
        self.phase = Phase.IDLE
        self.stats: dict[str, int] = defaultdict(int)
        self._last_step = -1
        self._cur: _StepData | None = None
        self._mail: dict[tuple, dict[int, Message]] = defaultdict(dict)
        self._idle_ticks = 0
        #: What this robot sent in the current and the previous step, by step (re-sent to a
        #: peer on its keep-alive), and the re-sends :meth:`advance` returns next.
        self._sent: dict[int, list[Envelope]] = {}
        self._log: list[Envelope] = []
        self._outbox: list[Envelope] = []
        #: The round in which this robot last sent each peer its state again, and in which
        #: each peer last sent it a keep-alive of the current step.
        self._spoke: dict[int, int] = {}
        self._waiters: dict[int, int] = {}

    # ------------------------------------------------------------------ set-up
    def initialise(self, ids: np.ndarray, positions: np.ndarray,
                   power_weights: np.ndarray | None = None) -> None:
        """Start from the team's known initial configuration (every robot knows it once).

        Computes the initial partition, takes the own bins with the prior mass, and sets
        the neighbours and the 2-hop contacts for step 0. After this, only neighbour
        traffic is used.
        """
        ids, positions, rho = _sorted_team(ids, positions, power_weights)
        if self.robot_id not in ids:
            raise ValueError(f"robot {self.robot_id} is not among the team ids {ids.tolist()}")
        self._take_configuration(ids, positions, rho)
        self.bins = self._owned_bins(self.cell, ids, positions,
                                     np.zeros(len(ids)) if rho is None else rho)
        self.weights = np.full(self.bins.size, self.ctx.prior_mass)
        if self.ctx.cumulative:
            self.alpha = np.zeros(self.bins.size)
            self.count = np.zeros(self.bins.size)

    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray | None = None) -> None:
        """(Re)join the team at step ``step``, from the world's team state at that step.

        For a robot that was declared dead (a restarted process with a fresh filter, or a
        robot that was only slow): every bin, message and step in progress is dropped, the
        robots the world says are dead are declared dead, and the neighbours, cell radius
        and contacts are those of the configuration of the live robots at ``step``
        (:meth:`initialise`'s rule, Voronoi cells). The robot owns no bins: in step ``step``
        the partition's hand-over gives it its bins from their previous owners, and those
        nobody hands it become orphans initialised to the prior, as after a death. The other
        robots admit it with :meth:`observe_team` on the same numbers, so both sides of
        every pair agree on being contacts. Call it before :meth:`start_step` of ``step``;
        counted in ``stats['rejoins']``.

        Parameters
        ----------
        step : int
            The step the robot takes part in next; later than any step it started.
        ids : np.ndarray of int, shape (R,)
            The team's robot ids (the world's ``TeamState``).
        positions : np.ndarray, shape (R, 2)
            Their positions at ``step`` [m] (those of dead robots are not used).
        alive : np.ndarray of bool, shape (R,), optional
            Which robots the world says are alive (default: all); this one must be.

        Raises
        ------
        ValueError
            For a step not after the last one started, a team state without this robot
            alive, or repeated ids.
        """
        if step <= self._last_step:
            raise ValueError(f"robot {self.robot_id}: cannot rejoin at step {step}, it "
                             f"already started step {self._last_step}")
        ids, positions, alive = _team_state(ids, positions, alive)
        live = ids[alive]
        if self.robot_id not in live:
            raise ValueError(f"robot {self.robot_id}: the team state of step {step} does not "
                             f"list it alive ({live.tolist()})")
        self.dead = set(ids[~alive].tolist())
        self._take_configuration(live, positions[alive], None)
        self.bins = np.empty(0, dtype=np.int64)
        self.weights = np.empty(0)
        self.alpha = np.empty(0) if self.ctx.cumulative else None
        self.count = np.empty(0) if self.ctx.cumulative else None
        self.phase = Phase.IDLE
        self._last_step = step - 1
        self._cur = None
        self._retained = None
        self._mail.clear()
        self._heard.clear()
        self._idle_ticks = 0
        self._sent, self._log, self._outbox, self._spoke, self._waiters = {}, [], [], {}, {}
        self.stats["rejoins"] += 1
        _log.info("robot %d rejoins the team at step %d with contacts %s", self.robot_id,
                  step, list(self.contacts))

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray) -> None:
        """Take the world's membership at the start of step ``step``.

        Robots the world says are dead are declared dead at once (``stats['world_dead']``;
        no timeouts spent on them). Robots declared dead that the world says are alive (a
        robot that rejoined, see :meth:`rejoin`, or one declared dead on lost messages) are
        admitted again (``stats['revived_peers']``), and become contacts when the
        configuration of the live robots at ``step`` makes them contacts of this robot
        (:meth:`initialise`'s rule, symmetric: the other robot decides on the same numbers).
        Call it before :meth:`start_step` of ``step``; with everybody alive and nobody
        declared dead it does nothing.

        Parameters
        ----------
        step : int
            The step about to start.
        ids : np.ndarray of int, shape (R,)
            The team's robot ids.
        positions : np.ndarray, shape (R, 2)
            Their positions at ``step`` [m].
        alive : np.ndarray of bool, shape (R,)
            Which robots the world says are alive.
        """
        alive = np.asarray(alive, dtype=bool)
        if not self.dead and alive.all():
            return
        ids, positions, alive = _team_state(ids, positions, alive)
        gone = set(ids[~alive].tolist()) - self.dead - {self.robot_id}
        if gone:
            self.stats["world_dead"] += len(gone)
            _log.warning("robot %d: the world says %s are dead at step %d; declared dead",
                         self.robot_id, sorted(gone), step)
            self._declare_dead(gone)
        back = self.dead & set(ids[alive].tolist())
        if not back or self.robot_id not in ids[alive]:
            return
        self.dead -= back
        self.stats["revived_peers"] += len(back)
        near = set(self._configuration_contacts(ids[alive], positions[alive])) & back
        self.contacts = tuple(sorted(set(self.contacts) | near))
        _log.info("robot %d: %s alive again at step %d; contacts among them: %s",
                  self.robot_id, sorted(back), step, sorted(near))

    def _configuration_contacts(self, ids: np.ndarray, positions: np.ndarray) -> tuple:
        """The own contacts in the Voronoi configuration of robots ``ids`` (ascending)."""
        part = partition(self.ctx.grid.env, positions)
        me = int(np.searchsorted(ids, self.robot_id))
        return self._contacts_in(ids, positions, np.zeros(len(ids)), part, me)[2]

    def _take_configuration(self, ids: np.ndarray, positions: np.ndarray,
                            rho: np.ndarray | None) -> None:
        """Cell, radius, neighbours and contacts in the configuration (``ids`` ascending)."""
        part = partition(self.ctx.grid.env, positions, rho)
        me = int(np.searchsorted(ids, self.robot_id))
        rho_all = np.zeros(len(ids)) if rho is None else rho
        radius, neighbours, contacts = self._contacts_in(ids, positions, rho_all, part, me)
        self.cell = np.asarray(part.cells[me])
        self.cell_radius = radius
        self.neighbours = neighbours
        self.contacts = contacts

    def _contacts_in(self, ids: np.ndarray, positions: np.ndarray, rho: np.ndarray, part,
                     me: int) -> tuple[float, tuple[int, ...], tuple[int, ...]]:
        """Cell radius, neighbours and contacts of row ``me`` of a partition of ``ids``.

        The rule of the initial configuration: the neighbours, their neighbours, and every
        robot within :meth:`FilterContext.contact_mask`'s bound (symmetric in each pair).
        """
        radii = np.array([_cell_radius(positions[j], part.cells[j]) for j in range(len(ids))])
        neighbours = tuple(int(ids[j]) for j in part.neighbours[me])
        two_hop = set(neighbours)
        for j in part.neighbours[me]:
            two_hop.update(int(ids[k]) for k in part.neighbours[j])
        near = self.ctx.contact_mask(positions[me], rho[me], radii[me], positions, rho, radii)
        two_hop.update(ids[near].tolist())
        two_hop.discard(self.robot_id)
        return float(radii[me]), neighbours, tuple(sorted(two_hop))

    # --------------------------------------------------------------- interface
    @property
    def done(self) -> bool:
        """Whether the current step is finished (or no step has started)."""
        return self.phase in (Phase.DONE, Phase.IDLE)

    @property
    def progress(self) -> tuple[int, str, int, int]:
        """A value that changes whenever this robot gets further in its step (watchdogs).

        The step, the phase, and within the update the active ids still pending and the
        partial sums sent; equal values mean no progress in between.
        """
        cur = self._cur
        if cur is None:
            return (self._last_step, self.phase.value, 0, 0)
        return (cur.step, self.phase.value, len(cur.pending), len(cur.partial_sent))

    @property
    def step(self) -> int:
        """Index of the last step started (-1 before the first)."""
        return self._last_step

    def start_step(self, step: int, position: np.ndarray, power_weight: float,
                   z: np.ndarray) -> list[Envelope]:
        """Begin step ``step`` at ``position`` with this robot's measurement set ``z``."""
        if not self.done:
            raise ProtocolError(f"robot {self.robot_id}: step {step} started while step "
                                f"{self._last_step} is in phase {self.phase.value}")
        if step <= self._last_step:
            raise ProtocolError(f"robot {self.robot_id}: step {step} is not after "
                                f"{self._last_step}")
        position = np.asarray(position, dtype=float).reshape(2)
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(z))
                and np.isfinite(power_weight) and power_weight >= 0):
            raise ValueError(f"robot {self.robot_id}: non-finite position, measurement or "
                             f"power weight at step {step}")
        previous = self._sent.get(self._last_step)
        self._sent = {} if previous is None else {self._last_step: previous}
        self._log = self._sent[step] = []
        if self._waiters:
            self._waiters = {}
        self._last_step = step
        self._cur = _StepData(step=step, position=position, power_weight=float(power_weight),
                              z=z)
        self._drop_stale(step)
        self.phase = Phase.STATES
        self._idle_ticks = 0
        self._cur.radius = self.cell_radius
        state = StateMsg(self.robot_id, step, position, float(power_weight), self.cell_radius)
        self._cur.state = state
        out = [self._to(c, state) for c in self.contacts]
        return out + self.advance()

    def receive(self, msg: Message) -> bool:
        """Buffer an incoming message; call :meth:`advance` to act on it.

        Any message from a live peer, even one dropped as stale, shows that the peer is
        alive (see :meth:`tick`). Returns whether the message is new: False when it is
        dropped, or repeats one already held (a keep-alive, or a message re-sent after a
        loss: the first copy is kept, so a duplicate is never applied twice).

        A repeated state of the current or the previous step (finished or not) is a
        keep-alive of a peer that still waits: the answer (what this robot sent that peer
        in that step and it may still miss, or this robot's own state, see
        :meth:`_resend`) is queued, and the next :meth:`advance` returns it. Transports
        must therefore call :meth:`advance` after every :meth:`receive`, also when the step
        is done.
        """
        src, key = _mail_route(msg)
        if src in self.dead or src == self.robot_id:
            self.stats["dropped"] += 1
            return False
        self._heard[src] = self._round
        step = msg.step
        if step < self._last_step or (self._cur is not None and step == self._last_step
                                      and self.phase == Phase.DONE):
            if type(msg) is StateMsg:
                self._resend(src, step)
            self.stats["dropped"] += 1
            return False
        box = self._mail[key]
        if src in box:
            if type(msg) is StateMsg:
                self._resend(src, step)
            else:
                self.stats["duplicates"] += 1
            return False
        box[src] = msg
        return True

    def advance(self) -> list[Envelope]:
        """Make as much progress as the buffered messages allow; returns what to send.

        Re-sends queued by :meth:`receive` (answers to keep-alives) come first.
        """
        if self._outbox:
            again, self._outbox = self._outbox, []
            return again + self._advance()
        return self._advance()

    def _advance(self) -> list[Envelope]:
        # Most messages complete nothing: leave at once while a wait is still short.
        if self._cur is None or self._waiting():
            return []
        out: list[Envelope] = []
        while self._cur is not None:
            before = (self.phase, len(self._cur.pending), len(self._cur.partial_sent))
            out.extend(self._progress())
            if (self.phase, len(self._cur.pending), len(self._cur.partial_sent)) == before:
                break
            self._idle_ticks = 0
        self._log.extend(out)
        return out

    def _resend(self, dst: int, step: int) -> None:
        """Answer robot ``dst``'s keep-alive of step ``step`` (a repeated state).

        Queues again what this robot sent it in that step and it may still miss
        (:func:`_may_miss`). With nothing to re-send, a robot that is itself still in that
        step answers with its own state, at most once per round and peer: the peer may
        lack the state, and it hears that this robot, which it may be waiting for, is
        alive. States are not logged, so a state is never re-sent as such: an answered
        state could be answered again, and two waiting robots would answer each other
        for ever.
        """
        if step == self._last_step:
            self._waiters[dst] = self._round
        held = self._held_from(dst, step)
        again = [e for e in self._sent.get(step, ()) if e.dst == dst and _may_miss(e.msg, held)]
        if (not again and step == self._last_step and not self.done
                and self._spoke.get(dst) != self._round):
            assert self._cur is not None and self._cur.state is not None
            again = [self._to(dst, self._cur.state)]
            self._spoke[dst] = self._round
        if again:
            self._outbox.extend(again)
            self.stats["resent"] += len(again)

    def tick(self) -> list[Envelope]:
        """One round passed without progress anywhere; time out silent peers if it is due.

        Returns the keep-alives (this step's state again, to every peer the robot waits
        for; they answer with what it may miss, see :meth:`receive`) and what the step
        sends if a timeout lets it go on. Of the awaited peers, only those silent for the
        last ``timeout_ticks`` rounds of this wait (so after ``timeout_ticks + 1`` rounds at
        the earliest) are declared dead; after ``3 x timeout_ticks`` rounds without
        progress, all of them.
        """
        cur = self._cur
        if self.done or cur is None:
            return []
        self._round += 1
        self._idle_ticks += 1
        assert cur.state is not None
        missing = self._missing()
        timeout = self.ctx.timeout_ticks
        # Peers that sent keep-alives lately may be waiting for this robot: they hear
        # from it every round, not only when their keep-alive and its answer both arrive.
        waiters = {p for p, r in self._waiters.items()
                   if self._round - r <= timeout and p not in self.dead}
        alive = [self._to(c, cur.state) for c in sorted(missing | waiters)]
        for e in alive:
            self._spoke[e.dst] = self._round
        if self._idle_ticks > 1:
            # The first keep-alive or its answer was lost: ask twice (on a lossy link the
            # two copies fail independently).
            alive += [self._to(c, cur.state) for c in sorted(missing)]
        if self._idle_ticks < timeout:
            return alive
        # A message taken in after tick r arrived in round r + 1's interval: silent means
        # nothing in the last ``timeout`` intervals, counted from the start of this wait
        # (a peer heard just before it began has had ``timeout`` chances to answer).
        since = self._round - self._idle_ticks
        silent = {p for p in missing
                  if self._round - max(self._heard.get(p, since), since) > timeout}
        if missing and not silent and self._idle_ticks < 3 * timeout:
            return alive
        self._idle_ticks = 0
        dead = silent or missing
        if dead:
            self.stats["timeouts"] += 1
            self.stats["declared_dead"] += len(dead)
            _log.warning("robot %d: no answer from %s in phase %s of step %d after %d "
                         "rounds; declared dead", self.robot_id, sorted(dead),
                         self.phase.value, self._last_step, timeout)
            self._declare_dead(dead)
        return alive + self.advance()

    def _held_from(self, src: int, step: int) -> set[str]:
        """Kinds of message of step ``step`` held from robot ``src`` (see :func:`_may_miss`).

        ``partial`` stands for its partial sums for this robot's update, ``total`` for its
        totals of its own update. Empty when the step's mail is gone (a later step started).
        """
        mail = self._mail
        keys = (("cell", (step, "cell")), ("own", (step, "own")),
                ("phantom", (step, "phantom")), ("scan", (step, "scan")),
                ("partial", (step, "partial", self.robot_id)), ("total", (step, "total", src)))
        return {kind for kind, key in keys if src in mail.get(key, ())}

    # ----------------------------------------------------------------- phases
    def _progress(self) -> list[Envelope]:
        cur = self._cur
        assert cur is not None
        if self.phase == Phase.STATES:
            if self._waiting():
                return []
            return self._compute_cell()
        if self.phase == Phase.CELLS:
            if self._waiting():
                return []
            return self._hand_over_bins()
        if self.phase == Phase.TRANSFERS:
            if self._waiting():
                return []
            self._take_over_bins()
            return self._predict()
        if self.phase == Phase.PHANTOMS:
            if self._waiting():
                return []
            self._add_phantoms()
            return self._start_update()
        if self.phase == Phase.UPDATE:
            return self._update_next()
        return []

    def _waiting(self) -> bool:
        """Whether a STATES to PHANTOMS wait still needs a message (False in other phases).

        ``bool(self._missing())``, but O(1) while fewer messages than peers have arrived,
        since it is asked on every message.
        """
        cur = self._cur
        assert cur is not None
        phase = self.phase
        if phase is Phase.STATES:
            need, kind = len(self.contacts), "state"
        elif phase is Phase.CELLS:
            need, kind = len(self.contacts), "cell"
        elif phase is Phase.TRANSFERS:
            need, kind = len(cur.transfer_peers), "own"
        elif phase is Phase.PHANTOMS:
            need, kind = len(cur.phantom_peers), "phantom"
        else:
            return False
        mail = self._mail.get((cur.step, kind))
        if (0 if mail is None else len(mail)) < need:
            return True
        return bool(self._missing())

    def _missing(self) -> set[int]:
        """Peers the current wait still needs to hear from (empty if not waiting)."""
        cur = self._cur
        assert cur is not None
        step = cur.step
        if self.phase == Phase.STATES:
            return set(self.contacts) - set(self._mail[(step, "state")])
        if self.phase == Phase.CELLS:
            return set(self.contacts) - set(self._mail[(step, "cell")])
        if self.phase == Phase.TRANSFERS:
            return cur.transfer_peers - set(self._mail[(step, "own")])
        if self.phase == Phase.PHANTOMS:
            return cur.phantom_peers - set(self._mail[(step, "phantom")])
        if self.phase == Phase.UPDATE and cur.pending:
            j = cur.pending[0]
            if j != self.robot_id:
                if j not in self._mail[(step, "scan")]:
                    return {j}
                z = self._mail[(step, "scan")][j].z
                if len(z) and j not in self._mail[(step, "total", j)]:
                    return {j}
                return set()
            if len(cur.z) == 0:
                return set()
            return (cur.scan_peers - {self.robot_id}) - set(self._mail[(step, "partial",
                                                                          self.robot_id)])
        return set()

    def _compute_cell(self) -> list[Envelope]:
        cur = self._cur
        assert cur is not None
        states = self._mail[(cur.step, "state")]
        if len(states) > len(self.contacts):
            self._reject_strangers(states, set(self.contacts))
        ids = np.array(sorted(set(states) | {self.robot_id}), dtype=np.int64)
        pos = np.array([cur.position if i == self.robot_id else states[i].position
                        for i in ids], dtype=float).reshape(-1, 2)
        rho = np.array([cur.power_weight if i == self.robot_id else states[i].power_weight
                        for i in ids], dtype=float)
        me = int(np.searchsorted(ids, self.robot_id))
        poly, rows = cell_of(self.ctx.grid.env, me, pos, rho)
        cur.ids, cur.positions, cur.weights = ids, pos, rho
        cur.cell = poly
        cur.neighbours = tuple(int(ids[r]) for r in rows)
        self.phase = Phase.CELLS
        table = [states[i] for i in sorted(states)]
        msg = CellMsg(self.robot_id, cur.step, cur.position, cur.power_weight, poly,
                      cur.neighbours, tuple(m.robot_id for m in table),
                      np.array([m.position for m in table], dtype=float).reshape(-1, 2),
                      np.array([m.power_weight for m in table], dtype=float),
                      np.array([m.cell_radius for m in table], dtype=float))
        return [self._to(c, msg) for c in self.contacts]

    def _hand_over_bins(self) -> list[Envelope]:
        """Alg. 1 lines 4-7: bins of the previous cell that a neighbour now owns go to it."""
        cur = self._cur
        assert cur is not None
        cells = self._mail[(cur.step, "cell")]
        for src, msg in cells.items():
            cur.cells[src] = (np.asarray(msg.vertices).reshape(-1, 2), tuple(msg.neighbour_ids))
        radius_ids = np.fromiter(cells, dtype=np.int64, count=len(cells))
        radii = _cell_radii([np.asarray(m.generator, dtype=float) for m in cells.values()],
                            [cur.cells[src][0] for src in cells])
        order = np.argsort(radius_ids, kind="stable")
        cur.fresh_ids, cur.fresh_radii = radius_ids[order], radii[order]
        relay_ids, relay_radii = tuple(cur.fresh_ids.tolist()), cur.fresh_radii
        cur.cell_ids, cur.cell_lo, cur.cell_hi = _bounding_boxes(cur.cells)
        self._check_cell()
        cur.owned = self._owned_bins(cur.cell, cur.ids, cur.positions, cur.weights)
        leaving = ~_isin_sorted(self.bins, cur.owned)
        # Alg. 1 sends to the neighbours N(r) only, which assumes that the previous cell
        # overlaps only current neighbours; with moving cells a bin can go to a robot that
        # was and is only a neighbour's neighbour, so transfers go to every contact.
        cur.transfer_peers = set(self.contacts) - self.dead
        out_bins: dict[int, np.ndarray] = {}
        if leaving.any():
            idx = np.flatnonzero(leaving)
            owner_rows = assign_bins(self.ctx.grid.centres_of(self.bins[idx]),
                                     cur.positions, cur.weights)
            owners = cur.ids[owner_rows]
            lost = ~self._alive(owners)
            if lost.any():
                # The owner died after its state of this step arrived (it is in the
                # partition) and before the hand-over: nobody can take these bins. Their
                # next owner re-initialises them as orphans (see orphan_bins).
                self.stats["lost_to_dead"] += int(lost.sum())
                _log.warning("robot %d: %d bins of its previous cell belong to a robot that "
                             "died during step %d; dropped", self.robot_id, int(lost.sum()),
                             cur.step)
                idx, owners = idx[~lost], owners[~lost]
            for dst in np.unique(owners):
                dst = int(dst)
                if dst == self.robot_id:
                    raise ProtocolError(f"robot {self.robot_id}: a bin it does not own maps "
                                        f"back to it at step {cur.step}")
                if dst not in cur.transfer_peers:
                    raise ProtocolError(
                        f"robot {self.robot_id}: bins of its previous cell belong to robot "
                        f"{dst}, which is not among its contacts (step {cur.step}): robots "
                        f"moved too far in one step for the 2-hop contact set")
                out_bins[dst] = idx[owners == dst]
        out = []
        cum = self.ctx.cumulative

        def payload(sel: np.ndarray) -> tuple:
            return (self.bins[sel], self.weights[sel], self.alpha[sel] if cum else None,
                    self.count[sel] if cum else None)

        # Most transfers are empty: they share one set of empty arrays.
        empty = payload(np.empty(0, dtype=np.int64))
        for dst in sorted(cur.transfer_peers):
            sel = out_bins.get(dst)
            out.append(self._to(dst, TransferMsg(
                self.robot_id, dst, cur.step, TransferKind.OWNERSHIP,
                *(empty if sel is None else payload(sel)), relay_ids, relay_radii)))
        keep = ~leaving
        self._retained = (self.bins[keep], self.weights[keep],
                          self.alpha[keep] if cum else None, self.count[keep] if cum else None)
        self.phase = Phase.TRANSFERS
        return out

    def _take_over_bins(self) -> None:
        cur = self._cur
        assert cur is not None
        owned = cur.owned
        w = np.full(owned.size, np.nan)
        cum = self.ctx.cumulative
        alpha = np.zeros(owned.size) if cum else None
        count = np.zeros(owned.size) if cum else None
        parts = [self._retained]
        for src in sorted(self._mail[(cur.step, "own")]):
            msg = self._mail[(cur.step, "own")][src]
            parts.append((np.asarray(msg.bins, dtype=np.int64), np.asarray(msg.weights),
                          None if msg.alpha is None else np.asarray(msg.alpha),
                          None if msg.count is None else np.asarray(msg.count)))
        for bins, weights, a, n in parts:
            if bins.size == 0:
                continue
            pos = np.searchsorted(owned, bins)
            ok = (pos < owned.size) & (owned[np.minimum(pos, owned.size - 1)] == bins)
            if not ok.all():
                # The sender's partition disagrees with the own one: after a death the
                # robots' dead sets can differ for a step, and a neighbour missing from a
                # contact set (docs/protocol.md) changes a partition. Bins sent on another
                # robot's view are dropped (their owner re-initialises them as orphans).
                self._misrouted(int((~ok).sum()), "bins", cur.step)
            seen = np.zeros(bins.size, dtype=bool)
            seen[ok] = ~np.isnan(w[pos[ok]])
            if seen.any():
                # Two robots held the bin (both owned it in disagreeing partitions of the
                # previous step): the own copy wins, then the lowest sender id.
                self.stats["duplicate_bins"] += int(seen.sum())
                _log.warning("robot %d: %d bins handed to it at step %d were already held; "
                             "the first copy is kept", self.robot_id, int(seen.sum()),
                             cur.step)
            keep = ok & ~seen
            if not keep.all():
                pos, weights = pos[keep], np.asarray(weights)[keep]
                a = None if a is None else np.asarray(a)[keep]
                n = None if n is None else np.asarray(n)[keep]
            w[pos] = weights
            if cum and a is not None and n is not None:
                alpha[pos] = a
                count[pos] = n
        orphans = np.isnan(w)
        if orphans.any():
            self.stats["orphan_bins"] += int(orphans.sum())
            _log.warning("robot %d: %d bins it now owns were handed over by nobody (a dead "
                         "owner or a missed neighbour) at step %d; re-initialised to the "
                         "prior mass %.3g",
                         self.robot_id, int(orphans.sum()), cur.step, self.ctx.prior_mass)
            w[orphans] = self.ctx.prior_mass
        self.bins, self.weights, self.alpha, self.count = owned, w, alpha, count
        self.cell = cur.cell
        self._retained = None

    def _predict(self) -> list[Envelope]:
        """Eq. 3 over the own bins; phantom mass for other robots' bins goes to them."""
        cur = self._cur
        assert cur is not None
        ctx = self.ctx
        mass = ctx.survival[self.bins] * self.weights
        if ctx.kernel.shape == (1, 1):
            self.weights = mass + ctx.birth[self.bins]
            return self._start_update()
        flat, moved = spread(ctx.grid, self.bins, mass, ctx.kernel)
        mine = _isin_sorted(flat, self.bins)
        own = np.zeros(self.bins.size)
        own[np.searchsorted(self.bins, flat[mine])] = moved[mine]
        cur.own_spread = own
        cur.phantom_peers = self._phantom_peers()
        others = ~mine & (moved > 0)
        out_bins: dict[int, np.ndarray] = {}
        if others.any():
            idx = np.flatnonzero(others)
            rows = assign_bins(ctx.grid.centres_of(flat[idx]), cur.positions, cur.weights)
            owners = cur.ids[rows]
            for dst in np.unique(owners):
                dst = int(dst)
                sel = idx[owners == dst]
                if dst not in cur.phantom_peers:
                    # The own partition gives these bins to a contact whose own cell is not
                    # within reach: the partitions disagree (a neighbour missing from a
                    # contact set, docs/protocol.md). The mass has nowhere to go.
                    self.stats["unroutable_bins"] += int(sel.size)
                    _log.warning("robot %d: phantom mass for %d bins of robot %d, whose cell "
                                 "is not within the motion kernel's reach at step %d; "
                                 "dropped (%.3g targets)", self.robot_id, int(sel.size), dst,
                                 cur.step, float(moved[sel].sum()))
                    continue
                out_bins[dst] = sel
        out = []
        for dst in sorted(cur.phantom_peers):
            sel = out_bins.get(dst, np.empty(0, dtype=np.int64))
            out.append(self._to(dst, TransferMsg(self.robot_id, dst, cur.step,
                                                 TransferKind.PHANTOM, flat[sel], moved[sel])))
        self.phase = Phase.PHANTOMS
        return out

    def _phantom_peers(self) -> set[int]:
        """Contacts whose cells come within the motion kernel's reach of the own cell."""
        cur = self._cur
        assert cur is not None
        peers = set()
        if len(cur.cell) == 0:
            return peers
        lo, hi = cur.cell.min(axis=0), cur.cell.max(axis=0)
        reach = self.ctx.reach
        # Bounding boxes further apart than the reach cannot hold closer polygons.
        gap = np.maximum(np.maximum(cur.cell_lo - hi, lo - cur.cell_hi), 0.0)
        near = self._alive(cur.cell_ids) & ~(np.hypot(gap[:, 0], gap[:, 1]) > reach)
        ids = cur.cell_ids[near]
        if ids.size == 0:
            return peers
        dist = _polygon_distances(cur.cell, [cur.cells[rid][0] for rid in ids.tolist()])
        peers.update(ids[dist <= reach].tolist())
        return peers

    def _add_phantoms(self) -> None:
        cur = self._cur
        assert cur is not None
        w = cur.own_spread
        assert w is not None
        for src in sorted(self._mail[(cur.step, "phantom")]):
            msg = self._mail[(cur.step, "phantom")][src]
            bins = np.asarray(msg.bins, dtype=np.int64)
            if bins.size == 0:
                continue
            pos = np.searchsorted(self.bins, bins)
            ok = (pos < self.bins.size) & (self.bins[np.minimum(pos, self.bins.size - 1)]
                                           == bins)
            weights = np.asarray(msg.weights)
            if not ok.all():
                self._misrouted(int((~ok).sum()), "phantom bins", cur.step)
                pos, weights = pos[ok], weights[ok]
            np.add.at(w, pos, weights)
        self.weights = w + self.ctx.birth[self.bins]

    def _start_update(self) -> list[Envelope]:
        """Alg. 2 lines 4-8: exchange measurement sets, list the updates to take part in."""
        cur = self._cur
        assert cur is not None
        grid, radius = self.ctx.grid, self.ctx.models.detection.radius
        fov = self.ctx.fov_bins(cur.position)
        owners = set()
        if fov.size:
            centres = grid.centres_of(fov)
            fov_owners = cur.ids[assign_bins(centres, cur.positions, cur.weights)]
            owners = set(np.unique(fov_owners).tolist())
        cur.scan_peers = owners - self.dead
        if fov.size:
            self._check_coverage(centres, fov_owners)
        out = [self._to(dst, ScanMsg(self.robot_id, cur.step, cur.position, cur.z))
               for dst in sorted(cur.scan_peers - {self.robot_id})]
        meet = grid.disks_meet(self.bins, cur.positions, radius)
        pending = set(cur.ids[self._alive(cur.ids) & meet].tolist())
        # The active robot coordinates its own update even without bins in its field of
        # view (a power cell need not contain its generator).
        if len(cur.z) and cur.scan_peers - {self.robot_id}:
            pending.add(self.robot_id)
        cur.pending = sorted(pending)
        self.phase = Phase.UPDATE
        return out + self._update_next()

    def _update_next(self) -> list[Envelope]:
        """Alg. 2 lines 9-26 for the lowest pending active id, as far as messages allow."""
        cur = self._cur
        assert cur is not None
        out: list[Envelope] = []
        while cur.pending:
            j = cur.pending[0]
            if j == self.robot_id:
                sensor, z = cur.position, cur.z
            else:
                scan = self._mail[(cur.step, "scan")].get(j)
                if scan is None:
                    return out
                sensor, z = np.asarray(scan.sensor), np.asarray(scan.z).reshape(-1, 2)
            models = self.ctx.models
            pos, psi_zx, pd = self._fov_terms(j, sensor, z)
            if len(z) == 0:
                eta = np.empty(0)
            elif j == self.robot_id:
                partials = self._mail[(cur.step, "partial", j)]
                if (cur.scan_peers - {j}) - set(partials):
                    return out
                mine = eta_partial(psi_zx, self.weights[pos])
                ordered = [mine if k == j else np.asarray(partials[k].values)
                           for k in sorted(set(partials) | {j})]
                eta = eta_total(ordered, models.clutter.intensity(z))
                out.extend(self._to(k, EtaTotalMsg(j, cur.step, eta))
                           for k in sorted(cur.scan_peers - {j}))
            else:
                if j not in cur.partial_sent:
                    cur.partial_sent.add(j)
                    out.append(self._to(j, EtaPartialMsg(
                        self.robot_id, j, cur.step, eta_partial(psi_zx, self.weights[pos]))))
                total = self._mail[(cur.step, "total", j)].get(j)
                if total is None:
                    return out
                eta = np.asarray(total.values)
                if eta.shape != (len(z),):
                    raise ProtocolError(f"robot {self.robot_id}: eta totals of robot {j} "
                                        f"have {eta.shape} values for {len(z)} measurements")
            self.weights[pos] = update_weights(self.weights[pos], pd, psi_zx, eta)
            if self.ctx.cumulative:
                # Chen eq. 9-10, one observation per scan; applied at the end of the step.
                if cur.observed is None:
                    cur.observed = np.zeros(self.bins.size, dtype=np.int64)
                    cur.rewarded = np.zeros(self.bins.size, dtype=np.int64)
                cur.observed[pos] += 1
                if len(z):
                    cur.rewarded[pos] += 1
            cur.pending.pop(0)
        if cur.observed is not None:
            self.alpha, self.count = cumulative_update_counts(self.alpha, self.count,
                                                              cur.observed, cur.rewarded)
        self._finish_step()
        return out

    def _fov_terms(self, j: int, sensor: np.ndarray,
                   z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Own bins in robot j's field of view, psi (eq. 6) and p_d there, for this step.

        Kept for the pending id j, since :meth:`_update_next` runs again on every message
        while j's update waits; none of them depends on the weights.

        Returns
        -------
        pos : np.ndarray of int64, shape (K_in,)
            Positions in :attr:`bins` of the bins in the field of view.
        psi_zx : np.ndarray, shape (M, K_in)
            psi of j's measurements at those bins [1/m^2].
        pd : np.ndarray, shape (K_in,)
            p_d of those bins for j's sensor.
        """
        cur = self._cur
        assert cur is not None
        if cur.fov_terms is None or cur.fov_terms[0] != j:
            grid, models = self.ctx.grid, self.ctx.models
            # fov_positions on the ascending own bins, without checking their order again.
            pos = _positions_in_sorted(self.bins, self.ctx.fov_bins(sensor))
            psi_zx, pd = psi_pd(models, grid.centres_of(self.bins[pos]), z, sensor)
            cur.fov_terms = (j, pos, psi_zx, pd)
        return cur.fov_terms[1:]

    def _finish_step(self) -> None:
        cur = self._cur
        assert cur is not None
        states = self._mail[(cur.step, "state")]
        if len(states) >= cur.ids.size:
            # A state arrived after the cell was computed from a robot that is no contact.
            self._reject_strangers(states, set(cur.ids.tolist()))
        self.neighbours = tuple(n for n in cur.neighbours if n not in self.dead)
        two_hop = set(self.neighbours)
        for n in self.neighbours:
            two_hop.update(cur.cells.get(n, (None, ()))[1])
        known = self._known_states()
        self.cell_radius = _cell_radius(cur.position, cur.cell)
        # The larger of the last two radii: a cell can grow fast (a neighbour leaving, a
        # power weight dropping) and shrink back, see docs/protocol.md.
        near = self.ctx.contact_mask(cur.position, cur.power_weight,
                                     max(cur.radius, self.cell_radius), known.positions,
                                     known.power_weights, self._recent_radii(known))
        two_hop.update(known.ids[near].tolist())
        two_hop.discard(self.robot_id)
        self.contacts = tuple(sorted(two_hop - self.dead))
        self.phase = Phase.DONE
        # The step's mail stays until the next step starts: it tells what a peer that
        # still waits can miss (_held_from).

    # ----------------------------------------------------------------- helpers
    def _known_states(self) -> _Known:
        """States of the contacts and of their contacts, this step (not self, not dead).

        The contact tables relayed in the cells are read in arrival order, later tables
        overriding earlier ones, and the contacts' own states override them all.
        """
        cur = self._cur
        assert cur is not None
        if cur.known is not None:
            return cur.known
        states = self._mail[(cur.step, "state")]
        # A table naming only robots whose own states arrived (or self, or the dead) adds
        # nothing: those entries are overridden or dropped below. Skipping such tables
        # first saves converting every table when everybody is everybody's contact.
        covered = set(states) | self.dead | {self.robot_id}
        cells = [m for m in self._mail[(cur.step, "cell")].values()
                 if not covered.issuperset(m.contact_ids)]
        ids = [np.asarray(m.contact_ids, dtype=np.int64).reshape(-1) for m in cells]
        ids.append(np.fromiter(states, dtype=np.int64, count=len(states)))
        pos = [np.asarray(m.contact_positions, dtype=float).reshape(-1, 2) for m in cells]
        pos.append(np.array([m.position for m in states.values()], dtype=float).reshape(-1, 2))
        rho = [np.asarray(m.contact_power_weights, dtype=float).reshape(-1) for m in cells]
        rho.append(np.array([m.power_weight for m in states.values()], dtype=float))
        radii = [np.asarray(m.contact_cell_radii, dtype=float).reshape(-1) for m in cells]
        radii.append(np.array([m.cell_radius for m in states.values()], dtype=float))
        all_ids = np.concatenate(ids)
        # The last entry of each id wins: its first occurrence in the reversed list.
        uniq, first = np.unique(all_ids[::-1], return_index=True)
        last = all_ids.size - 1 - first
        drop = np.fromiter(self.dead | {self.robot_id}, dtype=np.int64)
        keep = ~np.isin(uniq, drop)
        last = last[keep]
        cur.known = _Known(uniq[keep], np.concatenate(pos)[last], np.concatenate(rho)[last],
                           np.concatenate(radii)[last])
        return cur.known

    def _recent_radii(self, known: _Known) -> np.ndarray:
        """Larger of the last two cell radii of each known robot [m], shape (N,).

        The previous step's radius comes with the states; this step's from the cells
        received (the contacts) and the radii the ownership transfers relayed (the
        contacts' contacts). A robot nobody relayed (its relay died during the step) keeps
        the previous step's radius only.
        """
        cur = self._cur
        assert cur is not None
        ids = [cur.fresh_ids]
        radii = [cur.fresh_radii]
        for msg in self._mail[(cur.step, "own")].values():
            if len(msg.radius_ids):
                ids.append(np.asarray(msg.radius_ids, dtype=np.int64).reshape(-1))
                radii.append(np.asarray(msg.cell_radii, dtype=float).reshape(-1))
        all_ids = np.concatenate(ids)
        out = known.cell_radii.copy()
        if all_ids.size == 0 or known.ids.size == 0:
            return out
        # Every relay of a robot's radius is the same number (the same function of the same
        # cell), so which one is taken does not matter.
        uniq, first = np.unique(all_ids, return_index=True)
        pos = np.searchsorted(uniq, known.ids)
        pos_c = np.minimum(pos, uniq.size - 1)
        hit = uniq[pos_c] == known.ids
        out[hit] = np.maximum(out[hit], np.concatenate(radii)[first[pos_c[hit]]])
        return out

    def _check_cell(self) -> None:
        """Count a cell that the contacts' contacts would cut (a missed neighbour)."""
        cur = self._cur
        assert cur is not None
        known = self._known_states()
        extra = ~_isin_sorted(known.ids, cur.ids)
        if not extra.any() or len(cur.cell) == 0:
            return
        # Robot k's half-plane is (x - q) . u_k <= h_k (partition.cells); it cannot cut a
        # cell whose vertices all lie within h_k of q. Most extra robots are far: skip the
        # recomputation when none of them can cut.
        d2 = ((known.positions[extra] - cur.position) ** 2).sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            h = (d2 + cur.power_weight ** 2 - known.power_weights[extra] ** 2) \
                / (2.0 * np.sqrt(d2))
        reach = _cell_radius(cur.position, cur.cell)
        if np.all(h > reach * (1.0 + 1e-9) + 1e-9):
            return
        ids = np.concatenate([cur.ids, known.ids[extra]])
        order = np.argsort(ids, kind="stable")
        ids = ids[order]
        pos = np.concatenate([cur.positions, known.positions[extra]])[order]
        rho = np.concatenate([cur.weights, known.power_weights[extra]])[order]
        poly, _ = cell_of(self.ctx.grid.env, int(np.searchsorted(ids, self.robot_id)), pos,
                          rho)
        if poly.shape != cur.cell.shape or not np.allclose(poly, cur.cell, atol=1e-9):
            self.stats["cell_mismatch"] += 1
            _log.warning("robot %d: its cell at step %d misses a neighbour known only to "
                         "its contacts", self.robot_id, cur.step)

    def _misrouted(self, n: int, what: str, step: int) -> None:
        """Count and log ``n`` bins handed to this robot that it does not own (dropped)."""
        self.stats["misrouted_bins"] += n
        _log.warning("robot %d: dropped %d %s handed to it that it does not own at step %d "
                     "(the robots' partitions disagree: a death or a missed neighbour)",
                     self.robot_id, n, what, step)

    def _reject_strangers(self, states: dict[int, Message], known: set[int]) -> None:
        """Declare dead the senders of ``states`` that are neither ``known`` nor dead.

        A robot that sends its state counts this one as a contact; if this one does not
        count it (the contact sets disagree, e.g. after one of the two declared the other
        dead on lost messages), its state is left out and it is declared dead. It then
        times this robot out in turn, and at the next step both admit each other again on
        the same numbers (:meth:`observe_team`). Never happens while the sets agree.
        """
        strangers = set(states) - known - self.dead
        if not strangers:
            return
        for src in strangers:
            del states[src]
        self.stats["strangers"] += len(strangers)
        _log.warning("robot %d: %s sent states at step %d but are not its contacts (the "
                     "contact sets disagree); declared dead", self.robot_id,
                     sorted(strangers), self._last_step)
        self._declare_dead(strangers)

    def _alive(self, ids: np.ndarray) -> np.ndarray:
        """Which of the robot ids ``ids`` (N,) are not declared dead, bool (N,)."""
        if not self.dead:
            return np.ones(len(ids), dtype=bool)
        return ~np.isin(ids, np.fromiter(self.dead, dtype=np.int64, count=len(self.dead)))

    def _declare_dead(self, ids: set[int]) -> None:
        self.dead |= ids
        cur = self._cur
        self.contacts = tuple(c for c in self.contacts if c not in ids)
        self.neighbours = tuple(n for n in self.neighbours if n not in ids)
        if cur is None:
            return
        cur.transfer_peers -= ids
        cur.phantom_peers -= ids
        cur.scan_peers -= ids
        if self.phase == Phase.UPDATE and cur.pending and cur.pending[0] in ids:
            cur.pending.pop(0)
        cur.pending = [j for j in cur.pending if j not in ids]

    def _check_coverage(self, points: np.ndarray, owners: np.ndarray) -> None:
        """Count field-of-view bins outside every known cell (an unknown robot owns them).

        ``owners`` (N,) are the ids of the robots owning the ``points`` (N, 2): the cells
        are tried in decreasing number of points owned, so that most points are found in
        the first few cells (the count does not depend on the order).
        """
        cur = self._cur
        assert cur is not None
        tol = 1e-9 * (self.ctx.grid.env.width + self.ctx.grid.env.height)
        covered = points_in_polygon(points, cur.cell, tol) if len(cur.cell) else \
            np.zeros(len(points), dtype=bool)
        if covered.all():
            return
        # Only cells whose boxes meet the box of all the points can hold any of them.
        lo, hi = points.min(axis=0), points.max(axis=0)
        near = (self._alive(cur.cell_ids) & np.all(cur.cell_lo <= hi, axis=1)
                & np.all(cur.cell_hi >= lo, axis=1))
        ids = cur.cell_ids[near]
        owned = (owners[~covered][:, None] == ids[None, :]).sum(axis=0)
        ids = ids[np.argsort(-owned, kind="stable")]
        polys = [cur.cells[rid][0] for rid in ids.tolist()]
        covered[~covered] = points_in_any_polygon(points[~covered], polys, tol)
        if not covered.all():
            self.stats["uncovered_fov_bins"] += int((~covered).sum())
            _log.warning("robot %d: %d field-of-view bins lie in no known cell at step %d",
                         self.robot_id, int((~covered).sum()), cur.step)

    def _owned_bins(self, cell: np.ndarray, ids: np.ndarray, positions: np.ndarray,
                    rho: np.ndarray) -> np.ndarray:
        """Ascending flat indices of the bins this robot owns among the given generators."""
        grid = self.ctx.grid
        if len(cell) == 0:
            return np.empty(0, dtype=np.int64)
        lo = cell.min(axis=0) - grid.resolution
        hi = cell.max(axis=0) + grid.resolution
        env, res = grid.env, grid.resolution
        ix0 = max(int(np.floor((lo[0] - env.xmin) / res)), 0)
        ix1 = min(int(np.ceil((hi[0] - env.xmin) / res)), grid.nx - 1)
        iy0 = max(int(np.floor((lo[1] - env.ymin) / res)), 0)
        iy1 = min(int(np.ceil((hi[1] - env.ymin) / res)), grid.ny - 1)
        me = int(np.searchsorted(ids, self.robot_id))
        return bins_owned_in_box(grid, me, positions, rho, (iy0, iy1, ix0, ix1))

    def _to(self, dst: int, msg: Message) -> Envelope:
        return Envelope(self.robot_id, int(dst), msg)

    def _drop_stale(self, step: int) -> None:
        for key in [k for k in self._mail if k[0] < step]:
            del self._mail[key]


def _mail_route(msg: Message) -> tuple[int, tuple]:
    """Sender of ``msg`` and the key of the mailbox it goes to: (step, kind[, active id])."""
    route = _ROUTES.get(type(msg))
    if route is None:
        raise TypeError(f"not a protocol message: {type(msg).__name__}")
    return route(msg)


#: Mailbox routes by exact message type (the hot path of :meth:`RobotFilter.receive`); the
#: sender they give is :func:`.messages.sender_of`'s (tested).
_ROUTES = {
    StateMsg: lambda m: (m.robot_id, (m.step, "state")),
    CellMsg: lambda m: (m.robot_id, (m.step, "cell")),
    ScanMsg: lambda m: (m.robot_id, (m.step, "scan")),
    TransferMsg: lambda m: (m.from_id, (m.step, "own" if m.kind == TransferKind.OWNERSHIP
                                        else "phantom")),
    EtaPartialMsg: lambda m: (m.sender_id, (m.step, "partial", m.active_id)),
    EtaTotalMsg: lambda m: (m.active_id, (m.step, "total", m.active_id)),
}


def _sorted_team(ids: np.ndarray, positions: np.ndarray, power_weights: np.ndarray | None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Ids (N,), positions (N, 2) and power weights (N,) or None, by ascending id."""
    ids = np.asarray(ids, dtype=np.int64)
    order = np.argsort(ids, kind="stable")
    ids, positions = ids[order], np.asarray(positions, dtype=float).reshape(-1, 2)[order]
    rho = None if power_weights is None else np.asarray(power_weights, float)[order]
    if len(np.unique(ids)) != len(ids):
        raise ValueError(f"robot ids must be unique, got {ids.tolist()}")
    return ids, positions, rho


def _team_state(ids: np.ndarray, positions: np.ndarray, alive: np.ndarray | None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A team state by ascending id: ids (R,), positions (R, 2), alive flags (R,)."""
    n = len(np.asarray(ids).reshape(-1))
    alive = np.ones(n, dtype=bool) if alive is None else np.asarray(alive, dtype=bool)
    positions = np.asarray(positions, dtype=float).reshape(-1, 2)
    if alive.shape != (n,) or positions.shape != (n, 2):
        raise ValueError(f"a team state needs one position and one alive flag per id: "
                         f"{n} ids, positions {positions.shape}, alive {alive.shape}")
    order = np.argsort(np.asarray(ids, dtype=np.int64).reshape(-1), kind="stable")
    ids, positions, _ = _sorted_team(ids, positions, None)
    return ids, positions, alive[order]


def _may_miss(msg: Message, held: set[str]) -> bool:
    """Whether a peer from which the kinds ``held`` arrived may still miss ``msg`` from us.

    A robot sends the messages of a phase only once it holds those of the phase before
    from all its contacts: its ownership transfer shows that it had every cell, its phantom
    transfer every ownership transfer, and any message of the update (measurement set,
    partial or total eta) every phantom transfer. In the update, its partial sums for our
    measurements show that it had our measurement set, and its totals that it had our
    partial sums.
    """
    kind = type(msg)
    if kind is CellMsg:
        return not held - {"cell"}
    if kind is TransferMsg:
        later = _AFTER_OWN if msg.kind == TransferKind.OWNERSHIP else _UPDATE
        return not held & later
    if kind is ScanMsg:
        return "partial" not in held
    if kind is EtaPartialMsg:
        return "total" not in held
    return True


_UPDATE = frozenset({"scan", "partial", "total"})
_AFTER_OWN = _UPDATE | {"phantom"}


def _cell_radius(q: np.ndarray, cell: np.ndarray) -> float:
    """Largest distance from q to a vertex of ``cell`` [m] (0 for an empty cell)."""
    if len(cell) == 0:
        return 0.0
    return float(np.sqrt(((np.asarray(cell) - np.asarray(q)[None, :2]) ** 2).sum(axis=1).max()))


def _cell_radii(generators: list[np.ndarray], cells: list[np.ndarray]) -> np.ndarray:
    """:func:`_cell_radius` of each (generator, cell) pair, in one array operation, (N,)."""
    out = np.zeros(len(cells))
    sizes = np.array([len(c) for c in cells], dtype=np.int64)
    full = np.flatnonzero(sizes)
    if full.size == 0:
        return out
    vertices = np.concatenate([cells[i] for i in full]).reshape(-1, 2)
    q = np.repeat(np.array([generators[i][:2] for i in full], dtype=float).reshape(-1, 2),
                  sizes[full], axis=0)
    d2 = ((vertices - q) ** 2).sum(axis=1)
    starts = np.concatenate([[0], np.cumsum(sizes[full][:-1])])
    out[full] = np.sqrt(np.maximum.reduceat(d2, starts))
    return out


def _bounding_boxes(cells: dict[int, tuple[np.ndarray, tuple[int, ...]]]
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ids (N,), lower (N, 2) and upper (N, 2) box corners of the non-empty cells [m].

    The cells are taken in the dict's order; empty ones are left out.
    """
    ids = [rid for rid, (poly, _) in cells.items() if len(poly)]
    if not ids:
        return np.empty(0, dtype=np.int64), np.empty((0, 2)), np.empty((0, 2))
    polys = [cells[rid][0] for rid in ids]
    starts = np.cumsum([0] + [len(p) for p in polys[:-1]])
    vertices = np.concatenate(polys)
    return (np.array(ids, dtype=np.int64), np.minimum.reduceat(vertices, starts, axis=0),
            np.maximum.reduceat(vertices, starts, axis=0))


def _positions_in_sorted(sorted_set: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Positions in the ascending ``sorted_set`` of those ``values`` it holds, int64 (K,)."""
    if sorted_set.size == 0 or values.size == 0:
        return np.empty(0, dtype=np.int64)
    pos = np.minimum(np.searchsorted(sorted_set, values), sorted_set.size - 1)
    return pos[sorted_set[pos] == values]


def _isin_sorted(values: np.ndarray, sorted_set: np.ndarray) -> np.ndarray:
    """Membership of ``values`` in the ascending array ``sorted_set``."""
    if sorted_set.size == 0:
        return np.zeros(values.shape, dtype=bool)
    pos = np.minimum(np.searchsorted(sorted_set, values), sorted_set.size - 1)
    return sorted_set[pos] == values


def _polygon_distances(a: np.ndarray, polys: list[np.ndarray]) -> np.ndarray:
    """Distance between the convex polygon ``a`` and each of ``polys`` [m], shape (P,).

    0 where they touch or overlap (a vertex of one within 1e-9 m of the other), else the
    smallest vertex-to-edge distance either way. All polygons are handled in one array
    operation per term, with the same float expressions per (vertex, edge) pair as for a
    single pair, so the result does not depend on which polygons are grouped together.
    """
    b, starts, following = stack_polygons(polys)
    a_in_b = points_in_polygons(a, polys, tol=1e-9).any(axis=0)
    b_in_a = np.logical_or.reduceat(points_in_polygon(b, a, tol=1e-9), starts)
    # Vertices of a to the edges of every b, and vertices of every b to the edges of a.
    a_to_b = np.minimum.reduceat(_points_to_edges2(a, b, b[following]).min(axis=0), starts)
    b_to_a = np.minimum.reduceat(
        _points_to_edges2(b, a, np.roll(a, -1, axis=0)).min(axis=1), starts)
    dist = np.minimum(np.sqrt(a_to_b), np.sqrt(b_to_a))
    return np.where(a_in_b | b_in_a, 0.0, dist)


def _points_to_edges2(points: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Squared distance from each of ``points`` (P, 2) to each edge p0 -> p1 (E, 2), (P, E)."""
    d = p1 - p0
    len2 = np.maximum((d * d).sum(axis=1), 1e-300)
    rel = points[:, None, :] - p0[None, :, :]
    t = np.clip((rel * d[None]).sum(axis=2) / len2, 0.0, 1.0)
    closest = p0[None] + t[..., None] * d[None]
    return ((points[:, None, :] - closest) ** 2).sum(axis=2)


__all__ = ["FilterContext", "Phase", "ProtocolError", "RobotFilter"]
