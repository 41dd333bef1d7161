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
   came in (what makes the ROS run equal the in-memory one); under the labelled reading
   (``reward_union: label`` of ``shirsat_gmphd``) each set travels with its members' labels
   and the union is by label;
4. :meth:`tick`: a round without news; after ``timeout_ticks`` rounds the contacts not
   heard from are given up for this step (counted in ``stats["timeouts"]``) and the sets
   that did arrive are merged.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import registry
from ..params import ParamSpec
from ..scan import CDR_HEADER, CDR_POINT
from .contacts import TIMEOUT_TICKS, ContactExchange
from .radio import RangeRadio, SameNodeRadio

OPTIONS = (
    ParamSpec("radio", "same_node", "meet_merge: who hears whom: robots on the same grid node "
              "(Shirsat & Berman) or within radio_range metres", choices=("same_node",
                                                                          "range")),
    ParamSpec("radio_range", 50.0, "meet_merge: radio range C_R [m] (radio: range)", low=0.0),
)


@dataclass(frozen=True)
class RewardMsg:
    """Robot ``src``'s reward set M_k at step ``step``: positions (K, 2) [m].

    ``labels``: the members' labels (K,) under the union by label, empty otherwise.
    """

    src: int
    step: int
    points: np.ndarray
    labels: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))

    #: Its ``msg_defs`` type (for the engines' traffic counts).
    WIRE_TYPE = "RewardSet"

    def wire_size(self) -> int:
        """Estimated CDR payload size [bytes]: header, ids, an empty met list, the points.

        The labels (4 bytes each) are counted when there are some.
        """
        labels = 4 + 4 * len(self.labels) if len(self.labels) else 0
        return CDR_HEADER + 4 + 4 + 4 + 4 + CDR_POINT * len(self.points) + labels


class MeetMerge(ContactExchange):
    """One robot's side of meet-and-merge (see the module docstring).

    Parameters
    ----------
    robot_id : int
    radio : RangeRadio
        Who this robot reaches at a step.
    timeout_ticks : int
        Rounds without news before the missing contacts are given up for the step.
    """

    MESSAGE = RewardMsg
    NAME = "meet_merge"

    def __init__(self, robot_id: int, radio: RangeRadio,
                 timeout_ticks: int = TIMEOUT_TICKS) -> None:
        super().__init__(robot_id, radio, timeout_ticks)
        #: The robots whose sets were merged at the current (last) step, ascending.
        self.met: np.ndarray = np.empty(0, dtype=np.int64)
        self._points = np.empty((0, 2))
        self._labels = np.empty(0, dtype=np.int64)
        #: Whether the sets travel with labels (the estimator's union is by label).
        self.labelled = False

    def bind_estimator(self, estimator: Any) -> None:
        """The robot's estimator, whose reward set travels (``reward_set``, ``merge_rewards``)."""
        if not hasattr(estimator, "reward_set") or not hasattr(estimator, "merge_rewards"):
            raise ValueError("the meet_merge exchange needs an estimator with reward sets "
                             f"(reward_set, merge_rewards); {type(estimator).__name__} has none")
        self.estimator = estimator
        self.labelled = bool(getattr(estimator, "labelled", False))

    def _begin(self, position: np.ndarray) -> None:
        self.met = np.empty(0, dtype=np.int64)
        self._points = self.estimator.reward_set()
        if self.labelled:
            self._labels = self.estimator.reward_labels()

    def _message(self, contact: int) -> RewardMsg:
        return RewardMsg(self.robot_id, self._step, self._points, self._labels)

    def _complete(self, got: dict[int, RewardMsg]) -> None:
        others = {src: np.asarray(m.points, dtype=float).reshape(-1, 2)
                  for src, m in got.items()}
        if others and self.labelled:
            self.estimator.merge_rewards(others, {src: np.asarray(m.labels).reshape(-1)
                                                  for src, m in got.items()})
        elif others:
            self.estimator.merge_rewards(others)
        self.met = np.array(sorted(others), dtype=np.int64)


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
    wire="phd_swarm.nodes.faces.meet_merge:WIRE")
