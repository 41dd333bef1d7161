"""The grid PHD as a ``nav_msgs/OccupancyGrid``: the view stock RViz2 and Foxglove panels draw.

Our own ``DensityGrid`` carries the PHD exactly (float64 masses, Dames eq. 2); no stock
viewer draws it. The same bins go out beside it as an ``OccupancyGrid`` (int8 per bin,
0..100), the message RViz2's Map display and Foxglove's 3D panel show:

    value = min(100, round(100 * mass / (FULL_DENSITY * resolution^2)))

so 100 is a PHD density of :data:`FULL_DENSITY` (1 target per m^2) or more, whatever the
bin size, and the extraction threshold of Dames (0.05 targets per m^2 at 1 m bins,
:mod:`phd_swarm.core.extraction`) is 5. The scale is fixed rather than the image's maximum,
so the robots' windows and the team grid read the same, step after step. A non-finite mass
(never published; a guard) is -1, "unknown".

Layout: ``OccupancyGrid.data`` is row-major from the cell at ``info.origin``, x fastest,
row r at y = origin.y + r * resolution; the same order as ``DensityGrid.data`` and the
grid's images (:mod:`phd_swarm.core.geometry.grid`: row = y index, row 0 at ``ymin``). So
a window's origin is ``(x_min + origin_col * resolution, y_min + origin_row * resolution)``
and its data is its ``DensityGrid`` data scaled, value for value.
"""

from __future__ import annotations

from array import array

import numpy as np
from geometry_msgs.msg import Point, Pose, Quaternion
from nav_msgs.msg import MapMetaData, OccupancyGrid
from std_msgs.msg import Header

from phd_swarm_msgs.msg import DensityGrid

#: The PHD density shown as 100 (full) [targets / m^2].
FULL_DENSITY = 1.0

#: The value of a bin whose mass is not a number.
UNKNOWN = -1


def scale(resolution: float) -> float:
    """The mass of a bin of side ``resolution`` [m] shown as 100: FULL_DENSITY * resolution^2."""
    return FULL_DENSITY * resolution * resolution


def occupancy_values(mass: np.ndarray, resolution: float) -> np.ndarray:
    """The 0..100 values of bin masses ``mass`` (any shape) on bins of side ``resolution``.

    ``min(100, round(100 * mass / scale(resolution)))`` (half to even), negative masses 0,
    non-finite ones :data:`UNKNOWN`; int8, the shape of ``mass``.
    """
    m = np.asarray(mass, dtype=float)
    finite = np.isfinite(m)
    values = np.rint(100.0 * np.where(finite, m, 0.0) / scale(resolution))
    out = np.clip(values, 0, 100).astype(np.int8)
    out[~finite] = UNKNOWN
    return out


def occupancy_grid(header: Header, image: np.ndarray, x0: float, y0: float,
                   resolution: float) -> OccupancyGrid:
    """An ``OccupancyGrid`` of the masses ``image`` (H, W) whose cell (0, 0) starts at (x0, y0).

    Parameters
    ----------
    header : std_msgs.msg.Header
        Stamp and frame (the world frame); ``info.map_load_time`` is its stamp.
    image : np.ndarray, shape (H, W)
        Bin masses (expected targets per bin), row = y index.
    x0, y0 : float
        Lower-left corner of cell (0, 0) [m], world frame.
    resolution : float
        Bin side [m].
    """
    img = np.asarray(image, dtype=float)
    height, width = img.shape if img.ndim == 2 else (0, 0)
    info = MapMetaData(map_load_time=header.stamp, resolution=float(resolution), width=width,
                       height=height, origin=Pose(position=Point(x=float(x0), y=float(y0)),
                                                  orientation=Quaternion(w=1.0)))
    data = occupancy_values(img, resolution).tobytes() if img.size else b""
    return OccupancyGrid(header=header, info=info, data=array("b", data))


def from_density(msg: DensityGrid) -> OccupancyGrid:
    """The ``OccupancyGrid`` of a ``DensityGrid`` window: same header, bins and order."""
    res = float(msg.resolution)
    image = np.frombuffer(msg.data, dtype=np.float64).reshape(int(msg.height), int(msg.width))
    return occupancy_grid(msg.header, image, msg.x_min + msg.origin_col * res,
                          msg.y_min + msg.origin_row * res, res)


def to_mass(msg: OccupancyGrid) -> np.ndarray:
    """The masses (H, W) an ``OccupancyGrid`` of :func:`occupancy_grid` stands for.

    ``value / 100 * scale(resolution)``: exact to half a step of the scale; unknown cells
    are NaN. For pictures of a log (:mod:`phd_swarm.tools.views_snapshot`).
    """
    values = np.frombuffer(bytes(msg.data), dtype=np.int8).astype(float)
    values[values < 0] = np.nan
    return (values / 100.0 * scale(msg.info.resolution)).reshape(msg.info.height,
                                                                 msg.info.width)
