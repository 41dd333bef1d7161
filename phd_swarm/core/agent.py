"""The one agent step: scan -> exchange -> estimator -> controller, for every system.

An :class:`Agent` is one robot of a system (:class:`phd_swarm.core.system.SystemConfig`): its
exchange participant, estimator and controller, made from the registry
(:mod:`phd_swarm.core.registry`) with the team's shared set-up (:class:`Team`), and its own
seeded generator. The distributed in-memory engine (:mod:`phd_swarm.engines.distributed`)
and the ROS robot node (:mod:`phd_swarm.nodes.robot`) drive robots only through it, so the
proofs that the two give
the same run cover every system. One step k:

1. :meth:`Agent.observe_team` (or :meth:`Agent.rejoin`): the world's membership at step k;
2. :meth:`Agent.start_step` with the robot's position q^k and its measurement set Z^k:
   the estimator predicts and updates with the scan (unless the exchange runs it, as for
   Dames' distributed grid PHD: ``runs_in_exchange``, :mod:`phd_swarm.core.estimators.base`),
   then the exchange starts the step and returns the first messages to send;
3. :meth:`Agent.receive` + :meth:`Agent.advance` for every message that arrives, and
   :meth:`Agent.tick` for every round (tick period) without progress, until
   :attr:`Agent.done`; each returns the messages to send (addressed envelopes);
4. :meth:`Agent.finish_step`: the controller decides the goal (and the power weight the
   exchange sends with the robot's state at the next step) from what the estimator and the
   exchange know (:class:`~phd_swarm.core.controllers.base.Knowledge`).

Randomness: robot r's controller draws from ``robot_generator(seed, r)``, a stream of its
own (the world's streams are the first three children of the scenario seed,
:mod:`phd_swarm.sim.world`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .controllers.base import Decision, Knowledge
from .registry import ROLES, Part
from .scan import Scan

#: Child of the scenario's SeedSequence whose children are the robots' own streams.
ROBOT_STREAMS = 3


def robot_generator(seed: int, robot_id: int) -> np.random.Generator:
    """Robot ``robot_id``'s generator: child ``robot_id`` of child 3 of the scenario seed."""
    return np.random.default_rng(np.random.SeedSequence(seed,
                                                        spawn_key=(ROBOT_STREAMS, robot_id)))


@dataclass(frozen=True, eq=False)
class Team:
    """What the robots of one team share: the parts and their set-up, made once.

    Build it with :meth:`build`. Robots in one process share one team (and its caches);
    a robot in a process of its own builds the same.

    Attributes
    ----------
    scenario : Scenario
        The run's settings (``scenario.system`` names the parts).
    parts : dict of str to Part
        Role -> registered part.
    setups : dict of str to object
        Role -> what the part's ``setup`` returned.
    """

    scenario: Any
    parts: dict[str, Part]
    setups: dict[str, Any]

    @classmethod
    def build(cls, scenario: Any, **runtime: Any) -> Team:
        """Set up the parts of ``scenario.system``.

        ``runtime`` goes to every part's ``setup`` (e.g. ``timeout_ticks`` of the exchange).
        """
        system = scenario.system
        parts = system.parts()
        setups = {role: parts[role].setup(scenario, system, **runtime) for role in ROLES}
        return cls(scenario, parts, setups)

    def make(self, role: str, robot_id: int) -> Any:
        """Robot ``robot_id``'s instance of ``role``."""
        return self.parts[role].make(self.setups[role], robot_id)

    def agent(self, robot_id: int) -> Agent:
        """A new agent for robot ``robot_id`` (a fresh start, e.g. a restarted process)."""
        return Agent(robot_id, self)


def _refuse_partition_guard(team: Team) -> None:
    """Refuse a controller whose options bound the power weights at the team's partition.

    Such a bound (:class:`~phd_swarm.core.controllers.base.PowerWeightGuard`) needs every
    robot's position at the partition; a robot of the protocol computes its cell from its
    contacts' states alone, so only the central engine can apply it.
    """
    part = team.parts["controller"]
    hook = part.power_weight_guard
    guard = None if hook is None else hook(team.setups["controller"])
    if guard is not None:
        raise ValueError(f"controller {part.name}: option {guard.option} bounds the power "
                         f"weights by the positions of the whole team at the partition, "
                         f"which a robot of the distributed protocol does not know; run it "
                         f"on the central engine (engine: central)")


