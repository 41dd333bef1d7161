"""The ``voronoi_phd`` exchange's messages as ``phd_swarm_msgs`` types and CDR bytes.

States, cells, measurement sets, eta partial sums and totals, and bin transfers (ownership
and phantom; Dames Alg. 1-2, with Chen's cumulative layer) go straight between core values
and their CDR bytes through :mod:`phd_swarm.nodes.cdr` (:func:`encode`, :func:`decode`),
without ROS message objects: the robots' hot path. One function builds a message's fields
(:func:`to_fields`) and one checks them (:func:`from_fields`, raising
:class:`~phd_swarm.nodes.convert.InvalidMessage` naming the field); :func:`to_ros` and
:func:`from_ros` go through the same two, by way of the CDR. The wire
(:mod:`phd_swarm.nodes.faces.voronoi_phd`) is made of these.
"""

from __future__ import annotations

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message

from phd_swarm.core.exchange.voronoi_phd.messages import (
    CellMsg,
    EtaPartialMsg,
    EtaTotalMsg,
    Message,
    StateMsg,
    TransferKind,
    TransferMsg,
)
from phd_swarm.core.geometry.grid import Grid
from phd_swarm.core.scan import Scan
from phd_swarm.nodes import cdr
from phd_swarm.nodes.convert import (
    InvalidMessage,
    field_point,
    field_points,
    finite,
    scan_fields,
    scan_from_fields,
    stamp_fields,
    values,
)
from phd_swarm_msgs.msg import (
    CellPolygon,
    EtaPartial,
    EtaTotal,
    MeasurementSet,
    ParticleTransfer,
    RobotState,
)


def to_fields(msg: Message, dt: float, frame_id: str) -> tuple[type, dict]:
    """Core protocol message -> its ``phd_swarm_msgs`` type and fields (:mod:`.cdr` values)."""
    h = {"stamp": stamp_fields(msg.step, dt), "frame_id": frame_id}
    if isinstance(msg, StateMsg):
        return RobotState, {"header": h, "robot_id": msg.robot_id, "step": msg.step,
                            "position": msg.position[:2], "power_weight": msg.power_weight,
                            "cell_radius": msg.cell_radius}
    if isinstance(msg, CellMsg):
        return CellPolygon, {
            "header": h, "robot_id": msg.robot_id, "step": msg.step,
            "generator": msg.generator[:2], "power_weight": msg.power_weight,
            "vertices": np.asarray(msg.vertices, float).reshape(-1, 2),
            "neighbour_ids": msg.neighbour_ids, "contact_ids": msg.contact_ids,
            "contact_positions": np.asarray(msg.contact_positions, float).reshape(-1, 2),
            "contact_power_weights": msg.contact_power_weights,
            "contact_cell_radii": msg.contact_cell_radii}
    if isinstance(msg, Scan):
        return MeasurementSet, scan_fields(msg, dt, frame_id)
    if isinstance(msg, EtaPartialMsg):
        return EtaPartial, {"header": h, "sender_id": msg.sender_id,
                            "active_id": msg.active_id, "step": msg.step,
                            "values": msg.values}
    if isinstance(msg, EtaTotalMsg):
        return EtaTotal, {"header": h, "active_id": msg.active_id, "step": msg.step,
                          "values": msg.values}
    if isinstance(msg, TransferMsg):
        out = {"header": h, "from_id": msg.from_id, "to_id": msg.to_id, "step": msg.step,
               "kind": int(msg.kind), "bin_indices": msg.bins, "weights": msg.weights,
               "radius_ids": msg.radius_ids, "cell_radii": msg.cell_radii}
        if msg.alpha is not None:
            out["alpha"], out["observation_count"] = msg.alpha, msg.count
        return ParticleTransfer, out
    raise TypeError(f"not a protocol message: {type(msg).__name__}")


def encode(msg: Message, dt: float, frame_id: str) -> bytes:
    """Core protocol message -> the CDR of its ``phd_swarm_msgs`` message."""
    return cdr.encode(*to_fields(msg, dt, frame_id))


def to_ros(msg: Message, dt: float, frame_id: str):
    """Core protocol message -> its ``phd_swarm_msgs`` message."""
    typ, fields = to_fields(msg, dt, frame_id)
    return deserialize_message(cdr.encode(typ, fields), typ)


def decode(typ: type, data: bytes, grid: Grid, max_measurements: int) -> Message:
    """The CDR of a ``typ`` protocol message -> core message, checking its contents.

    Raises
    ------
    InvalidMessage
        Bytes that do not decode as ``typ`` (:class:`.cdr.CdrError`), or the contents
        :func:`from_fields` refuses.
    """
    try:
        fields = cdr.decode(typ, data)
    except cdr.CdrError as exc:
        raise InvalidMessage(f"does not deserialise: {exc}") from None
    return from_fields(typ, fields, grid, max_measurements)


