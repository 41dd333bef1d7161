"""Conversions between core values and ROS messages, with the checks of incoming data.

The only module that knows both :mod:`phd_swarm.core.exchange.voronoi_phd.messages` and
``phd_swarm_msgs``. ``from_ros`` functions check what a message *is* (finite numbers,
consistent lengths, indices on the grid, sizes within bounds) and raise
:class:`InvalidMessage` naming the field; whether the message is *welcome* (known sender,
addressed here, step in range) is for the receiving node to decide.

Arrays travel as ``array.array`` built from the numpy buffer, which rosidl accepts without
checking element by element (fast for density grids and particle transfers).
"""

from __future__ import annotations

import array
import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped
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
def stamp(step: int, dt: float) -> Time:
    """Sim time of step ``step`` as a ROS time (exact for dt in whole nanoseconds)."""
    ns = int(step) * round(dt * 1e9)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


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
    out = np.array([(p.x, p.y) for p in pts], dtype=float).reshape(-1, 2)
    if not np.all(np.isfinite(out)):
        raise InvalidMessage(f"{field}: non-finite coordinate")
    return out


def point_xy(p: Point, field: str) -> np.ndarray:
    """One ``Point`` -> (2,) array; InvalidMessage if not finite."""
    if not (math.isfinite(p.x) and math.isfinite(p.y)):
        raise InvalidMessage(f"{field}: non-finite coordinate ({p.x}, {p.y})")
    return np.array([p.x, p.y])


def values(seq, field: str) -> np.ndarray:
    """``float64[]`` -> array; InvalidMessage if not finite."""
    out = np.array(seq, dtype=float)
    if not np.all(np.isfinite(out)):
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
def to_ros(msg: Message, dt: float, frame_id: str):
    """Core protocol message -> its ``phd_swarm_msgs`` message."""
    h = header(msg.step, dt, frame_id)
    if isinstance(msg, StateMsg):
        return RobotState(header=h, robot_id=msg.robot_id, step=msg.step,
                          position=Point(x=float(msg.position[0]), y=float(msg.position[1])),
                          power_weight=float(msg.power_weight),
                          cell_radius=float(msg.cell_radius))
    if isinstance(msg, CellMsg):
        return CellPolygon(header=h, robot_id=msg.robot_id, step=msg.step,
                           generator=Point(x=float(msg.generator[0]),
                                           y=float(msg.generator[1])),
                           power_weight=float(msg.power_weight), vertices=points(msg.vertices),
                           neighbour_ids=u32(msg.neighbour_ids),
                           contact_ids=u32(msg.contact_ids),
                           contact_positions=points(msg.contact_positions),
                           contact_power_weights=f64(msg.contact_power_weights),
                           contact_cell_radii=f64(msg.contact_cell_radii))
    if isinstance(msg, Scan):
        return MeasurementSet(header=h, robot_id=msg.robot_id, step=msg.step,
                              sensor_position=Point(x=float(msg.sensor[0]),
                                                    y=float(msg.sensor[1])),
                              measurements=points(msg.z))
    if isinstance(msg, EtaPartialMsg):
        return EtaPartial(header=h, sender_id=msg.sender_id, active_id=msg.active_id,
                          step=msg.step, values=f64(msg.values))
    if isinstance(msg, EtaTotalMsg):
        return EtaTotal(header=h, active_id=msg.active_id, step=msg.step,
                        values=f64(msg.values))
    if isinstance(msg, TransferMsg):
        cum = msg.alpha is not None
        return ParticleTransfer(header=h, from_id=msg.from_id, to_id=msg.to_id, step=msg.step,
                                kind=int(msg.kind), bin_indices=u32(msg.bins),
                                weights=f64(msg.weights),
                                alpha=f64(msg.alpha) if cum else array.array("d"),
                                observation_count=f64(msg.count) if cum
                                else array.array("d"),
                                radius_ids=u32(msg.radius_ids),
                                cell_radii=f64(msg.cell_radii))
    raise TypeError(f"not a protocol message: {type(msg).__name__}")


