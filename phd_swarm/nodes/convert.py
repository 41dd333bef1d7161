"""Conversions between core values and ROS messages, with the checks of incoming data.

The shared ones: stamps and headers, points and arrays, measurement sets (world to robot,
and forwarded between robots), density grids and target sets; an exchange's own messages
are its face's (:mod:`phd_swarm.nodes.faces`). ``from_ros`` functions check what a
message *is* (finite numbers, consistent lengths, indices on the grid, sizes within
bounds) and raise :class:`InvalidMessage` naming the field; whether the message is
*welcome* (known sender, addressed here, step in range) is for the receiving node to
decide.

Measurement sets go straight between core values and their CDR bytes through
:mod:`phd_swarm.nodes.cdr` (:func:`decode_scan`), without ROS message objects: the robots'
hot path. One function builds a message's fields (:func:`scan_fields`) and one checks
them (:func:`scan_from_fields`); the faces of exchanges do the same for their messages.

Arrays of other messages travel as ``array.array`` built from the numpy buffer, which
rosidl accepts without checking element by element (fast for density grids).
"""

from __future__ import annotations

import array
import math
from collections.abc import Mapping
from types import SimpleNamespace
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped
from rclpy.serialization import serialize_message
from std_msgs.msg import Header

from phd_swarm.core.geometry.grid import Grid
from phd_swarm.core.scan import Scan
from phd_swarm.nodes import auth, cdr
from phd_swarm_msgs.msg import DensityGrid, MeasurementSet, TargetSet

#: ``owner_id`` / ``source_id`` of team-wide grids and sets, and of ground truth.
TEAM_ID = 0xFFFFFFFF


class InvalidMessage(ValueError):
    """A message that cannot be right: the text names the field and the problem."""


class Unauthenticated(InvalidMessage):
    """A message of a keyed run without the MAC of the run's key (:mod:`.auth`)."""


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


def field_points(points3: np.ndarray, field: str) -> np.ndarray:
    """Decoded points (N, 3) -> own (N, 2) copy; InvalidMessage if not finite."""
    return _finite_xy(np.array(points3[:, :2]), field)


def point_xy(p: Point, field: str) -> np.ndarray:
    """One ``Point`` -> (2,) array; InvalidMessage if not finite."""
    return _finite_point(p.x, p.y, field)


def _finite_point(x: float, y: float, field: str) -> np.ndarray:
    if not (math.isfinite(x) and math.isfinite(y)):
        raise InvalidMessage(f"{field}: non-finite coordinate ({x}, {y})")
    return np.array([x, y])


def field_point(point3: np.ndarray, field: str) -> np.ndarray:
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


# ------------------------------------------------------------------ measurement sets
def scan_fields(msg: Scan, dt: float, frame_id: str) -> dict:
    """A scan -> the fields of its ``MeasurementSet`` (:mod:`.cdr` values)."""
    return {"header": {"stamp": stamp_fields(msg.step, dt), "frame_id": frame_id},
            "robot_id": msg.robot_id, "step": msg.step, "sensor_position": msg.sensor,
            "measurements": msg.z}


def scan_from_fields(f: dict, max_measurements: int) -> Scan:
    """Fields of a ``MeasurementSet`` (:func:`.cdr.decode`) -> scan, checked.

    Raises
    ------
    InvalidMessage
        More than ``max_measurements`` measurements, or a non-finite coordinate.
    """
    z = f["measurements"]
    if len(z) > max_measurements:
        raise InvalidMessage(f"measurements: {len(z)} measurements, more than "
                             f"max_measurements = {max_measurements}")
    return Scan(f["robot_id"], f["step"], field_point(f["sensor_position"], "sensor_position"),
                field_points(z, "measurements"))


def encode_scan(step: int, dt: float, frame_id: str, robot_id: int, sensor: np.ndarray,
                z: np.ndarray, key: bytes | None = None) -> bytes:
    """The CDR of the ``MeasurementSet`` of robot ``robot_id`` at ``step`` (the world's).

    ``sensor``: its position (2,); ``z``: the measurements (N, 2). Sealed with the run's
    ``key`` (:func:`.auth.seal`; an empty ``mac`` without one).
    """
    full = cdr.encode(MeasurementSet, {
        "header": {"stamp": stamp_fields(step, dt), "frame_id": frame_id},
        "robot_id": robot_id, "step": step, "sensor_position": sensor, "measurements": z})
    return auth.seal(key, full[:-4])  # without its empty mac (aligned: nothing precedes it)


def decode_scan(data: bytes, max_measurements: int, key: bytes | None = None) -> Scan:
    """The CDR of a ``MeasurementSet`` -> scan (what a robot takes from the world), checked.

    Raises
    ------
    Unauthenticated
        With the run's ``key``: bytes without its MAC (checked before anything is decoded).
    InvalidMessage
        Bytes that do not decode (:class:`.cdr.CdrError`), or what
        :func:`scan_from_fields` refuses.
    """
    if key is not None and not auth.is_sealed(key, data):
        raise Unauthenticated("measurement set not signed with this run's key")
    try:
        fields = cdr.decode(MeasurementSet, data)
    except cdr.CdrError as exc:
        raise InvalidMessage(f"does not deserialise: {exc}") from None
    return scan_from_fields(fields, max_measurements)


def scan_from_ros(msg: MeasurementSet, max_measurements: int) -> Scan:
    """``MeasurementSet`` -> :class:`~phd_swarm.core.scan.Scan`, checking count and finiteness."""
    return scan_from_fields(cdr.decode(MeasurementSet, serialize_message(msg)), max_measurements)


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


def add_density(image: np.ndarray, msg: DensityGrid | Mapping[str, Any], grid: Grid) -> None:
    """Add a ``DensityGrid`` window into the team image (ny, nx).

    ``msg``: the message, or the numpy codec's dict of one (:func:`phd_swarm.nodes.cdr.decode`).
    Raises InvalidMessage if the window does not fit the grid or holds bad numbers.
    """
    if isinstance(msg, Mapping):
        msg = SimpleNamespace(**msg)
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
