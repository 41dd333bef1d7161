"""Conversions between core values and ROS messages, with the checks of incoming data.

The only module that knows both :mod:`phd_swarm.core.exchange.voronoi_phd.messages` and
``phd_swarm_msgs``. ``from_ros`` functions check what a message *is* (finite numbers,
consistent lengths, indices on the grid, sizes within bounds) and raise
:class:`InvalidMessage` naming the field; whether the message is *welcome* (known sender,
addressed here, step in range) is for the receiving node to decide.

Protocol messages (the ``voronoi_phd`` exchange's inbox kinds) go straight between core
values and their CDR bytes through :mod:`phd_swarm.nodes.cdr` (:func:`encode`,
:func:`decode`), without ROS message objects: the robots' hot path. One function builds a
message's fields (:func:`to_fields`) and one checks them (:func:`from_fields`);
:func:`to_ros` and :func:`from_ros` go through the same two, by way of the CDR.

Arrays of other messages travel as ``array.array`` built from the numpy buffer, which
rosidl accepts without checking element by element (fast for density grids).
"""

from __future__ import annotations

import array
import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Header

from phd_swarm.core.exchange.voronoi_phd.messages import (
    CellMsg,
    EtaPartialMsg,
    EtaTotalMsg,
    Message,
    StateMsg,
    TransferKind,
    TransferMsg,
)
from phd_swarm.core.grid import Grid
from phd_swarm.core.scan import Scan
from phd_swarm.nodes import cdr
from phd_swarm_msgs.msg import (
    CellPolygon,
    DensityGrid,
    EtaPartial,
    EtaTotal,
    MeasurementSet,
    ParticleTransfer,
    RobotState,
    TargetSet,
)

#: ``owner_id`` / ``source_id`` of team-wide grids and sets, and of ground truth.
TEAM_ID = 0xFFFFFFFF


class InvalidMessage(ValueError):
    """A message that cannot be right: the text names the field and the problem."""


