"""The wire format of the ``voronoi_phd`` exchange (Dames Alg. 1-2): six inbox kinds.

States, cells, measurement sets, eta partial sums and totals, and bin transfers (ownership
and phantom), as ``phd_swarm_msgs`` types; conversions in :mod:`phd_swarm.nodes.convert`,
straight between core messages and CDR bytes on the robots' inbox path.
"""

from __future__ import annotations

from phd_swarm.core.exchange.voronoi_phd.messages import (
    CellMsg,
    EtaPartialMsg,
    EtaTotalMsg,
    Message,
    StateMsg,
    TransferMsg,
    sender_of,
)
from phd_swarm.core.grid import Grid
from phd_swarm.core.scan import Scan
from phd_swarm.nodes import convert
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
    return convert.decode(TYPES[kind], data, grid, max_measurements)


def _addressee(msg: Message) -> int | None:
    if isinstance(msg, TransferMsg):
        return msg.to_id
    if isinstance(msg, EtaPartialMsg):
        return msg.active_id
    return None


WIRE = Wire(types=TYPES, kind=lambda msg: KINDS[type(msg)], to_ros=convert.to_ros,
            from_ros=convert.from_ros, sender=sender_of, addressee=_addressee,
            encode=convert.encode, decode=_decode)
