"""Meet and merge: robots that meet exchange their reward sets and keep the union.

Registered as the ``meet_merge`` exchange. Shirsat & Berman (Sec. IV, eq. 6, Alg. 2-3): at
a renewal epoch, a step at which two or more robots occupy the same node, each sends its
reward set M_k (the targets it has extracted so far) to the others, and each replaces its
own by the union of all of them (:meth:`merge_rewards` of the estimator, which must provide
``reward_set``). A simulated radio (:mod:`.radio`, here :class:`~.radio.SameNodeRadio`;
``range`` for a radio of range C_R) decides who hears whom from the world's team state of
the step, so a robot sends one message per robot it meets and none otherwise.

One step k of robot r:

1. :meth:`start_step`: the robot's estimator has taken the scan of step k (so M_k includes
   X^_k, Alg. 1 line d); its contacts are the live robots the radio reaches at step k;
   it sends M_k to each (:class:`RewardMsg`) and the step is done at once if there are
   none;
2. :meth:`receive`: the contacts' sets of step k (a set of a later step, which a faster
   robot may send before this one has started it, is kept for that step);
3. when every contact's set is in, the estimator merges them all at once, in robot-id
   order, so every robot of the meeting ends with the same set whatever order the messages
   came in (what makes the ROS run equal the in-memory one);
4. :meth:`tick`: a round without news; after ``timeout_ticks`` rounds the contacts not
   heard from are given up for this step (counted in ``stats["timeouts"]``) and the sets
   that did arrive are merged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import registry
from ..params import ParamSpec
from ..scan import CDR_HEADER, CDR_POINT
from .base import Envelope, Exchange
from .radio import RangeRadio, SameNodeRadio

#: Rounds without news before the contacts not heard from are given up for the step.
TIMEOUT_TICKS = 5

OPTIONS = (
    ParamSpec("radio", "same_node", "meet_merge: who hears whom: robots on the same grid node "
              "(Shirsat & Berman) or within radio_range metres", choices=("same_node",
                                                                          "range")),
    ParamSpec("radio_range", 50.0, "meet_merge: radio range C_R [m] (radio: range)", low=0.0),
)


@dataclass(frozen=True)
class RewardMsg:
    """Robot ``src``'s reward set M_k at step ``step``: positions (K, 2) [m]."""

    src: int
    step: int
    points: np.ndarray

    #: Its ``msg_defs`` type (for the engines' traffic counts).
    WIRE_TYPE = "RewardSet"

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]: header, ids, an empty met list, the points."""
        return CDR_HEADER + 4 + 4 + 4 + 4 + CDR_POINT * len(self.points)


class MeetMerge(Exchange):
    """One robot's side of meet-and-merge (see the module docstring).

    Parameters
    ----------
    robot_id : int
    radio : RangeRadio
        Who this robot reaches at a step.
    timeout_ticks : int
        Rounds without news before the missing contacts are given up for the step.
    """

    def __init__(self, robot_id: int, radio: RangeRadio,
                 timeout_ticks: int = TIMEOUT_TICKS) -> None:
        self.robot_id = int(robot_id)
        self.radio = radio
        self.timeout_ticks = int(timeout_ticks)
        self.estimator: Any = None
        self._step = -1
        self._team: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._waiting: set[int] = set()
        self._got: dict[int, dict[int, np.ndarray]] = {}
        self._quiet = 0
        self._done = True
        #: The contacts of the current (last) step, ascending.
        self.contacts: np.ndarray = np.empty(0, dtype=np.int64)
        #: The robots whose sets were merged at the current (last) step, ascending.
        self.met: np.ndarray = np.empty(0, dtype=np.int64)
        #: Counters: meetings (steps with a contact), messages sent, timeouts.
        self.stats: dict[str, int] = {"meetings": 0, "sent": 0, "timeouts": 0}

    def bind_estimator(self, estimator: Any) -> None:
        """The robot's estimator, whose reward set travels (``reward_set``, ``merge_rewards``)."""
        if not hasattr(estimator, "reward_set") or not hasattr(estimator, "merge_rewards"):
            raise ValueError("the meet_merge exchange needs an estimator with reward sets "
                             f"(reward_set, merge_rewards); {type(estimator).__name__} has none")
        self.estimator = estimator

    # ----------------------------------------------------------------- membership
    def initialise(self, ids: np.ndarray, positions: np.ndarray) -> None:
        """Nothing to set up: the radio reads the team state of every step."""

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray) -> None:
        """The world's team state of ``step``: who is alive, and where (for the radio)."""
        self._team = (np.asarray(ids), np.asarray(positions, dtype=float),
                      np.asarray(alive, dtype=bool))

    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray) -> None:
        """Back in the team at ``step``: the reward set is the robot's own, kept."""
        self.observe_team(step, ids, positions, alive)

    # ---------------------------------------------------------------------- step
    def start_step(self, step: int, position: np.ndarray, power_weight: float,
                   z: np.ndarray) -> list[Envelope]:
        """Send M_k to the robots the radio reaches at ``step``; done at once without any."""
        if self.estimator is None:
            raise RuntimeError("meet_merge: no estimator bound (Agent binds it)")
        if self._team is None:
            raise RuntimeError("meet_merge: no team state for the step")
        self._step = int(step)
        for old in [k for k in self._got if k < self._step]:
            del self._got[old]
        self.contacts = self.radio.contacts(self.robot_id, *self._team)
        self._waiting = set(self.contacts.tolist()) - set(self._got.get(self._step, {}))
        self._quiet = 0
        self._done = False
        self.met = np.empty(0, dtype=np.int64)
        if self.contacts.size:
            self.stats["meetings"] += 1
        points = self.estimator.reward_set()
        out = [Envelope(self.robot_id, int(c), RewardMsg(self.robot_id, self._step, points))
               for c in self.contacts.tolist()]
        self.stats["sent"] += len(out)
        self._finish_if_complete()
        return out

    def receive(self, msg: Any) -> bool:
        """Keep a contact's set of this step (or of a later one, for that step)."""
        if not isinstance(msg, RewardMsg) or msg.step < self._step or msg.src == self.robot_id:
            return False
        got = self._got.setdefault(int(msg.step), {})
        if msg.src in got:
            return False
        got[int(msg.src)] = np.asarray(msg.points, dtype=float).reshape(-1, 2)
        if msg.step == self._step:
            self._waiting.discard(int(msg.src))
            self._quiet = 0
        return True

    def advance(self) -> list[Envelope]:
        """Merge once every contact's set is in."""
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
        mine = self._got.get(self._step, {})
        others = {src: pts for src, pts in mine.items() if src in set(self.contacts.tolist())}
        if others:
            self.estimator.merge_rewards(others)
        self.met = np.array(sorted(others), dtype=np.int64)
        self._done = True

    @property
    def done(self) -> bool:
        """Whether the step's merge is done."""
        return self._done

    @property
    def step(self) -> int:
        """The current (or last) step; -1 before the first."""
        return self._step


def _setup(scenario: Any, system: Any, timeout_ticks: int = TIMEOUT_TICKS,
           **runtime: Any) -> tuple[RangeRadio, int]:
    radio = (SameNodeRadio() if system.option("radio") == "same_node"
             else RangeRadio(float(system.option("radio_range"))))
    return radio, int(timeout_ticks)


registry.register(
    "exchange", "meet_merge",
    lambda setup, rid: MeetMerge(rid, setup[0], setup[1]), setup=_setup, options=OPTIONS,
    description="Meet and merge: robots the radio joins (same grid node, or range C_R) "
                "exchange their reward sets and keep the union (Shirsat & Berman eq. 6, "
                "Alg. 2-3).",
    provides=("meetings",), requires=("reward_set",),
    wire="phd_swarm.nodes.meet_merge_wire:WIRE")
