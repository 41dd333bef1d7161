"""The ROS face of the ``voronoi_phd`` exchange (Dames Alg. 1-2): six inbox kinds, a cell.

States, cells, measurement sets, eta partial sums and totals, and bin transfers (ownership
and phantom), as ``phd_swarm_msgs`` types; conversions in :mod:`.voronoi_codec`,
straight between core messages and CDR bytes on the robots' inbox path (:data:`WIRE`).
Each robot also publishes its own cell of the step on ``cell`` (:data:`CELL`).
"""

from __future__ import annotations

from geometry_msgs.msg import Point

from phd_swarm.core.exchange.voronoi_phd.messages import (
    CellMsg,
    EtaPartialMsg,
    EtaTotalMsg,
    Message,
    StateMsg,
    TransferMsg,
    sender_of,
)
from phd_swarm.core.geometry.grid import Grid
from phd_swarm.core.scan import Scan
from phd_swarm.nodes import convert
from phd_swarm.nodes.face import Face, Step
from phd_swarm.nodes.faces import voronoi_codec as codec
from phd_swarm.nodes.wire import Wire
from phd_swarm_msgs.msg import (
    CellPolygon,
    EtaPartial,
    EtaTotal,
    MeasurementSet,
    ParticleTransfer,
    RobotState,
)

#: Inbox kind of each core message type.
KINDS = {StateMsg: "state", CellMsg: "cell", Scan: "measurements",
         EtaPartialMsg: "eta_partial", EtaTotalMsg: "eta_total", TransferMsg: "particles"}

#: ROS type of each inbox kind.
TYPES = {"state": RobotState, "cell": CellPolygon, "measurements": MeasurementSet,
         "eta_partial": EtaPartial, "eta_total": EtaTotal, "particles": ParticleTransfer}


def _decode(kind: str, data: bytes, grid: Grid, max_measurements: int) -> Message:
    return codec.decode(TYPES[kind], data, grid, max_measurements)


def _addressee(msg: Message) -> int | None:
    if isinstance(msg, TransferMsg):
        return msg.to_id
    if isinstance(msg, EtaPartialMsg):
        return msg.active_id
    return None


WIRE = Wire(types=TYPES, kind=lambda msg: KINDS[type(msg)], to_ros=codec.to_ros,
            from_ros=codec.from_ros, sender=sender_of, addressee=_addressee,
            encode=codec.encode, decode=_decode)


def _cell(step: Step, memo: dict) -> CellPolygon:
    """The robot's own cell of the step (Dames Alg. 1), its power weight and neighbours."""
    ex, position = step.agent.exchange, step.agent.position
    return CellPolygon(header=step.header(), robot_id=step.robot_id, step=step.k,
                       generator=Point(x=float(position[0]), y=float(position[1])),
                       power_weight=float(step.decision.power_weight),
                       vertices=convert.points(ex.cell), neighbour_ids=convert.u32(ex.neighbours))


#: Output ``cell``: the robot's Voronoi or power cell, for observers.
CELL = Face(CellPolygon, _cell)
