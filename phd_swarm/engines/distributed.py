"""The in-memory engine: R robots running the distributed protocol against the world.

Every message goes through one queue; with ``delivery_seed`` set, the next message to deliver
is drawn at random from everything in flight, so tests can show that the result does not
depend on arrival order. The engine counts, per step and per receiving robot, the messages
and (estimated CDR) bytes of each type. It is the ROS-free twin of the ROS stack and the
fast engine of parameter sweeps.

One step k:

0. every live robot learns the world's membership (ids, positions q^k, alive flags:
   :meth:`Participant.observe_team`), so a robot killed is declared dead at once and a
   robot revived (:meth:`DistributedEngine.revive`, :meth:`Participant.rejoin`) is admitted
   again;
1. the world gives each live robot its measurement set Z^k at its position q^k;
2. the robots run one step of their exchange (for Dames' system the protocol of
   :class:`phd_swarm.core.exchange.voronoi_phd.participant.Participant`), messages being
   delivered until every live robot is done (rounds without progress are ticks, which
   time out dead peers);
3. each robot's controller picks its goal and next power weight.

Steps 0-3 are those of :class:`phd_swarm.core.agent.Agent`, the one agent step that the ROS
robot node runs too, for whatever system ``scenario.system`` names;
4. the world moves the robots toward their goals and the targets, to step k+1.

With ``reference=True`` the estimator's central form (its ``central`` hook: for the grid
PHD a :class:`~phd_swarm.core.estimators.grid_phd.central.CentralPhdFilter`) is fed the same
measurement sets in robot-id order, for the equivalence tests.

Lossy links (``faults``, a :class:`~phd_swarm.core.exchange.faults.LinkFaults`): every
envelope a robot sends goes through that robot's
:class:`~phd_swarm.core.exchange.faults.FaultyLink`, which drops it, delays it by whole
rounds or lets it through. The delivery then runs in rounds, each one pass in which every
message due is handed out and its receivers advance; a round in which nothing is due is a
round without progress, in which every waiting robot ticks (keep-alives, which their peers
answer with re-sends, and timeouts). A message delayed by d rounds is handed out d rounds
after the round it would have arrived in; one still held when the step ends arrives during
the next step (and is dropped there as stale). Per step, :class:`StepTraffic` counts the
envelopes dropped and delayed.
"""

from __future__ import annotations

import inspect
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from itertools import groupby
from typing import Any

import numpy as np

from phd_swarm.core.agent import Team
from phd_swarm.core.controllers.base import Decision
from phd_swarm.core.exchange.base import ENGINE_TIMEOUT_TICKS, Envelope
from phd_swarm.core.exchange.faults import FaultyLink, LinkFaults
from phd_swarm.core.scan import Scan
from phd_swarm.sim.scenario import Scenario
from phd_swarm.sim.world import World


class DeadlockError(RuntimeError):
    """No robot can make progress and no timeout can help: a protocol bug."""


def message_type(msg: Any) -> str:
    """Name of a message's type as in ``msg_defs``: every message names it (``WIRE_TYPE``).

    Dames' phantom transfers are counted apart from ownership ones.
    """
    return msg.WIRE_TYPE


@dataclass
class StepTraffic:
    """Messages and bytes received by each robot during one step, by type.

    Attributes
    ----------
    messages, bytes : dict of int to Counter
        Receiver id -> message type -> count or estimated bytes.
    lost : int
        Messages from or to a killed robot.
    dropped, delayed : int
        Envelopes the lossy links dropped and delayed (``faults``; 0 without).
    """

    messages: dict[int, Counter] = field(default_factory=lambda: defaultdict(Counter))
    bytes: dict[int, Counter] = field(default_factory=lambda: defaultdict(Counter))
    lost: int = 0
    dropped: int = 0
    delayed: int = 0