def from_ros(msg, grid: Grid, max_measurements: int) -> Message:
    """``phd_swarm_msgs`` protocol message -> core message, checking its contents.

    Raises
    ------
    InvalidMessage
        Non-finite numbers, negative weights or masses, mismatched lengths, bin indices
        off the grid, more than ``max_measurements`` measurements.
    """
    if isinstance(msg, RobotState):
        return StateMsg(msg.robot_id, msg.step, point_xy(msg.position, "position"),
                        finite(msg.power_weight, "power_weight", 0.0),
                        finite(msg.cell_radius, "cell_radius", 0.0))
    if isinstance(msg, CellPolygon):
        n = len(msg.contact_ids)
        if not (len(msg.contact_positions) == len(msg.contact_power_weights)
                == len(msg.contact_cell_radii) == n):
            raise InvalidMessage(f"contact table: {n} ids but {len(msg.contact_positions)} "
                                 f"positions, {len(msg.contact_power_weights)} power weights, "
                                 f"{len(msg.contact_cell_radii)} radii")
        rho = values(msg.contact_power_weights, "contact_power_weights")
        radii = values(msg.contact_cell_radii, "contact_cell_radii")
        if np.any(rho < 0) or np.any(radii < 0):
            raise InvalidMessage("contact table: negative power weight or cell radius")
        return CellMsg(msg.robot_id, msg.step, point_xy(msg.generator, "generator"),
                       finite(msg.power_weight, "power_weight", 0.0),
                       xy(msg.vertices, "vertices"),
                       tuple(int(i) for i in msg.neighbour_ids),
                       tuple(int(i) for i in msg.contact_ids),
                       xy(msg.contact_positions, "contact_positions"), rho, radii)
    if isinstance(msg, MeasurementSet):
        return scan_from_ros(msg, max_measurements)
    if isinstance(msg, EtaPartial):
        return EtaPartialMsg(msg.sender_id, msg.active_id, msg.step,
                             _eta_values(msg.values, max_measurements))
    if isinstance(msg, EtaTotal):
        return EtaTotalMsg(msg.active_id, msg.step, _eta_values(msg.values, max_measurements))
    if isinstance(msg, ParticleTransfer):
        if msg.kind not in (ParticleTransfer.KIND_OWNERSHIP, ParticleTransfer.KIND_PHANTOM):
            raise InvalidMessage(f"kind: unknown transfer kind {msg.kind}")
        bins = np.frombuffer(msg.bin_indices, dtype=np.uint32).astype(np.int64)
        w = values(msg.weights, "weights")
        if len(w) != len(bins):
            raise InvalidMessage(f"{len(bins)} bin indices but {len(w)} weights")
        if np.any(w < 0):
            raise InvalidMessage("weights: negative PHD mass")
        if len(bins) and bins.max() >= grid.size:
            raise InvalidMessage(f"bin_indices: index {int(bins.max())} is off the grid of "
                                 f"{grid.size} bins")
        alpha = count = None
        if len(msg.alpha) or len(msg.observation_count):
            alpha = values(msg.alpha, "alpha")
            count = values(msg.observation_count, "observation_count")
            if len(alpha) != len(bins) or len(count) != len(bins):
                raise InvalidMessage(f"{len(bins)} bins but {len(alpha)} alpha and "
                                     f"{len(count)} observation counts")
            if np.any(alpha < 0) or np.any(count < 0):
                raise InvalidMessage("alpha / observation_count: negative value")
        radius_ids = tuple(int(i) for i in msg.radius_ids)
        radii = values(msg.cell_radii, "cell_radii")
        if len(radii) != len(radius_ids):
            raise InvalidMessage(f"{len(radius_ids)} radius ids but {len(radii)} cell radii")
        if np.any(radii < 0):
            raise InvalidMessage("cell_radii: negative radius")
        return TransferMsg(msg.from_id, msg.to_id, msg.step, TransferKind(msg.kind), bins, w,
                           alpha, count, radius_ids, radii)
    raise InvalidMessage(f"not a protocol message: {type(msg).__name__}")


def _eta_values(seq, max_measurements: int) -> np.ndarray:
    if len(seq) > max_measurements:
        raise InvalidMessage(f"values: {len(seq)} values, more than max_measurements = "
                             f"{max_measurements}")
    v = values(seq, "values")
    if np.any(v < 0):
        raise InvalidMessage("values: negative normalisation sum")
    return v


def scan_from_ros(msg: MeasurementSet, max_measurements: int) -> Scan:
    """``MeasurementSet`` -> :class:`~phd_swarm.core.scan.Scan`, checking count and finiteness."""
    if len(msg.measurements) > max_measurements:
        raise InvalidMessage(f"measurements: {len(msg.measurements)} measurements, more than "
                             f"max_measurements = {max_measurements}")
    return Scan(msg.robot_id, msg.step, point_xy(msg.sensor_position, "sensor_position"),
                   xy(msg.measurements, "measurements"))


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
