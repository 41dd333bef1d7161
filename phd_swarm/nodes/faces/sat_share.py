"""The ROS face of the ``sat_share`` exchange: one inbox kind, ``sat``.

An agent's state of a step (:class:`phd_swarm.core.exchange.sat_share.SatMsg`: position,
mode, predicted targets, search map by the event rule, joint-plan members) travels to each
agent in radio range as a ``phd_swarm_msgs/SatState`` of kind ``sat`` in its inbox message;
the same type carries the agent's own state of the step on ``sat_state``
(:mod:`.search_and_track`).
"""

from __future__ import annotations

import numpy as np

from phd_swarm.core.exchange.sat_share import SatMsg
from phd_swarm.nodes.convert import InvalidMessage, f64, header, point_xy, points, u32, values, xy
from phd_swarm.nodes.wire import Wire
from phd_swarm_msgs.msg import SatState

#: Most predicted targets and search-map nodes a message may hold (bigger ones are refused).
MAX_PREDICTED = 10_000
MAX_NODES = 1_000_000


def sat_state(msg: SatMsg, dt: float, frame_id: str) -> SatState:
    """A ``SatState`` of ``msg`` (inbox kind ``sat``, and the agent's own sat_state)."""
    return SatState(header=header(msg.step, dt, frame_id), source_id=int(msg.src),
                    step=int(msg.step), position=points(msg.position)[0],
                    tracking=bool(msg.tracking), predicted=points(msg.predicted),
                    search=f64(msg.search), plan_members=u32(np.asarray(msg.plan_members,
                                                                        dtype=np.int64)))


def _from_ros(msg: SatState, grid, max_measurements: int) -> SatMsg:
    if len(msg.predicted) > MAX_PREDICTED:
        raise InvalidMessage(f"predicted: {len(msg.predicted)} targets, more than "
                             f"{MAX_PREDICTED}")
    if len(msg.search) > MAX_NODES:
        raise InvalidMessage(f"search: {len(msg.search)} values, more than {MAX_NODES}")
    search = values(msg.search, "search")
    if search.size and (search.min() < 0.0 or search.max() > 1.0):
        raise InvalidMessage("search: values must lie in [0, 1]")
    return SatMsg(int(msg.source_id), int(msg.step), point_xy(msg.position, "position"),
                  bool(msg.tracking), xy(msg.predicted, "predicted"), search,
                  tuple(int(i) for i in msg.plan_members))


WIRE = Wire(types={"sat": SatState}, kind=lambda msg: "sat", to_ros=sat_state,
            from_ros=_from_ros, sender=lambda msg: msg.src, addressee=lambda msg: None)
