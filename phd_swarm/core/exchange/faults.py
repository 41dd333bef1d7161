"""Lossy links: drop or delay outgoing protocol messages, for fault-injection runs.

A :class:`FaultyLink` stands between one sender and its transport. For every outgoing
envelope it decides, from one uniform draw ``u`` of its own generator, whether the envelope
is

- dropped, when ``u < drop`` (probability ``drop``);
- delayed by ``d`` whole rounds, ``1 <= d <= max_delay_rounds``, when
  ``drop <= u < drop + (1 - drop) delay`` (probability ``(1 - drop) delay``: of the
  envelopes not dropped, a fraction ``delay`` is delayed); ``d`` is read from the same draw,
  uniform over ``1..max_delay_rounds``;
- delivered now otherwise.

A round is what the transport makes of it: in
:class:`phd_swarm.engines.distributed.DistributedEngine` one pass of its delivery loop, in
the ROS robot node one tick period (``tick_period``). The link only decides; the transport
holds the delayed envelopes back and hands them over after that many rounds.

Each sender has a generator of its own, ``np.random.default_rng([seed, robot_id])``
(:meth:`FaultyLink.for_sender`), so the senders' faults are independent and do not depend
on how the robots are spread over processes: the in-memory engine and a ROS robot node
draw the same faults for the same sequence of envelopes. With ``drop = delay = 0`` a link
draws no random numbers and hands every envelope back unchanged.

Example (a transport's send path)::

    link = FaultyLink.for_sender(LinkFaults(drop=0.05), robot_id)
    now, delayed = link.route(envelopes)
    publish(now)
    for rounds, envelope in delayed:
        hold(envelope, rounds)      # publish it ``rounds`` rounds from now
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

T = TypeVar("T")

#: Decision codes of :meth:`FaultyLink.decide`.
DROP = -1
NOW = 0


@dataclass(frozen=True)
class LinkFaults:
    """How lossy the links between robots are.

    Attributes
    ----------
    drop : float
        Probability that a message is lost, in [0, 1].
    delay : float
        Probability that a message that is not lost arrives late, in [0, 1].
    max_delay_rounds : int
        A late message arrives 1 to ``max_delay_rounds`` rounds late (uniform), >= 1.
    seed : int
        Seed of the senders' generators (``default_rng([seed, robot_id])``), >= 0.
    """

    drop: float = 0.0
    delay: float = 0.0
    max_delay_rounds: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("drop", "delay"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating,
                                                                 np.integer)):
                raise ValueError(f"LinkFaults.{name} must be a number in [0, 1], "
                                 f"got {value!r}")
            if not 0.0 <= float(value) <= 1.0:
                raise ValueError(f"LinkFaults.{name} must lie in [0, 1], got {value!r}")
        if (isinstance(self.max_delay_rounds, bool)
                or not isinstance(self.max_delay_rounds, (int, np.integer))
                or self.max_delay_rounds < 1):
            raise ValueError(f"LinkFaults.max_delay_rounds must be an integer >= 1, "
                             f"got {self.max_delay_rounds!r}")
        if (isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer))
                or self.seed < 0):
            raise ValueError(f"LinkFaults.seed must be an integer >= 0, got {self.seed!r}")

    @property
    def active(self) -> bool:
        """Whether any message can be dropped or delayed."""
        return self.drop > 0.0 or self.delay > 0.0


class FaultyLink:
    """The faults of one sender's outgoing link.

    Parameters
    ----------
    faults : LinkFaults
        Drop and delay probabilities.
    rng : np.random.Generator
        The sender's own generator (see :meth:`for_sender`).

    Attributes
    ----------
    dropped, delayed : int
        Envelopes dropped and delayed so far.
    """

    def __init__(self, faults: LinkFaults, rng: np.random.Generator) -> None:
        self.faults = faults
        self.rng = rng
        self.dropped = 0
        self.delayed = 0
        self._delay_hi = faults.drop + (1.0 - faults.drop) * faults.delay

    @classmethod
    def for_sender(cls, faults: LinkFaults, robot_id: int) -> FaultyLink:
        """The link of robot ``robot_id``, on ``np.random.default_rng([seed, robot_id])``."""
        return cls(faults, np.random.default_rng([faults.seed, int(robot_id)]))

    def decide(self, n: int) -> np.ndarray:
        """Fate of the next ``n`` envelopes: -1 dropped, 0 now, d > 0 delayed by d rounds.

        Draws ``n`` uniforms (none when ``n == 0`` or the faults are off).

        Returns
        -------
        np.ndarray of int64, shape (n,)
        """
        f = self.faults
        if n == 0 or not f.active:
            return np.zeros(n, dtype=np.int64)
        u = self.rng.random(n)
        fate = np.zeros(n, dtype=np.int64)
        late = (u >= f.drop) & (u < self._delay_hi)
        if late.any():
            # Where u lies within the delay interval picks d, uniform over 1..max.
            frac = (u[late] - f.drop) / (self._delay_hi - f.drop)
            fate[late] = np.minimum(1 + (frac * f.max_delay_rounds).astype(np.int64),
                                    f.max_delay_rounds)
        fate[u < f.drop] = DROP
        self.dropped += int((fate == DROP).sum())
        self.delayed += int(late.sum())
        return fate

    def route(self, envelopes: Sequence[T]) -> tuple[list[T], list[tuple[int, T]]]:
        """Split outgoing envelopes into those to send now and those to send later.

        Parameters
        ----------
        envelopes : sequence
            Outgoing messages, in send order (any objects: the link does not look inside).

        Returns
        -------
        now : list
            To send now, in the given order. With the faults off, ``envelopes`` as a list
            and no random number drawn.
        delayed : list of (int, envelope)
            To send ``rounds`` rounds from now, in the given order. Dropped envelopes are
            in neither list (counted in :attr:`dropped`).
        """
        if not self.faults.active or not envelopes:
            return list(envelopes), []
        fate = self.decide(len(envelopes))
        now = [e for e, d in zip(envelopes, fate.tolist(), strict=True) if d == NOW]
        later = [(d, e) for e, d in zip(envelopes, fate.tolist(), strict=True) if d > 0]
        return now, later


__all__ = ["DROP", "NOW", "FaultyLink", "LinkFaults"]
