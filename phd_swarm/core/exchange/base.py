"""The exchange role: what robots tell each other, as a transport-agnostic state machine.

An exchange participant never calls a transport. The agent (:mod:`phd_swarm.core.agent`)
hands it the world's membership and the robot's scan, feeds it the messages that arrive and
a tick for every round (tick period) without news, and sends the :class:`Envelope` s it
returns; the in-memory engine delivers them through a queue, the ROS robot node publishes
them on the receivers' inbox topics (:mod:`phd_swarm.nodes.wire`). A robot's exchange is
done with a step when :attr:`Exchange.done`. An exchange that carries the estimator's own
state (Shirsat & Berman's reward sets) or the controller's (Papaioannou et al.'s modes and
plans) overrides :meth:`Exchange.bind_estimator` or :meth:`Exchange.bind_controller`, which
the agent calls once with the robot's own.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, NamedTuple

import numpy as np

#: Rounds without progress before an exchange gives up a silent peer, in the in-memory
#: engine (whatever the exchange; the robot node has its own ``timeout_ticks`` parameter).
ENGINE_TIMEOUT_TICKS = 3


class ProtocolError(RuntimeError):
    """An exchange's invariant was violated (a bug, or views of the team that disagree).

    Raised by any exchange's step methods; the robot node rejects the step it was starting
    and says why, whatever the exchange.
    """


class Envelope(NamedTuple):
    """A message addressed to robot ``dst`` by robot ``src``.

    A named tuple, not a dataclass: the engine creates ~10^4 per step, and a tuple is
    several times cheaper to build.
    """

    src: int
    dst: int
    msg: Any

    def __repr__(self) -> str:
        return f"Envelope(src={self.src}, dst={self.dst}, msg={type(self.msg).__name__})"


class Exchange(ABC):
    """One robot's side of an exchange (see the module docstring).

    Every method that may produce messages returns them as a list of :class:`Envelope`.
    """

    @abstractmethod
    def initialise(self, ids: np.ndarray, positions: np.ndarray) -> None:
        """The team's configuration at the start (ids (R,), positions (R, 2) [m])."""

    @abstractmethod
    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray, keep_dead: frozenset[int] = frozenset()) -> None:
        """The world's membership at the start of ``step`` (who died, who came back).

        ``keep_dead``: robots this one holds for dead although the world says they are
        alive (a real-time robot's verdict on silence, until the world's own; see
        :class:`phd_swarm.nodes.robot.RobotNode`): they are not admitted again.
        """

    @property
    def dead_peers(self) -> frozenset[int]:
        """The robots this one holds for dead (none for an exchange without a dead set)."""
        return frozenset()

    @abstractmethod
    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray) -> None:
        """Come back into the team at ``step`` after being counted dead."""

    @abstractmethod
    def start_step(self, step: int, position: np.ndarray, power_weight: float,
                   z: np.ndarray) -> list[Envelope]:
        """Start ``step`` at ``position`` with measurement set ``z`` (M, 2)."""

    @abstractmethod
    def receive(self, msg: Any) -> bool:
        """Take one message in; True if it is news (not a repeat or a keep-alive)."""

    @abstractmethod
    def advance(self) -> list[Envelope]:
        """Go as far as the messages received allow."""

    @abstractmethod
    def tick(self) -> list[Envelope]:
        """One round without progress: keep-alives, timeouts."""

    @property
    @abstractmethod
    def done(self) -> bool:
        """Whether the current step is finished."""

    @property
    @abstractmethod
    def step(self) -> int:
        """The current (or last) step."""

    def bind_estimator(self, estimator: Any) -> None:  # noqa: B027 (a hook, empty by default)
        """Be handed the robot's estimator once, to carry its state (default: ignore it)."""

    def bind_controller(self, controller: Any) -> None:  # noqa: B027 (a hook, empty by default)
        """Be handed the robot's controller once, to carry its state (default: ignore it)."""
