"""Failure detection: keep-alives while a robot waits, and timeouts of silent peers.

Every wait counts ticks (rounds without progress). A robot that waits re-sends its state
of the step on every tick, a keep-alive, to the peers it waits for (twice from the second
tick of a wait on) and to the peers whose keep-alives it received lately (they may be
waiting for it): a peer that is itself blocked (on a robot that died) is slow, not dead.
The awaited robots from which nothing at all arrived in the last ``timeout_ticks`` rounds
of the wait are declared dead (so after ``timeout_ticks + 1`` rounds at the earliest);
after ``3 x timeout_ticks`` rounds without progress every awaited robot is (a wait that
cannot end). Any message from a peer counts as hearing from it. A run without losses has
no rounds without progress, hence no keep-alives.
"""

from __future__ import annotations


class Liveness:
    """Rounds, when each peer was last heard from, and the decision to time peers out.

    Parameters
    ----------
    timeout_ticks : int
        Rounds without progress before a silent peer is declared dead.
    """

    def __init__(self, timeout_ticks: int) -> None:
        self.timeout = timeout_ticks
        #: Rounds ticked so far, and the round in which each peer was last heard from.
        self._round = 0
        self._heard: dict[int, int] = {}
        #: Rounds of the current wait without progress.
        self._idle_ticks = 0
        #: The round in which this robot last sent each peer its state again, and in which
        #: each peer last sent it a keep-alive of the current step.
        self._spoke: dict[int, int] = {}
        self._waiters: dict[int, int] = {}

    def clear(self) -> None:
        """Forget every peer heard from and every wait (a robot rejoining the team)."""
        self._heard.clear()
        self._idle_ticks = 0
        self._spoke, self._waiters = {}, {}

    def start_step(self) -> None:
        """A new step: a new wait, and the keep-alives of the last step no longer count."""
        if self._waiters:
            self._waiters = {}
        self._idle_ticks = 0

    def heard(self, src: int) -> None:
        """A message from ``src`` arrived (in this round)."""
        self._heard[src] = self._round

    def progressed(self) -> None:
        """The robot got further: the wait starts again."""
        self._idle_ticks = 0

    def keep_alive_from(self, src: int) -> None:
        """``src`` sent a keep-alive of the current step: it may be waiting for this robot."""
        self._waiters[src] = self._round

    def may_answer(self, dst: int) -> bool:
        """Whether this robot has not yet sent ``dst`` its state in this round."""
        return self._spoke.get(dst) != self._round

    def answered(self, dst: int) -> None:
        """Note that ``dst`` got this robot's state in this round."""
        self._spoke[dst] = self._round

    def tick(self, missing: set[int], dead: set[int]) -> tuple[list[int], set[int] | None]:
        """One round without progress while waiting for the peers ``missing``.

        Parameters
        ----------
        missing : set of int
            Peers the wait still needs to hear from.
        dead : set of int
            Peers declared dead (no keep-alives to them).

        Returns
        -------
        keep_alives : list of int
            Peers to send the state of the step to, in order (a peer may appear twice).
        timed_out : set of int or None
            None while the wait goes on; else the peers to declare dead (possibly none),
            and the wait starts again.
        """
        self._round += 1
        self._idle_ticks += 1
        timeout = self.timeout
        # Peers that sent keep-alives lately may be waiting for this robot: they hear
        # from it every round, not only when their keep-alive and its answer both arrive.
        waiters = {p for p, r in self._waiters.items()
                   if self._round - r <= timeout and p not in dead}
        to = sorted(missing | waiters)
        for dst in to:
            self._spoke[dst] = self._round
        if self._idle_ticks > 1:
            # The first keep-alive or its answer was lost: ask twice (on a lossy link the
            # two copies fail independently).
            to += sorted(missing)
        if self._idle_ticks < timeout:
            return to, None
        # A message taken in after tick r arrived in round r + 1's interval: silent means
        # nothing in the last ``timeout`` intervals, counted from the start of this wait
        # (a peer heard just before it began has had ``timeout`` chances to answer).
        since = self._round - self._idle_ticks
        silent = {p for p in missing
                  if self._round - max(self._heard.get(p, since), since) > timeout}
        if missing and not silent and self._idle_ticks < 3 * timeout:
            return to, None
        self._idle_ticks = 0
        return to, silent or missing


__all__ = ["Liveness"]