# ------------------------------------------------------------------------ primitives
def stamp_fields(step: int, dt: float) -> dict[str, int]:
    """Sim time of step ``step`` as ``builtin_interfaces/Time`` fields (:mod:`.cdr`).

    Exact for dt in whole nanoseconds.
    """
    ns = int(step) * round(dt * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def stamp(step: int, dt: float) -> Time:
    """Sim time of step ``step`` as a ROS time (exact for dt in whole nanoseconds)."""
    return Time(**stamp_fields(step, dt))


def header(step: int, dt: float, frame_id: str) -> Header:
    """Header stamped with the sim time of ``step`` in frame ``frame_id``."""
    return Header(stamp=stamp(step, dt), frame_id=frame_id)


def f64(values: np.ndarray) -> array.array:
    """float64 numpy array -> ``array('d')`` for a ``float64[]`` field."""
    return array.array("d", np.ascontiguousarray(values, dtype=np.float64).tobytes())


def u32(values: np.ndarray) -> array.array:
    """Integer array -> ``array('I')`` for a ``uint32[]`` field."""
    return array.array("I", np.ascontiguousarray(values, dtype=np.uint32).tobytes())


def points(xy: np.ndarray) -> list[Point]:
    """(N, 2) positions -> ``geometry_msgs/Point`` list (z = 0)."""
    return [Point(x=float(x), y=float(y)) for x, y in np.asarray(xy, float).reshape(-1, 2)]


def xy(pts: list[Point], field: str = "points") -> np.ndarray:
    """``geometry_msgs/Point`` list -> (N, 2) array; InvalidMessage if not finite."""
    return _finite_xy(np.array([(p.x, p.y) for p in pts], dtype=float).reshape(-1, 2), field)


def _finite_xy(out: np.ndarray, field: str) -> np.ndarray:
    if not np.isfinite(out).all():
        raise InvalidMessage(f"{field}: non-finite coordinate")
    return out


def _rows_xy(points3: np.ndarray, field: str) -> np.ndarray:
    """Decoded points (N, 3) -> own (N, 2) copy; InvalidMessage if not finite."""
    return _finite_xy(np.array(points3[:, :2]), field)


def point_xy(p: Point, field: str) -> np.ndarray:
    """One ``Point`` -> (2,) array; InvalidMessage if not finite."""
    return _finite_point(p.x, p.y, field)


def _finite_point(x: float, y: float, field: str) -> np.ndarray:
    if not (math.isfinite(x) and math.isfinite(y)):
        raise InvalidMessage(f"{field}: non-finite coordinate ({x}, {y})")
    return np.array([x, y])


def _point_xy(point3: np.ndarray, field: str) -> np.ndarray:
    """A decoded point (3,) -> (2,) array; InvalidMessage if not finite."""
    x, y = point3[:2].tolist()
    return _finite_point(x, y, field)


def values(seq, field: str) -> np.ndarray:
    """``float64[]`` -> array; InvalidMessage if not finite."""
    out = np.array(seq, dtype=float)
    if not np.isfinite(out).all():
        raise InvalidMessage(f"{field}: non-finite value")
    return out


def finite(value: float, field: str, low: float | None = None) -> float:
    """``value`` as a float; InvalidMessage naming ``field`` unless finite (and >= ``low``)."""
    if not math.isfinite(value) or (low is not None and value < low):
        raise InvalidMessage(f"{field}: {value!r} is not a finite number"
                             + ("" if low is None else f" >= {low}"))
    return float(value)


def pose_stamped(q: np.ndarray, step: int, dt: float, frame_id: str) -> PoseStamped:
    """A position as a ``PoseStamped`` (identity orientation)."""
    return PoseStamped(header=header(step, dt, frame_id),
                       pose=Pose(position=Point(x=float(q[0]), y=float(q[1]))))


# ------------------------------------------------------------------ protocol messages
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
        return MeasurementSet, {"header": h, "robot_id": msg.robot_id, "step": msg.step,
                                "sensor_position": msg.sensor, "measurements": msg.z}
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
    return StateMsg(f["robot_id"], f["step"], _point_xy(f["position"], "position"),
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
    return CellMsg(f["robot_id"], f["step"], _point_xy(f["generator"], "generator"),
                   finite(f["power_weight"], "power_weight", 0.0),
                   _rows_xy(f["vertices"], "vertices"), tuple(f["neighbour_ids"].tolist()),
                   tuple(f["contact_ids"].tolist()),
                   _rows_xy(positions, "contact_positions"), rho, radii)


def _scan(f: dict, grid: Grid | None, max_measurements: int) -> Scan:
    z = f["measurements"]
    if len(z) > max_measurements:
        raise InvalidMessage(f"measurements: {len(z)} measurements, more than "
                             f"max_measurements = {max_measurements}")
    return Scan(f["robot_id"], f["step"], _point_xy(f["sensor_position"], "sensor_position"),
                _rows_xy(z, "measurements"))


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


def scan_from_ros(msg: MeasurementSet, max_measurements: int) -> Scan:
    """``MeasurementSet`` -> :class:`~phd_swarm.core.scan.Scan`, checking count and finiteness."""
    return _scan(cdr.decode(MeasurementSet, serialize_message(msg)), None, max_measurements)


# ---------------------------------------------------------------- observation messages
def density_grid(owner_id: int, step: int, grid: Grid, bins: np.ndarray,
                 weights: np.ndarray, dt: float, frame_id: str) -> DensityGrid:
    """The bounding window of ``bins`` with their weights (other bins 0), Dames eq. 2 mass."""
    nx = grid.shape[1]
    h = header(step, dt, frame_id)
    if len(bins) == 0:
        return DensityGrid(header=h, owner_id=owner_id, step=step, x_min=grid.env.xmin,
                           y_min=grid.env.ymin, resolution=grid.resolution)
    rows, cols = np.divmod(bins, nx)
    r0, c0 = int(rows.min()), int(cols.min())
    height, width = int(rows.max()) - r0 + 1, int(cols.max()) - c0 + 1
    window = np.zeros((height, width))
    window[rows - r0, cols - c0] = weights
    return DensityGrid(header=h, owner_id=owner_id, step=step, x_min=grid.env.xmin,
                       y_min=grid.env.ymin, resolution=grid.resolution, origin_col=c0,
                       origin_row=r0, width=width, height=height, data=f64(window.ravel()))


def add_density(image: np.ndarray, msg: DensityGrid, grid: Grid) -> None:
    """Add a ``DensityGrid`` window into the team image (ny, nx).

    Raises InvalidMessage if the window does not fit the grid or holds bad numbers.
    """
    ny, nx = grid.shape
    if not (math.isclose(msg.resolution, grid.resolution) and math.isclose(
            msg.x_min, grid.env.xmin) and math.isclose(msg.y_min, grid.env.ymin)):
        raise InvalidMessage("grid geometry (x_min, y_min, resolution) differs from the "
                             "scenario's")
    if msg.width * msg.height != len(msg.data):
        raise InvalidMessage(f"data: {len(msg.data)} values for a {msg.width} x {msg.height} "
                             "window")
    if msg.origin_col + msg.width > nx or msg.origin_row + msg.height > ny:
        raise InvalidMessage("window extends beyond the grid")
    data = np.frombuffer(msg.data, dtype=np.float64).reshape(msg.height, msg.width)
    if not np.all(np.isfinite(data)) or np.any(data < 0):
        raise InvalidMessage("data: non-finite or negative mass")
    image[msg.origin_row:msg.origin_row + msg.height,
          msg.origin_col:msg.origin_col + msg.width] += data


def target_set(source_id: int, step: int, ids: np.ndarray, positions: np.ndarray,
               expected: float, dt: float, frame_id: str) -> TargetSet:
    """A ``TargetSet`` (truth or estimate)."""
    return TargetSet(header=header(step, dt, frame_id), source_id=source_id, step=step,
                     ids=u32(ids), positions=points(positions),
                     expected_cardinality=float(expected))


def target_positions(msg: TargetSet) -> np.ndarray:
    """Positions of a ``TargetSet``, shape (N, 2)."""
    return xy(msg.positions, "positions")
