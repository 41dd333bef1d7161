"""The QoS profiles of phd_swarm, named in one place (house style, STYLE.md §3).

- ``PROTOCOL``: distributed-filter traffic (states, measurement sets, eta sums, particle
  transfers). Every message matters for equality with the centralised filter, so reliable;
  KEEP_LAST with a deep queue so that a burst within one step is never overwritten.
- ``LATCHED``: state a late joiner must still see (cells, config, the last estimate):
  reliable + transient-local, depth 1.
- ``OBSERVATION``: grids, estimates, markers for monitors and RViz2/Foxglove: reliable,
  shallow; a slow viewer does not hold the team back because nothing waits on it.
- ``SENSOR``: the standard sensor-data profile (best effort), only where loss is acceptable.
"""

from __future__ import annotations

from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)

PROTOCOL = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)

LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)

OBSERVATION = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)

SENSOR = qos_profile_sensor_data
