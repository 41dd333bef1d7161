"""One robot of the distributed grid PHD filter (Dames 2020 Sec. III) as a state machine.

The robot never calls a transport: :meth:`Participant.start_step`, :meth:`receive`,
:meth:`advance` and :meth:`tick` take messages in and return :class:`Envelope` s addressed to
robots. One step ``t`` runs these phases:

1. ``STATES`` (Alg. 1 line 1): send the state (q, rho) to the contact set K, wait for
   theirs. K is the 2-hop neighbourhood of the previous partition (neighbours and their
   neighbours, learnt from the cells they shared), so a robot exchanges O(neighbours)
   messages, independent of the team size (:mod:`.membership`).
2. ``CELLS`` (Alg. 1 lines 2-3): compute the own power/Voronoi cell from the contacts'
   states, send it (with the neighbour ids) to K, wait for theirs (:mod:`.cells`).
3. ``TRANSFERS`` (Alg. 1 lines 4-7): hand the bins of the previous cell that now belong to
   another robot to that robot; bins arrive from the contacts likewise (:mod:`.handover`).
4. ``PHANTOMS`` (Sec. III-B): predict (eq. 3) over the own bins expanded by the support of
   the motion kernel; the phantom mass that lands on other robots' bins is sent to them.
   Skipped for static targets (identity kernel) (:mod:`.phantoms`).
5. ``UPDATE`` (Alg. 2): exchange measurement sets, partial and total eta sums, and update
   the own bins (eq. 4) (:mod:`.eta`).

Per-bin state besides the PHD mass (Chen's cumulative alpha and n) is a layer that travels
with the bins (:mod:`.layers`). Ownership of a bin is the canonical rule of
:func:`phd_swarm.core.geometry.ownership.assign_bins` (lowest power distance, lowest id on
ties) over the robot and its contacts, so all robots agree on it without a global view.
Every sum that combines several robots' numbers is taken in robot-id order, so the result
does not depend on the order messages arrive in.

Failures and lost messages: every wait counts :meth:`tick` s; a waiting robot sends
keep-alives and declares silent peers dead (:mod:`.liveness`). A keep-alive is also a
request, answered by the next :meth:`advance` with what the peer may still miss
(:mod:`.mailbox`), so transports call :meth:`advance` after every :meth:`receive`, also when
the step is done. A run without losses sends exactly the messages of the loss-free
protocol; with every message arriving in the end and no peer timed out, the result is
bit-identical to it. :mod:`phd_swarm.core.exchange.faults` injects the losses.

Membership: :meth:`Participant.observe_team` and :meth:`Participant.rejoin`
(:mod:`.membership`). Disagreeing partitions cost counted bins for a step (:mod:`.handover`,
:mod:`.phantoms`); every counter stays zero in the runs compared with the central filter.

Length: about 500 lines, because the phase sequence and the answers to keep-alives (which
touch every phase) are kept in one place; each job of a phase is in a module of its own.
"""

from __future__ import annotations

import logging
from collections import defaultdict
from typing import Any

import numpy as np

from ..base import Envelope, Exchange
from .cells import LocalPartition, NeighbourCells
from .context import FilterContext
from .errors import ProtocolError
from .eta import EtaUpdate
from .handover import HandOver, owned_bins
from .layers import layer_for
from .liveness import Liveness
from .mailbox import Mailbox, mail_route
from .membership import Membership, recent_radii, sorted_team
from .messages import Message, StateMsg
from .phantoms import PhantomExchange, moves_mass, static_prediction
from .step import Phase, Step

_log = logging.getLogger("phd_swarm.protocol")


class _Delegated:
    """A public attribute of :class:`Participant` kept by one of its collaborators."""

    def __init__(self, owner: str) -> None:
        self.owner = owner

    def __set_name__(self, cls: type, name: str) -> None:
        self.name = name

    def __get__(self, robot: Any, cls: type | None = None) -> Any:
        return self if robot is None else getattr(getattr(robot, self.owner), self.name)

    def __set__(self, robot: Any, value: Any) -> None:
        setattr(getattr(robot, self.owner), self.name, value)