def from_ros(msg, grid: Grid, max_measurements: int) -> Message:
    """``phd_swarm_msgs`` protocol message -> core message, checking its contents.

    Raises
    ------
    InvalidMessage
        As :func:`from_fields`, or ``msg`` is not a protocol message.
    """
    typ = type(msg)
    if typ not in _FROM_FIELDS:
        raise InvalidMessage(f"not a protocol message: {typ.__name__}")
    return from_fields(typ, cdr.decode(typ, serialize_message(msg)), grid, max_measurements)


def from_fields(typ: type, fields: dict, grid: Grid, max_measurements: int) -> Message:
    """Fields of a ``typ`` protocol message (:func:`.cdr.decode`) -> core message, checked.

    The core message owns its arrays (copies, never views of the fields).

    Raises
    ------
    InvalidMessage
        Non-finite numbers, negative weights or masses, mismatched lengths, bin indices
        off the grid, more than ``max_measurements`` measurements.
    """
    return _FROM_FIELDS[typ](fields, grid, max_measurements)


def _state(f: dict, grid: Grid, max_measurements: int) -> StateMsg:
    return StateMsg(f["robot_id"], f["step"], field_point(f["position"], "position"),
                    finite(f["power_weight"], "power_weight", 0.0),
                    finite(f["cell_radius"], "cell_radius", 0.0))


def _cell(f: dict, grid: Grid, max_measurements: int) -> CellMsg:
    n = len(f["contact_ids"])
    positions, rho, radii = (f["contact_positions"], f["contact_power_weights"],
                             f["contact_cell_radii"])
    if not len(positions) == len(rho) == len(radii) == n:
        raise InvalidMessage(f"contact table: {n} ids but {len(positions)} positions, "
                             f"{len(rho)} power weights, {len(radii)} radii")
    rho = values(rho, "contact_power_weights")
    radii = values(radii, "contact_cell_radii")
    if (rho < 0).any() or (radii < 0).any():
        raise InvalidMessage("contact table: negative power weight or cell radius")
    return CellMsg(f["robot_id"], f["step"], field_point(f["generator"], "generator"),
                   finite(f["power_weight"], "power_weight", 0.0),
                   field_points(f["vertices"], "vertices"), tuple(f["neighbour_ids"].tolist()),
                   tuple(f["contact_ids"].tolist()),
                   field_points(positions, "contact_positions"), rho, radii)


def _scan(f: dict, grid: Grid | None, max_measurements: int) -> Scan:
    return scan_from_fields(f, max_measurements)


def _eta_partial(f: dict, grid: Grid, max_measurements: int) -> EtaPartialMsg:
    return EtaPartialMsg(f["sender_id"], f["active_id"], f["step"],
                         _eta_values(f["values"], max_measurements))


def _eta_total(f: dict, grid: Grid, max_measurements: int) -> EtaTotalMsg:
    return EtaTotalMsg(f["active_id"], f["step"], _eta_values(f["values"], max_measurements))


def _transfer(f: dict, grid: Grid, max_measurements: int) -> TransferMsg:
    kind = f["kind"]
    if kind not in (ParticleTransfer.KIND_OWNERSHIP, ParticleTransfer.KIND_PHANTOM):
        raise InvalidMessage(f"kind: unknown transfer kind {kind}")
    bins = f["bin_indices"].astype(np.int64)
    w = values(f["weights"], "weights")
    if len(w) != len(bins):
        raise InvalidMessage(f"{len(bins)} bin indices but {len(w)} weights")
    if (w < 0).any():
        raise InvalidMessage("weights: negative PHD mass")
    if len(bins) and bins.max() >= grid.size:
        raise InvalidMessage(f"bin_indices: index {int(bins.max())} is off the grid of "
                             f"{grid.size} bins")
    alpha = count = None
    if len(f["alpha"]) or len(f["observation_count"]):
        alpha = values(f["alpha"], "alpha")
        count = values(f["observation_count"], "observation_count")
        if len(alpha) != len(bins) or len(count) != len(bins):
            raise InvalidMessage(f"{len(bins)} bins but {len(alpha)} alpha and "
                                 f"{len(count)} observation counts")
        if (alpha < 0).any() or (count < 0).any():
            raise InvalidMessage("alpha / observation_count: negative value")
    radius_ids = tuple(f["radius_ids"].tolist())
    radii = values(f["cell_radii"], "cell_radii")
    if len(radii) != len(radius_ids):
        raise InvalidMessage(f"{len(radius_ids)} radius ids but {len(radii)} cell radii")
    if (radii < 0).any():
        raise InvalidMessage("cell_radii: negative radius")
    return TransferMsg(f["from_id"], f["to_id"], f["step"], TransferKind(kind), bins, w,
                       alpha, count, radius_ids, radii)


_FROM_FIELDS = {RobotState: _state, CellPolygon: _cell, MeasurementSet: _scan,
                EtaPartial: _eta_partial, EtaTotal: _eta_total, ParticleTransfer: _transfer}


def _eta_values(seq, max_measurements: int) -> np.ndarray:
    if len(seq) > max_measurements:
        raise InvalidMessage(f"values: {len(seq)} values, more than max_measurements = "
                             f"{max_measurements}")
    v = values(seq, "values")
    if (v < 0).any():
        raise InvalidMessage("values: negative normalisation sum")
    return v
