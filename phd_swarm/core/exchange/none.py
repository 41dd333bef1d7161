"""The empty exchange: a robot that tells nobody anything (a single robot, Sung & Tokekar).

Registered as ``none``. Every step is done as soon as it starts, no message is ever sent,
and what arrives is ignored (there is nothing to arrive). The agent
(:class:`phd_swarm.core.agent.Agent`) still runs the estimator on the robot's own scan and
the controller on what the estimator knows.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import registry
from .base import Envelope, Exchange


class NoExchange(Exchange):
    """One robot's side of no exchange at all."""

    def __init__(self) -> None:
        self._step = -1
        #: Protocol counters (none), for the engines' team totals.
        self.stats: dict[str, int] = {}

    def initialise(self, ids: np.ndarray, positions: np.ndarray) -> None:
        """Nothing to set up."""

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray, keep_dead: frozenset[int] = frozenset()) -> None:
        """Nothing to learn from the team."""

    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray) -> None:
        """Nothing to rejoin."""

    def start_step(self, step: int, position: np.ndarray, power_weight: float,
                   z: np.ndarray) -> list[Envelope]:
        """The step is done at once; nothing to send."""
        self._step = int(step)
        return []

    def receive(self, msg: Any) -> bool:
        """Nothing is news."""
        return False

    def advance(self) -> list[Envelope]:
        """Nothing to send."""
        return []

    def tick(self) -> list[Envelope]:
        """Nothing to send."""
        return []

    @property
    def done(self) -> bool:
        """Always done."""
        return True

    @property
    def step(self) -> int:
        """The current (or last) step; -1 before the first."""
        return self._step


registry.register(
    "exchange", "none", lambda setup, rid: NoExchange(),
    description="No exchange: each robot keeps its estimate to itself (a single robot, "
                "Sung & Tokekar 2022).", wire="phd_swarm.nodes.faces.none:WIRE")