class Participant(Exchange):
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
    cell_radius : float
        Largest distance from the robot to a vertex of its cell [m].
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
        ``rejoins``, ``strangers`` and those of the modules of the phases. A counter that
        stayed 0 is absent.
    """

    alpha = _Delegated("_layer")
    count = _Delegated("_layer")
    cell_radius = _Delegated("_members")
    neighbours = _Delegated("_members")
    contacts = _Delegated("_members")
    dead = _Delegated("_members")

    def __init__(self, robot_id: int, ctx: FilterContext) -> None:
        self.robot_id = int(robot_id)
        self.ctx = ctx
        self.bins = np.empty(0, dtype=np.int64)
        self.weights = np.empty(0)
        self.cell = np.empty((0, 2))
        self.phase = Phase.IDLE
        self.stats: dict[str, int] = defaultdict(int)
        self._layer = layer_for(ctx)
        self._members = Membership(self.robot_id, ctx, self.stats, self._forget)
        self._liveness = Liveness(ctx.timeout_ticks)
        self._mail = Mailbox(self.robot_id)
        self._last_step = -1
        self._cur: Step | None = None

    # ------------------------------------------------------------------ set-up
    def initialise(self, ids: np.ndarray, positions: np.ndarray,
                   power_weights: np.ndarray | None = None) -> None:
        """Start from the team's known initial configuration (every robot knows it once).

        Computes the initial partition, takes the own bins with the prior mass, and sets
        the neighbours and the 2-hop contacts for step 0. After this, only neighbour
        traffic is used.
        """
        ids, positions, rho = sorted_team(ids, positions, power_weights)
        if self.robot_id not in ids:
            raise ValueError(f"robot {self.robot_id} is not among the team ids {ids.tolist()}")
        self.cell = self._members.take_configuration(ids, positions, rho)
        self.bins = owned_bins(self.ctx.grid, self.robot_id, self.cell, ids, positions,
                               np.zeros(len(ids)) if rho is None else rho)
        self.weights = np.full(self.bins.size, self.ctx.prior_mass)
        self._layer.reset(self.bins.size)

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
        self.cell = self._members.rejoin(step, ids, positions, alive)
        self.bins = np.empty(0, dtype=np.int64)
        self.weights = np.empty(0)
        self._layer.reset(0)
        self.phase = Phase.IDLE
        self._last_step = step - 1
        self._cur = None
        self._mail.clear()
        self._liveness.clear()
        self.stats["rejoins"] += 1
        _log.info("robot %d rejoins the team at step %d with contacts %s", self.robot_id,
                  step, list(self.contacts))

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray, keep_dead: frozenset[int] = frozenset()) -> None:
        """Take the world's membership at the start of step ``step``.

        Robots the world says are dead are declared dead at once (``stats['world_dead']``;
        no timeouts spent on them). Robots declared dead that the world says are alive (a
        robot that rejoined, see :meth:`rejoin`, or one declared dead on lost messages) are
        admitted again (``stats['revived_peers']``), and become contacts when the
        configuration of the live robots at ``step`` makes them contacts of this robot
        (:meth:`initialise`'s rule, symmetric: the other robot decides on the same numbers).
        Call it before :meth:`start_step` of ``step``; with everybody alive and nobody
        declared dead it does nothing. The robots of ``keep_dead`` stay dead although the
        world says they are alive (the configuration that decides contacts still counts
        them, so that both sides of every other pair decide on the same numbers).

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
        keep_dead : frozenset of int
            Robots declared dead here that are not admitted again at this step.
        """
        self._members.observe_team(step, ids, positions, alive, keep_dead)

    @property
    def dead_peers(self) -> frozenset[int]:
        """The robots declared dead (by the world or by a timeout here)."""
        return frozenset(self._members.dead)

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
        return (cur.state.step, self.phase.value, *cur.update_progress())

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
        self._mail.start_step(step, self._last_step)
        self._liveness.start_step()
        self._last_step = step
        state = StateMsg(self.robot_id, step, position, float(power_weight),
                         self._members.cell_radius)
        self._cur = Step(state, z)
        self._mail.drop_before(step)
        self.phase = Phase.STATES
        out = [self._to(c, state) for c in self._members.contacts]
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
        src, key = mail_route(msg)
        if src in self._members.dead or src == self.robot_id:
            self.stats["dropped"] += 1
            return False
        self._liveness.heard(src)
        step = msg.step
        if step < self._last_step or (self._cur is not None and step == self._last_step
                                      and self.phase == Phase.DONE):
            if type(msg) is StateMsg:
                self._resend(src, step)
            self.stats["dropped"] += 1
            return False
        box = self._mail.box(key)
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
        if self._mail.queued:
            return self._mail.take_queue() + self._advance()
        return self._advance()

    def _advance(self) -> list[Envelope]:
        # Most messages complete nothing: leave at once while a wait is still short.
        if self._cur is None or self._waiting():
            return []
        out: list[Envelope] = []
        while self._cur is not None:
            before = (self.phase, *self._cur.update_progress())
            out.extend(self._progress())
            if (self.phase, *self._cur.update_progress()) == before:
                break
            self._liveness.progressed()
        self._mail.record(out)
        return out

    def _resend(self, dst: int, step: int) -> None:
        """Answer robot ``dst``'s keep-alive of step ``step`` (a repeated state).

        Queues again what this robot sent it in that step and it may still miss
        (:func:`.mailbox.may_miss`). With nothing to re-send, a robot that is itself still
        in that step answers with its own state, at most once per round and peer: the peer
        may lack the state, and it hears that this robot, which it may be waiting for, is
        alive. States are not logged, so a state is never re-sent as such: an answered
        state could be answered again, and two waiting robots would answer each other
        for ever.
        """
        if step == self._last_step:
            self._liveness.keep_alive_from(dst)
        again = self._mail.owed_to(dst, step)
        if (not again and step == self._last_step and not self.done
                and self._liveness.may_answer(dst)):
            assert self._cur is not None
            again = [self._to(dst, self._cur.state)]
            self._liveness.answered(dst)
        if again:
            self._mail.queue(again)
            self.stats["resent"] += len(again)

    def tick(self) -> list[Envelope]:
        """One round passed without progress anywhere; time out silent peers if it is due.

        Returns the keep-alives (this step's state again, to every peer the robot waits
        for; they answer with what it may miss, see :meth:`receive`) and what the step
        sends if a timeout lets it go on (:meth:`.liveness.Liveness.tick`: who is declared
        dead when).
        """
        cur = self._cur
        if self.done or cur is None:
            return []
        to, dead = self._liveness.tick(self._missing(), self._members.dead)
        alive = [self._to(c, cur.state) for c in to]
        if dead is None:
            return alive
        if dead:
            self.stats["timeouts"] += 1
            self.stats["declared_dead"] += len(dead)
            _log.warning("robot %d: no answer from %s in phase %s of step %d after %d "
                         "rounds; declared dead", self.robot_id, sorted(dead),
                         self.phase.value, self._last_step, self.ctx.timeout_ticks)
            self._members.declare_dead(dead)
        return alive + self.advance()

    # ----------------------------------------------------------------- phases
    def _progress(self) -> list[Envelope]:
        """Complete the current phase if its messages are in; returns what that sends."""
        if self.phase is Phase.UPDATE:
            return self._update()
        complete = _ON_COMPLETE.get(self.phase)
        return [] if complete is None or self._waiting() else complete(self)

    def _waiting(self) -> bool:
        """Whether a STATES to PHANTOMS wait still needs a message (:meth:`Step.waiting`)."""
        return self._cur.waiting(self.phase, self._members.contacts, self._mail)

    def _missing(self) -> set[int]:
        """Peers the current wait still needs to hear from (empty if not waiting)."""
        return self._cur.missing(self.phase, self._members.contacts, self._mail)

    def _compute_cell(self) -> list[Envelope]:
        """Alg. 1 lines 2-3: the own cell from the states received, sent to the contacts."""
        cur = self._cur
        assert cur is not None
        step = cur.state.step
        states = self._mail.box((step, "state"))
        if len(states) > len(self._members.contacts):
            self._members.reject_strangers(states, set(self._members.contacts), step)
        cur.view = LocalPartition.compute(self.ctx.grid.env, cur.state, states)
        self.phase = Phase.CELLS
        msg = cur.view.message(cur.state, states)
        return [self._to(c, msg) for c in self._members.contacts]

    def _hand_over_bins(self) -> list[Envelope]:
        """Alg. 1 lines 4-6: bins of the previous cell that a contact now owns go to it."""
        cur = self._cur
        assert cur is not None and cur.view is not None
        step = cur.state.step
        msgs = self._mail.box((step, "cell"))
        cur.cells = NeighbourCells.receive(msgs)
        cur.known = self._members.known_states(self._mail.box((step, "state")), msgs)
        self._members.check_cell(cur.view, cur.known, cur.state)
        cur.handover = HandOver(self.robot_id, self.ctx, self.stats, cur.view,
                                set(self._members.contacts) - self._members.dead)
        relay = (tuple(cur.cells.radius_ids.tolist()), cur.cells.radii)
        out = cur.handover.give(step, self.bins, self.weights, self._layer,
                                self._members.alive, relay)
        self.phase = Phase.TRANSFERS
        return out

    def _take_over_and_predict(self) -> list[Envelope]:
        """Alg. 1 line 7, then eq. 3 over the own bins; phantom mass goes to its owners."""
        cur = self._cur
        assert cur is not None and cur.handover is not None and cur.view is not None
        assert cur.cells is not None
        self.bins, self.weights = cur.handover.take(
            cur.state.step, self._mail.box((cur.state.step, "own")), self._layer)
        self.cell = cur.view.cell
        if not moves_mass(self.ctx):
            self.weights = static_prediction(self.ctx, self.bins, self.weights)
            return self._start_update()
        cur.phantoms = PhantomExchange(self.robot_id, self.ctx, self.stats)
        out = cur.phantoms.send(cur.state.step, self.bins, self.weights, cur.view, cur.cells,
                                self._members.alive)
        self.phase = Phase.PHANTOMS
        return out

    def _add_phantoms_and_update(self) -> list[Envelope]:
        """The phantom mass received completes eq. 3; then the update starts."""
        cur = self._cur
        assert cur is not None and cur.phantoms is not None
        self.weights = cur.phantoms.add(cur.state.step, self.bins,
                                        self._mail.box((cur.state.step, "phantom")))
        return self._start_update()

    def _start_update(self) -> list[Envelope]:
        """Alg. 2 lines 4-8: exchange measurement sets, list the updates to take part in."""
        cur = self._cur
        assert cur is not None and cur.view is not None and cur.cells is not None
        cur.update = EtaUpdate(self.robot_id, self.ctx, self.stats, cur.state.step,
                               cur.state.position, cur.z)
        out = cur.update.start(self.bins, cur.view, cur.cells, self._members.alive,
                               self._members.dead)
        self.phase = Phase.UPDATE
        return out + self._update()

    def _update(self) -> list[Envelope]:
        """Alg. 2 lines 9-26 as far as messages allow; the step ends with the last update."""
        cur = self._cur
        assert cur is not None and cur.update is not None
        out = cur.update.advance(self.bins, self.weights, self._layer, self._mail)
        if not cur.update.pending:
            self._finish_step()
        return out

    def _finish_step(self) -> None:
        """Neighbours and contacts for the next step; the step is done."""
        cur = self._cur
        assert cur is not None and cur.view is not None and cur.cells is not None
        assert cur.known is not None
        step = cur.state.step
        states = self._mail.box((step, "state"))
        if len(states) >= cur.view.ids.size:
            # A state arrived after the cell was computed from a robot that is no contact.
            self._members.reject_strangers(states, set(cur.view.ids.tolist()), step)
        radii = recent_radii(cur.known, cur.cells, self._mail.box((step, "own")))
        self._members.finish_step(cur.state, cur.view, cur.cells, cur.known, radii)
        self.phase = Phase.DONE
        # The step's mail stays until the next step starts: it tells what a peer that
        # still waits can miss (Mailbox.held_from).

    # ----------------------------------------------------------------- helpers
    def _forget(self, ids: set[int]) -> None:
        """Robots ``ids`` were declared dead: the step in progress stops waiting for them."""
        if self._cur is not None:
            self._cur.drop(ids)

    def _to(self, dst: int, msg: Message) -> Envelope:
        return Envelope(self.robot_id, int(dst), msg)


#: What completes each wait for one message per peer (the update completes as it goes).
_ON_COMPLETE = {Phase.STATES: Participant._compute_cell,
                Phase.CELLS: Participant._hand_over_bins,
                Phase.TRANSFERS: Participant._take_over_and_predict,
                Phase.PHANTOMS: Participant._add_phantoms_and_update}

__all__ = ["FilterContext", "Phase", "ProtocolError", "Participant"]