class DistributedEngine:
    """Run a scenario with the distributed filter, message by message, in one process.

    Parameters
    ----------
    scenario : Scenario
        Map, models, team, targets, duration, seed, and the system the robots run
        (``scenario.system``).
    controller : str, optional
        Shorthand for ``scenario.with_system(controller=...)``: run this controller
        (``phd``, ``uniform``, ``chen_p``, ``chen_o``, or any registered) instead.
    delivery_seed : int, optional
        Shuffle the delivery order with this seed (None: first in, first out).
    reference : bool
        Also run the centralised reference filter on the same measurement sets.
    timeout_ticks : int
        Rounds without progress before a robot declares a silent peer dead.
    faults : LinkFaults, optional
        Drop and delay the robots' messages (one
        :class:`~phd_swarm.core.exchange.faults.FaultyLink` per sender, seeded with
        ``[faults.seed, robot id]``). None: perfect links.
    """

    def __init__(self, scenario: Scenario, controller: str | None = None,
                 delivery_seed: int | None = None, reference: bool = False,
                 timeout_ticks: int = ENGINE_TIMEOUT_TICKS,
                 faults: LinkFaults | None = None) -> None:
        if controller is not None:
            scenario = scenario.with_system(controller=controller)
        self.scenario = scenario
        self.grid = scenario.grid
        self.world = World(scenario)
        self.team = Team.build(scenario, timeout_ticks=timeout_ticks)
        self.timeout_ticks = timeout_ticks
        ids = self.world.robot_ids
        self.agents = {int(i): self.team.agent(int(i)) for i in ids}
        positions = self.world.robot_positions
        for agent in self.agents.values():
            agent.initialise(ids, positions)
        self.killed: set[int] = set()
        #: Killed robots the team has not yet seen dead at the start of a step.
        self._unseen_dead: set[int] = set()
        central = self.team.parts["estimator"].central
        if reference and central is None:
            raise ValueError(f"reference=True needs an estimator with a central form; "
                             f"{scenario.system.estimator!r} has none")
        #: The estimator's central form (its ``central`` hook), fed the same scans.
        self.central = central(scenario) if reference else None
        self._rng = None if delivery_seed is None else np.random.default_rng(delivery_seed)
        self.traffic: list[StepTraffic] = []
        self.last_scans: dict[int, np.ndarray] = {}
        #: Each live robot's decision at the last step (goal and power weight).
        self.decisions: dict[int, Decision] = {}
        self.faults = faults
        self.links = None if faults is None else {
            int(i): FaultyLink.for_sender(faults, int(i)) for i in ids}
        #: Rounds of the lossy delivery so far, the envelopes due next round, and the
        #: delayed ones by the round they are due in.
        self._rounds = 0
        self._next: list[Envelope] = []
        self._held: dict[int, list[Envelope]] = defaultdict(list)

    # ------------------------------------------------------------------ control
    @property
    def step_index(self) -> int:
        """Index of the next step to run."""
        return self.world.step_index

    def kill(self, robot_id: int) -> None:
        """Stop a robot: it no longer scans, moves, sends or receives."""
        self.killed.add(int(robot_id))
        self._unseen_dead.add(int(robot_id))
        self.world.kill(int(robot_id))

    def revive(self, robot_id: int, restart: bool = False) -> None:
        """Bring a killed robot back: it rejoins the team at the next step.

        Call it between steps. The world scans and moves the robot again from the next
        step, and its filter rejoins (:meth:`Participant.rejoin`) from the world's team
        state at that step: with ``restart=True`` a fresh :class:`Participant` (a restarted
        process), else the old one (a robot that was only slow, stopped wherever it was).
        Its power weight starts from 0 again.

        Raises
        ------
        ValueError
            If the robot is not dead, or the team has not yet seen it dead (no step has
            started since it was killed).
        """
        rid = int(robot_id)
        if rid not in self.killed:
            raise ValueError(f"robot {rid} is not dead")
        if rid in self._unseen_dead:
            raise ValueError(f"robot {rid} was killed after the last step started; run a "
                             f"step without it before reviving it")
        self.killed.discard(rid)
        self.world.revive(rid)
        if restart:
            self.agents[rid] = self.team.agent(rid)
        self.agents[rid].rejoin(self.world.step_index, self.world.robot_ids,
                                self.world.robot_positions, self.world.alive)

    @property
    def robots(self) -> dict[int, object]:
        """Robot id -> its exchange participant.

        For Dames' system a
        :class:`~phd_swarm.core.exchange.voronoi_phd.participant.Participant` (bins, weights,
        counters).
        """
        return {rid: agent.exchange for rid, agent in self.agents.items()}

    @property
    def power_weights(self) -> dict[int, float]:
        """Robot id -> the power weight its state carries at the next step."""
        return {rid: agent.power_weight for rid, agent in self.agents.items()}

    def live_ids(self) -> list[int]:
        """Ids of the robots not killed, ascending."""
        return [i for i in sorted(self.agents) if i not in self.killed]

    def step(self) -> None:
        """Run one full step (scan, protocol, control, world motion)."""
        k = self.world.step_index
        scans = self.world.scans()
        positions = dict(zip(self.world.robot_ids.tolist(), self.world.robot_positions,
                             strict=True))
        traffic = StepTraffic()
        self._announce_team(k)
        queue: list[Envelope] = []
        live = self.live_ids()
        estimator = self.team.parts["estimator"]
        team_step = None if estimator.runs_in_exchange else estimator.team_step
        # The labels of the scans, from a sensor that identifies targets (else none).
        labels = self.world.scan_labels
        if team_step is not None:
            # The estimators of all live robots in one call (the estimator part's own
            # vectorised step, equal robot by robot to each robot's predict and update).
            team_step([self.agents[rid].estimator for rid in live],
                      [Scan(rid, k, positions[rid], scans.get(rid, np.empty((0, 2))),
                            labels.get(rid)) for rid in live])
        for rid in live:
            z = scans.get(rid, np.empty((0, 2)))
            queue.extend(self.agents[rid].start_step(k, positions[rid], z,
                                                     labels=labels.get(rid),
                                                     estimated=team_step is not None))
        if self.links is None:
            self._deliver(queue, traffic)
        else:
            self._deliver_lossy(queue, traffic)
        self.traffic.append(traffic)
        self.decisions = {rid: self.agents[rid].finish_step() for rid in self.live_ids()}
        goals = {rid: d.goal for rid, d in self.decisions.items()}
        self.last_scans = scans
        if self.central is not None:
            self.central.step([Scan(rid, k, positions[rid], scans[rid])
                               for rid in sorted(scans)])
        self.world.apply_goals(goals)
        self.world.advance()

    def _announce_team(self, k: int) -> None:
        """Step 0 of a step: give every live robot the world's membership (its team state)."""
        alive = self.world.alive
        ids = self.world.robot_ids
        positions = self.world.robot_positions
        for rid in self.live_ids():
            self.agents[rid].observe_team(k, ids, positions, alive)
        self._unseen_dead.clear()

    def run(self, steps: int | None = None) -> None:
        """Run ``steps`` steps (default: the rest of the scenario)."""
        n = self.scenario.steps - self.world.step_index if steps is None else steps
        for _ in range(n):
            self.step()

    def _deliver(self, initial: list[Envelope], traffic: StepTraffic) -> None:
        """Deliver messages until every live robot has finished the step.

        In order (no ``delivery_seed``) the queue is taken in rounds: every message queued
        is handed to its receiver, then each receiver advances once, which is what a robot
        does with a burst of messages and saves calling it on each. With a delivery seed
        each message is drawn at random from all those queued and its receiver advances at
        once, the finest interleaving. The result does not depend on the order (tested).
        """
        shuffle = self._rng is not None
        robots = self.agents
        stalls = 0
        limit = 4 * self.timeout_ticks + 8
        queue: list[Envelope] = list(initial)
        while True:
            while queue:
                if shuffle:
                    i = int(self._rng.integers(len(queue)))
                    queue[i], queue[-1] = queue[-1], queue[i]
                    batch = [queue.pop()]
                else:
                    batch, queue = queue, []
                receivers = self._hand_out(batch, traffic)
                for dst in receivers:
                    queue.extend(robots[dst].advance())
            waiting = [rid for rid in self.live_ids() if not robots[rid].done]
            if not waiting:
                return
            stalls += 1
            if stalls > limit:
                phases = {rid: robots[rid].exchange.phase.value for rid in waiting}
                raise DeadlockError(f"step {self.world.step_index}: robots still waiting after "
                                    f"{limit} rounds without progress: {phases}")
            for rid in waiting:
                queue.extend(robots[rid].tick())

    def _deliver_lossy(self, initial: list[Envelope], traffic: StepTraffic) -> None:
        """:meth:`_deliver` through the lossy links, round by round.

        Each round hands out every envelope due (in random order with a delivery seed) and
        advances the receivers; what they send is routed through the senders' links, due
        next round or ``d`` rounds later, or dropped. A round with nothing due is a round
        without progress: the waiting robots tick. A :class:`DeadlockError` is raised after
        ``4 timeout_ticks + 8 + max_delay_rounds`` such rounds in a row in which no robot
        got further (:attr:`Participant.progress`), which the robots' own timeouts rule out
        unless the protocol is broken.
        """
        robots = self.agents
        assert self.faults is not None
        limit = 4 * self.timeout_ticks + 8 + self.faults.max_delay_rounds
        stalls, marker = 0, None
        self._route(initial, traffic)
        while True:
            self._rounds += 1
            batch, self._next = self._next, []
            batch.extend(self._held.pop(self._rounds, ()))
            if batch:
                if self._rng is not None:
                    batch = [batch[i] for i in self._rng.permutation(len(batch))]
                for dst in self._hand_out(batch, traffic):
                    self._route(robots[dst].advance(), traffic)
                continue
            waiting = [rid for rid in self.live_ids() if not robots[rid].done]
            if not waiting:
                return
            now = [robots[rid].exchange.progress for rid in waiting]
            stalls = stalls + 1 if now == marker else 1
            marker = now
            if stalls > limit:
                phases = {rid: robots[rid].exchange.phase.value for rid in waiting}
                raise DeadlockError(f"step {self.world.step_index}: robots still waiting after "
                                    f"{limit} rounds without progress: {phases}")
            for rid in waiting:
                self._route(robots[rid].tick(), traffic)

    def _route(self, out: list[Envelope], traffic: StepTraffic) -> None:
        """Send robots' envelopes through their senders' links (due next round or later)."""
        links = self.links
        assert links is not None
        for src, group in groupby(out, key=lambda e: e.src):
            envelopes = list(group)
            now, later = links[src].route(envelopes)
            self._next.extend(now)
            for d, envelope in later:
                self._held[self._rounds + 1 + d].append(envelope)
            traffic.delayed += len(later)
            traffic.dropped += len(envelopes) - len(now) - len(later)

    def _hand_out(self, batch: list[Envelope], traffic: StepTraffic) -> dict[int, None]:
        """Buffer each message at its receiver and count it; return the receivers.

        Receivers come in the order of their first message. Messages from or to a killed
        robot are lost (counted in ``traffic.lost``).
        """
        robots, killed = self.agents, self.killed
        messages, sizes = traffic.messages, traffic.bytes
        receivers: dict[int, None] = {}
        last, kind, size = None, "", 0
        for src, dst, msg in batch:
            if dst in killed or src in killed:
                traffic.lost += 1
                continue
            # A broadcast is queued as consecutive envelopes of one message object.
            if msg is not last:
                last, kind, size = msg, message_type(msg), msg.wire_size()
            messages[dst][kind] += 1
            sizes[dst][kind] += size
            robots[dst].receive(msg)
            receivers[dst] = None
        return receivers

    # -------------------------------------------------------------- observation
    def team_estimates(self) -> tuple[np.ndarray, float]:
        """The live robots' own estimates, stacked (K, 2) [m], and their expected counts summed.

        The team's estimate for systems whose estimator runs in the agent (a grid PHD
        distributed over cells is read with :meth:`team_weights` instead).
        """
        estimators = [self.agents[rid].estimator for rid in self.live_ids()]
        points = [np.asarray(e.estimates(), dtype=float).reshape(-1, 2) for e in estimators]
        return (np.concatenate(points) if points else np.empty((0, 2)),
                float(sum(e.expected_count() for e in estimators)))

    def figures(self, truth: np.ndarray, ids: np.ndarray | None = None) -> dict[str, Any]:
        """The system's own per-step figures (its estimator's ``figures`` hook), or none.

        E.g. Sung & Tokekar's counts of components and tracks and Mahalanobis distances
        (:mod:`phd_swarm.core.estimators.sung.figures`). A hook that takes the keyword
        ``ids`` is also given the true targets' ids (when known), and one that takes
        ``controllers`` the live robots' controllers (e.g. Papaioannou et al.'s per-target
        figures and overlap counts, :mod:`phd_swarm.core.estimators.papaioannou.figures`).
        The controller part's ``figures`` hook, ``(controllers, truth)``, adds its own
        (as :meth:`phd_swarm.engines.central.CentralEngine.figures` does).
        """
        hook = self.team.parts["estimator"].figures
        own = self.team.parts["controller"].figures
        if hook is None and own is None:
            return {}
        live = self.live_ids()
        controllers = [self.agents[rid].controller for rid in live]
        out: dict[str, Any] = {}
        if hook is not None:
            estimators = [self.agents[rid].estimator for rid in live]
            takes = inspect.signature(hook).parameters
            extra: dict[str, Any] = {}
            if "ids" in takes and ids is not None:
                extra["ids"] = ids
            if "controllers" in takes:
                extra["controllers"] = controllers
            out.update(hook(estimators, truth, self.scenario.ospa_c, self.scenario.ospa_p,
                            **extra))
        if own is not None:
            # The controller part's own figures (e.g. chen_o's switching counts).
            out.update(own(controllers, truth))
        return out

    def team_weights(self) -> np.ndarray:
        """The team PHD as an image (ny, nx): the union of the live robots' bins."""
        img = np.zeros(self.grid.size)
        for rid in self.live_ids():
            robot = self.agents[rid].exchange
            img[robot.bins] += robot.weights
        return img.reshape(self.grid.shape)

    def ownership_counts(self) -> np.ndarray:
        """How many live robots own each bin, shape (size,); a partition gives all ones."""
        counts = np.zeros(self.grid.size, dtype=np.int64)
        for rid in self.live_ids():
            np.add.at(counts, self.agents[rid].exchange.bins, 1)
        return counts

    def counters(self) -> dict[str, int]:
        """The robots' protocol counters (:attr:`Participant.stats`), summed over the team."""
        total: dict[str, int] = {}
        for robot in self.robots.values():
            for key, value in robot.stats.items():
                total[key] = total.get(key, 0) + value
        return total

    def messages_per_robot(self, step: int = -1) -> dict[int, int]:
        """Messages received by each live robot in a step."""
        t = self.traffic[step]
        return {rid: sum(t.messages[rid].values()) for rid in self.live_ids()}
