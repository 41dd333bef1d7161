"""One message per contact per step: the machinery the radio-based exchanges share.

An exchange of this kind (Shirsat & Berman's :mod:`.meet_merge`, Papaioannou et al.'s
:mod:`.sat_share`) works the same way at every step k of robot r:

1. :meth:`ContactExchange.start_step`: the contacts are the live robots the radio
   (:mod:`.radio`) reaches, from the world's team state of step k; the robot sends one
   message to each (:meth:`ContactExchange._message`), and the step is done at once if
   there are none;
2. :meth:`ContactExchange.receive`: a contact's message of step k is kept (one of a later
   step, which a faster robot may send before this one has started it, is kept for that
   step); repeats, stale steps and the robot's own messages are ignored;
3. when every contact's message is in, the subclass uses them all at once, in robot-id
   order (:meth:`ContactExchange._complete`), so the result does not depend on the order
   the messages came in (what makes a ROS run equal the in-memory one);
4. :meth:`ContactExchange.tick`: a round without news; after ``timeout_ticks`` rounds the
   contacts not heard from are given up for the step (``stats["timeouts"]``) and the
   messages that did arrive are used.

Messages per robot per step: one per robot in reach, none otherwise.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Any

import numpy as np

from .base import Envelope, Exchange
from .radio import RangeRadio

#: Rounds without news before the contacts not heard from are given up for the step.
TIMEOUT_TICKS = 5


class ContactExchange(Exchange):
    """The step machinery of a radio-based exchange (see the module docstring).

    Subclasses set :attr:`MESSAGE` (the message type, with ``src`` and ``step``) and
    :attr:`NAME`, and implement :meth:`_message` and :meth:`_complete`.

    Parameters
    ----------
    robot_id : int
    radio : RangeRadio
        Who this robot reaches at a step.
    timeout_ticks : int
        Rounds without news before the missing contacts are given up for the step.
    """

    #: The message type this exchange sends and keeps.
    MESSAGE: type = object
    #: Its name in error messages.
    NAME = "exchange"

    def __init__(self, robot_id: int, radio: RangeRadio,
                 timeout_ticks: int = TIMEOUT_TICKS) -> None:
        self.robot_id = int(robot_id)
        self.radio = radio
        self.timeout_ticks = int(timeout_ticks)
        self.estimator: Any = None
        self._step = -1
        self._team: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._waiting: set[int] = set()
        self._got: dict[int, dict[int, Any]] = {}
        self._quiet = 0
        self._done = True
        #: The contacts of the current (last) step, ascending.
        self.contacts: np.ndarray = np.empty(0, dtype=np.int64)
        #: Counters: steps with a contact, messages sent, contacts given up on.
        self.stats: dict[str, int] = {"meetings": 0, "sent": 0, "timeouts": 0}

    # ----------------------------------------------------------------- membership
    def initialise(self, ids: np.ndarray, positions: np.ndarray) -> None:
        """Nothing to set up: the radio reads the team state of every step."""

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray, keep_dead: frozenset[int] = frozenset()) -> None:
        """The world's team state of ``step``: who is alive, and where (for the radio).

        The robots of ``keep_dead`` are out of reach as if dead.
        """
        ids = np.asarray(ids)
        alive = np.asarray(alive, dtype=bool)
        if keep_dead:
            alive = alive & ~np.isin(ids, np.fromiter(keep_dead, dtype=np.int64))
        self._team = (ids, np.asarray(positions, dtype=float), alive)

    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray) -> None:
        """Back in the team at ``step``: the robot's own state is kept."""
        self.observe_team(step, ids, positions, alive)

    # ---------------------------------------------------------------------- step
    def start_step(self, step: int, position: np.ndarray, power_weight: float,
                   z: np.ndarray) -> list[Envelope]:
        """Send this step's message to every robot in reach; done at once without any."""
        if self.estimator is None:
            raise RuntimeError(f"{self.NAME}: no estimator bound (Agent binds it)")
        if self._team is None:
            raise RuntimeError(f"{self.NAME}: no team state for the step")
        self._step = int(step)
        for old in [k for k in self._got if k < self._step]:
            del self._got[old]
        self.contacts = self.radio.contacts(self.robot_id, *self._team)
        self._waiting = set(self.contacts.tolist()) - set(self._got.get(self._step, {}))
        self._quiet = 0
        self._done = False
        if self.contacts.size:
            self.stats["meetings"] += 1
        self._begin(np.asarray(position, dtype=float).reshape(2))
        out = [Envelope(self.robot_id, int(c), self._message(int(c)))
               for c in self.contacts.tolist()]
        self.stats["sent"] += len(out)
        self._finish_if_complete()
        return out

    def receive(self, msg: Any) -> bool:
        """Keep a contact's message of this step (or of a later one, for that step)."""
        if not isinstance(msg, self.MESSAGE) or msg.step < self._step \
                or msg.src == self.robot_id:
            return False
        got = self._got.setdefault(int(msg.step), {})
        if msg.src in got:
            return False
        got[int(msg.src)] = msg
        if msg.step == self._step:
            self._waiting.discard(int(msg.src))
            self._quiet = 0
        return True

    def advance(self) -> list[Envelope]:
        """Use the messages once every contact's is in."""
        self._finish_if_complete()
        return []

    def tick(self) -> list[Envelope]:
        """A round without news; give up on silent contacts after ``timeout_ticks``."""
        if self._done:
            return []
        self._quiet += 1
        if self._quiet >= self.timeout_ticks:
            self.stats["timeouts"] += len(self._waiting)
            self._waiting.clear()
            self._finish_if_complete()
        return []

    def _finish_if_complete(self) -> None:
        if self._done or self._waiting:
            return
        contacts = set(self.contacts.tolist())
        got = {src: m for src, m in sorted(self._got.get(self._step, {}).items())
               if src in contacts}
        self._complete(got)
        self._done = True

    @property
    def done(self) -> bool:
        """Whether the step's exchange is done."""
        return self._done

    @property
    def step(self) -> int:
        """The current (or last) step; -1 before the first."""
        return self._step

    # --------------------------------------------------------------- subclasses
    def _begin(self, position: np.ndarray) -> None:
        """Start of a step, before the messages are built (the robot's position s_k [m])."""

    @abstractmethod
    def _message(self, contact: int) -> Any:
        """The message of this step to ``contact``."""

    @abstractmethod
    def _complete(self, got: dict[int, Any]) -> None:
        """Use the contacts' messages of the step (sender id -> message, ascending)."""
