"""Papaioannou et al.'s opportunistic exchange: search maps, positions, modes and predictions.

Registered as the ``sat_share`` exchange. Agents within the radio range C_R
(:class:`~.radio.RangeRadio`, Sec. IV-C) send each other, once per step, a
:class:`SatMsg`: their position, whether they are tracking, their predicted target
positions X^_{k+1|k} (for the tracking-overlap test of Sec. V-C b), and their search values
(Sec. V-B c) when the event rule of Sec. V-B d allows it: an agent shares its map with a
contact only if it is not executing a joint search plan, or if the contact is not one of
that plan's agents. Exchanging is mutual ("they exchange their search densities and compute
a joint search plan"), so a pair exchanges only if the rule allows it on both sides: the
sender leaves its map out for an agent of its plan, the receiver ignores the map of an
agent of its own plan. Every map taken is max-merged into the estimator's
(:meth:`~phd_swarm.core.estimators.papaioannou.PapaioannouEstimator.merge_search`); the
controller reads what came in through :class:`SatView` (``extras["view"]``) and builds the
joint plan of Alg. 1 with the agents whose maps it received.

One step k of agent r: :meth:`start_step` sends to the contacts of step k (the step is done
at once without any); :meth:`receive` keeps a contact's message of step k (or of a later
step, for that step); when every contact's message is in, the maps are merged in id order
and the step is done; :meth:`tick` gives up on silent contacts after ``timeout_ticks``
rounds. Messages per agent per step: one per agent in range.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import registry
from ..params import ParamSpec
from ..scan import CDR_HEADER, CDR_POINT
from .base import Envelope, Exchange
from .radio import RangeRadio

#: Rounds without news before the contacts not heard from are given up for the step.
TIMEOUT_TICKS = 5

OPTIONS = (
    ParamSpec("radio_range", 50.0, "sat_share: communication range C_R [m] (Sec. VI-A: 50; "
              "Fig. 2-3: 10 and 50, Fig. 5: 20 and 40)", low=0.0),
)


@dataclass(frozen=True)
class SatMsg:
    """What agent ``src`` tells an agent in range at step ``step``.

    Attributes
    ----------
    src, step : int
    position : np.ndarray, shape (2,)
        s_k [m].
    tracking : bool
        Whether ``src`` is in tracking mode.
    predicted : np.ndarray, shape (K, 2)
        X^_{k+1|k} positions [m].
    search : np.ndarray, shape (S,) or (0,)
        Search values p_v, or empty when the event rule keeps the map back.
    plan_members : tuple of int
        The agents of ``src``'s current joint plan (itself included).
    """

    src: int
    step: int
    position: np.ndarray
    tracking: bool
    predicted: np.ndarray
    search: np.ndarray
    plan_members: tuple[int, ...] = ()

    #: Its ``msg_defs`` type (for the engines' traffic counts).
    WIRE_TYPE = "SatState"

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]."""
        return (CDR_HEADER + 4 + 4 + CDR_POINT + 4 + 4 + CDR_POINT * len(self.predicted)
                + 4 + 8 * self.search.size + 4 + 4 * len(self.plan_members))


@dataclass
class SatView:
    """What the controller learns from the exchange at a step.

    Attributes
    ----------
    step : int
    messages : dict of int to SatMsg
        The contacts' messages of the step, by sender id (those that arrived).
    maps_from : tuple of int
        The senders whose search maps came in (merged into the estimator), ascending.
    """

    step: int
    messages: dict[int, SatMsg] = field(default_factory=dict)
    maps_from: tuple[int, ...] = ()