class Agent:
    """One robot of a system: exchange, estimator, controller and its generator.

    Parameters
    ----------
    robot_id : int
        The robot's id in the team.
    team : Team
        The team's parts and set-up.

    Attributes
    ----------
    exchange : object
        The exchange participant (for ``voronoi_phd`` a
        :class:`~phd_swarm.core.exchange.voronoi_phd.participant.Participant`).
    estimator, controller : object
        The robot's estimator and controller (:class:`~phd_swarm.core.controllers.base.
        Controller`).
    power_weight : float
        The weight the robot's state carries at the next step (the last decision's).
    position, z : np.ndarray
        The robot's position and measurement set at the current step.
    """

    def __init__(self, robot_id: int, team: Team) -> None:
        self.robot_id = int(robot_id)
        self.team = team
        _refuse_partition_guard(team)
        self.exchange = team.make("exchange", robot_id)
        self.estimator = team.make("estimator", robot_id)
        self.controller = team.make("controller", robot_id)
        self.rng = robot_generator(team.scenario.seed, robot_id)
        # An exchange that carries the estimator's state (Shirsat & Berman's reward sets)
        # or the controller's (Papaioannou et al.'s mode and joint plan) keeps them.
        self.exchange.bind_estimator(self.estimator)
        self.exchange.bind_controller(self.controller)
        self._view = team.parts["exchange"].view or (lambda exchange: None)
        #: Whether this agent runs the estimator, or the exchange does (Dames' grid PHD).
        self._runs_estimator = not team.parts["estimator"].runs_in_exchange
        self.power_weight = 0.0
        self.position = np.zeros(2)
        self.z = np.empty((0, 2))

    # ---------------------------------------------------------------- membership
    def initialise(self, ids: np.ndarray, positions: np.ndarray) -> None:
        """The team's configuration at the start (every robot gets the same)."""
        self.exchange.initialise(ids, positions)

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray, keep_dead: frozenset[int] = frozenset()) -> None:
        """The world's membership at the start of ``step`` (who died, who came back).

        ``keep_dead``: see :meth:`phd_swarm.core.exchange.base.Exchange.observe_team`.
        """
        self.exchange.observe_team(step, ids, positions, alive, keep_dead)

    @property
    def dead_peers(self) -> frozenset[int]:
        """The robots the exchange holds for dead."""
        return self.exchange.dead_peers

    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray) -> None:
        """Come back into the team at ``step`` (after being counted dead).

        The power weight starts from 0 again.
        """
        self.exchange.rejoin(step, ids, positions, alive)
        self.power_weight = 0.0

    # --------------------------------------------------------------------- step
    def start_step(self, step: int, position: np.ndarray, z: np.ndarray, *,
                   labels: np.ndarray | None = None, estimated: bool = False) -> list:
        """Start ``step`` at ``position`` with measurement set ``z``; messages to send.

        The estimator predicts and takes the scan first (unless the exchange runs it, or
        ``estimated``: the caller has already stepped it with this scan, e.g. the
        distributed engine with the estimator part's ``team_step``). ``labels``: the
        target label of each measurement, from a sensor that identifies targets
        (:attr:`phd_swarm.core.scan.Scan.labels`); None or empty when it gives none.
        """
        self.position = np.asarray(position, dtype=float)
        self.z = np.asarray(z, dtype=float).reshape(-1, 2)
        if self._runs_estimator and not estimated:
            self.estimator.predict()
            self.estimator.update(Scan(self.robot_id, step, self.position, self.z, labels))
        return self.exchange.start_step(step, self.position, self.power_weight, self.z)

    def receive(self, msg: Any) -> bool:
        """Take one message in; True if it is news (not a repeat or a keep-alive)."""
        return self.exchange.receive(msg)

    def advance(self) -> list:
        """Go as far as the messages received allow; messages to send."""
        return self.exchange.advance()

    def tick(self) -> list:
        """One round (tick period) without progress: keep-alives and timeouts."""
        return self.exchange.tick()

    @property
    def done(self) -> bool:
        """Whether the exchange has finished the current step."""
        return self.exchange.done

    @property
    def step(self) -> int:
        """The current (or last) step of the exchange."""
        return self.exchange.step

    def finish_step(self) -> Decision:
        """The controller's decision at the end of the step (call once :attr:`done`)."""
        knowledge = Knowledge(self.robot_id, self.exchange.step, self.position, self.z,
                              self._view(self.exchange), self.estimator)
        decision = self.controller.decide(knowledge, self.rng)
        self.power_weight = decision.power_weight
        return decision
