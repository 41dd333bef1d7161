"""One sensor's measurement set Z_r^t (Dames Sec. II) as a plain value.

The one scan type: the world's output, the filters' input, and the ``voronoi_phd``
exchange's ``MeasurementSet`` message (:mod:`phd_swarm.core.exchange.voronoi_phd.messages`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Estimated CDR sizes [bytes] for the communication benchmark: 4-byte encapsulation, a
#: header with stamp and a short frame id ("map"), and a geometry_msgs/Point.
CDR_HEADER = 4 + 8 + 4 + 4
CDR_POINT = 24


@dataclass(frozen=True, eq=False)
class Scan:
    """Measurement set of robot ``robot_id`` at step ``step``.

    Attributes
    ----------
    robot_id : int
        Sender; measurement sets are applied in increasing robot id (Dames Alg. 2).
    step : int
        Filter step the scan belongs to.
    sensor : np.ndarray, shape (2,)
        Sensor position q [m], world frame.
    z : np.ndarray, shape (M, 2)
        Measured target positions [m], world frame; M may be 0.
    labels : np.ndarray of int64, shape (M,) or (0,)
        The target label of each measurement, 0 for none (clutter), from a sensor that
        identifies targets (:mod:`phd_swarm.core.sensors.disk_labelled`); empty (the
        default) when the sensor gives no labels.
    """

    #: Its message type in ``msg_defs`` (traffic counts, :mod:`phd_swarm.engines`).
    WIRE_TYPE = "MeasurementSet"

    robot_id: int
    step: int
    sensor: np.ndarray
    z: np.ndarray
    labels: np.ndarray | None = None

    def __post_init__(self) -> None:
        sensor = np.asarray(self.sensor, dtype=float).reshape(-1)[:2]
        z = np.asarray(self.z, dtype=float).reshape(-1, 2)
        if sensor.shape != (2,) or not np.isfinite(sensor).all():
            raise ValueError(f"scan of robot {self.robot_id}: sensor position must be two "
                             f"finite numbers, got {self.sensor!r}")
        if not np.isfinite(z).all():
            raise ValueError(f"scan of robot {self.robot_id}: measurements must be finite")
        labels = np.empty(0, dtype=np.int64) if self.labels is None else self.labels
        labels = np.asarray(labels).reshape(-1)
        if labels.size and (labels.shape[0] != z.shape[0]
                            or not np.issubdtype(labels.dtype, np.integer)
                            or labels.min() < 0):
            raise ValueError(f"scan of robot {self.robot_id}: labels must be {z.shape[0]} "
                             f"integers >= 0 (one per measurement) or none, got {labels!r}")
        object.__setattr__(self, "sensor", sensor)
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "labels", labels.astype(np.int64))

    def wire_size(self) -> int:
        """Estimated CDR payload size of the ``MeasurementSet`` message [bytes]."""
        return CDR_HEADER + 4 + 4 + CDR_POINT + 4 + CDR_POINT * len(self.z)