class SatShare(Exchange):
    """One agent's side of the exchange (see the module docstring).

    Parameters
    ----------
    robot_id : int
    radio : RangeRadio
    timeout_ticks : int
    """

    def __init__(self, robot_id: int, radio: RangeRadio,
                 timeout_ticks: int = TIMEOUT_TICKS) -> None:
        self.robot_id = int(robot_id)
        self.radio = radio
        self.timeout_ticks = int(timeout_ticks)
        self.estimator: Any = None
        self.controller: Any = None
        self._step = -1
        self._team: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._waiting: set[int] = set()
        self._got: dict[int, dict[int, SatMsg]] = {}
        self._quiet = 0
        self._done = True
        self._members: set[int] = set()
        self.contacts: np.ndarray = np.empty(0, dtype=np.int64)
        self.view = SatView(-1)
        self.stats: dict[str, int] = {"contacts": 0, "sent": 0, "maps_sent": 0, "timeouts": 0}

    def bind_estimator(self, estimator: Any) -> None:
        """The agent's estimator: its search values travel and take the merged maps."""
        for attr in ("search", "merge_search", "predicted_states"):
            if not hasattr(estimator, attr):
                raise ValueError(f"the sat_share exchange needs an estimator with a search map "
                                 f"and predicted states; {type(estimator).__name__} has no "
                                 f"{attr}")
        self.estimator = estimator

    def bind_controller(self, controller: Any) -> None:
        """The agent's controller: its mode and joint-plan members travel."""
        self.controller = controller

    # ----------------------------------------------------------------- membership
    def initialise(self, ids: np.ndarray, positions: np.ndarray) -> None:
        """Nothing to set up: the radio reads the team state of every step."""

    def observe_team(self, step: int, ids: np.ndarray, positions: np.ndarray,
                     alive: np.ndarray) -> None:
        """The world's team state of ``step`` (for the radio)."""
        self._team = (np.asarray(ids), np.asarray(positions, dtype=float),
                      np.asarray(alive, dtype=bool))

    def rejoin(self, step: int, ids: np.ndarray, positions: np.ndarray,
               alive: np.ndarray) -> None:
        """Back in the team at ``step``."""
        self.observe_team(step, ids, positions, alive)

    # ---------------------------------------------------------------------- step
    def start_step(self, step: int, position: np.ndarray, power_weight: float,
                   z: np.ndarray) -> list[Envelope]:
        """Send this step's message to every agent in range; done at once without any."""
        if self.estimator is None:
            raise RuntimeError("sat_share: no estimator bound (Agent binds it)")
        if self._team is None:
            raise RuntimeError("sat_share: no team state for the step")
        self._step = int(step)
        for old in [k for k in self._got if k < self._step]:
            del self._got[old]
        self.contacts = self.radio.contacts(self.robot_id, *self._team)
        self._waiting = set(self.contacts.tolist()) - set(self._got.get(self._step, {}))
        self._quiet = 0
        self._done = False
        self.view = SatView(self._step)
        if self.contacts.size:
            self.stats["contacts"] += 1
        tracking = bool(getattr(self.controller, "tracking", False))
        members = tuple(sorted(getattr(self.controller, "plan_members", ()) or ()))
        self._members = set(members)
        predicted = np.asarray(self.estimator.predicted_states(), dtype=float)[:, :2]
        pos = np.asarray(position, dtype=float).reshape(2).copy()
        out = []
        for c in self.contacts.tolist():
            share = c not in self._members                          # Sec. V-B d
            values = self.estimator.search.copy() if share else np.empty(0)
            out.append(Envelope(self.robot_id, int(c), SatMsg(
                self.robot_id, self._step, pos, tracking, predicted, values, members)))
            self.stats["maps_sent"] += int(share)
        self.stats["sent"] += len(out)
        self._finish_if_complete()
        return out

    def receive(self, msg: Any) -> bool:
        """Keep a contact's message of this step (or of a later one, for that step)."""
        if not isinstance(msg, SatMsg) or msg.step < self._step or msg.src == self.robot_id:
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
        """Merge once every contact's message is in."""
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
        mine = {src: m for src, m in sorted(self._got.get(self._step, {}).items())
                if src in contacts}
        maps = []
        for src, m in mine.items():
            # A pair exchanges maps only if neither is in a joint plan with the other: the
            # sender checked its side, this checks the receiver's (Sec. V-B d).
            if m.search.size and src not in self._members:
                self.estimator.merge_search(m.search)
                maps.append(src)
        self.view = SatView(self._step, mine, tuple(maps))
        self._done = True

    @property
    def done(self) -> bool:
        """Whether the step's exchange is done."""
        return self._done

    @property
    def step(self) -> int:
        """The current (or last) step; -1 before the first."""
        return self._step


def _setup(scenario: Any, system: Any, timeout_ticks: int = TIMEOUT_TICKS,
           **runtime: Any) -> tuple[RangeRadio, int]:
    return RangeRadio(float(system.option("radio_range"))), int(timeout_ticks)


registry.register(
    "exchange", "sat_share",
    lambda setup, rid: SatShare(rid, setup[0], setup[1]), setup=_setup, options=OPTIONS,
    description="Agents within C_R exchange positions, modes, predicted targets and (by the "
                "event rule) search maps, max-merged (Papaioannou et al. Sec. V-B c-d, V-C b).",
    provides=("sat_view",), requires=("search_map",),
    view=lambda exchange: exchange.view)
