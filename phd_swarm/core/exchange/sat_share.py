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
(:meth:`~phd_swarm.core.estimators.papaioannou.estimator.PapaioannouEstimator.merge_search`); the
controller reads what came in through :class:`SatView` (its ``view`` hook) and builds the
joint plan of Alg. 1 with the agents whose maps it received.

The step machinery (one message per contact, merged in id order once all are in, a timeout
for silent contacts) is :class:`.contacts.ContactExchange`'s. Messages per agent per step:
one per agent in range.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import registry
from ..params import ParamSpec
from ..scan import CDR_HEADER, CDR_POINT
from .contacts import TIMEOUT_TICKS, ContactExchange
from .radio import RangeRadio

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


class SatShare(ContactExchange):
    """One agent's side of the exchange (see the module docstring).

    Parameters
    ----------
    robot_id : int
    radio : RangeRadio
    timeout_ticks : int
    """

    MESSAGE = SatMsg
    NAME = "sat_share"

    def __init__(self, robot_id: int, radio: RangeRadio,
                 timeout_ticks: int = TIMEOUT_TICKS) -> None:
        super().__init__(robot_id, radio, timeout_ticks)
        self.controller: Any = None
        self._members: set[int] = set()
        self._state: tuple[np.ndarray, bool, np.ndarray, tuple[int, ...]] | None = None
        self.view = SatView(-1)
        self.stats["maps_sent"] = 0

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

    def _begin(self, position: np.ndarray) -> None:
        self.view = SatView(self._step)
        members = tuple(sorted(getattr(self.controller, "plan_members", ()) or ()))
        self._members = set(members)
        predicted = np.asarray(self.estimator.predicted_states(), dtype=float)[:, :2]
        self._state = (position.copy(), bool(getattr(self.controller, "tracking", False)),
                       predicted, members)

    def _message(self, contact: int) -> SatMsg:
        position, tracking, predicted, members = self._state
        share = contact not in self._members                        # Sec. V-B d
        self.stats["maps_sent"] += int(share)
        values = self.estimator.search.copy() if share else np.empty(0)
        return SatMsg(self.robot_id, self._step, position, tracking, predicted, values,
                      members)

    def _complete(self, got: dict[int, SatMsg]) -> None:
        maps = []
        for src, m in got.items():
            # A pair exchanges maps only if neither is in a joint plan with the other: the
            # sender checked its side, this checks the receiver's (Sec. V-B d).
            if m.search.size and src not in self._members:
                self.estimator.merge_search(m.search)
                maps.append(src)
        self.view = SatView(self._step, got, tuple(maps))


def _setup(scenario: Any, system: Any, timeout_ticks: int = TIMEOUT_TICKS,
           **runtime: Any) -> tuple[RangeRadio, int]:
    return RangeRadio(float(system.option("radio_range"))), int(timeout_ticks)


registry.register(
    "exchange", "sat_share",
    lambda setup, rid: SatShare(rid, setup[0], setup[1]), setup=_setup, options=OPTIONS,
    description="Agents within C_R exchange positions, modes, predicted targets and (by the "
                "event rule) search maps, max-merged (Papaioannou et al. Sec. V-B c-d, V-C b).",
    provides=("sat_view",), requires=("search_map",),
    view=lambda exchange: exchange.view, wire="phd_swarm.nodes.faces.sat_share:WIRE")
