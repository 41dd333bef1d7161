"""The QoS profiles of phd_swarm, named in one place (house style, STYLE.md §3).

Writers and readers of a topic may keep different history depths (depth does not affect
compatibility): a transient-local writer keeps a short history for late joiners, a reader a
deep queue so that a burst is never overwritten before the executor takes it.

- ``INBOX`` (protocol traffic, /robot_<i>/inbox/*): reliable, transient-local. A robot
  creates its publisher to a new contact's inbox when it first needs it and writes at once;
  the transient-local history delivers that message when the two match. Every message
  matters for equality with the centralised filter.
- ``STEP`` (one message per step that someone waits for or records: measurement sets,
  statuses, truth, density grids, metrics): reliable, transient-local, short writer history,
  so a reader that matches a little late (the recorder, the monitor) still gets the step.
- ``LATCHED`` (state a late joiner must see: team state, poses, cells, goals, estimates):
  reliable + transient-local, depth 1.
- ``OBSERVATION`` (markers, the team density): reliable, shallow, volatile; a slow viewer
  holds nobody back.
- ``CLOCK``: reliable, volatile, depth 10; compatible with rclpy's best-effort time source.
- ``PROTOCOL``: reliable, volatile, deep; for tests and tools that exchange protocol
  messages without the late-joiner guarantee.
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


def _profile(depth: int, durability: DurabilityPolicy) -> QoSProfile:
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE, durability=durability)


PROTOCOL = _profile(1000, DurabilityPolicy.VOLATILE)

INBOX_PUB = _profile(16, DurabilityPolicy.TRANSIENT_LOCAL)
INBOX_SUB = _profile(1000, DurabilityPolicy.TRANSIENT_LOCAL)

STEP_PUB = _profile(8, DurabilityPolicy.TRANSIENT_LOCAL)
STEP_SUB = _profile(200, DurabilityPolicy.TRANSIENT_LOCAL)

LATCHED = _profile(1, DurabilityPolicy.TRANSIENT_LOCAL)

OBSERVATION = _profile(10, DurabilityPolicy.VOLATILE)

CLOCK = _profile(10, DurabilityPolicy.VOLATILE)

SENSOR = qos_profile_sensor_data

#: Writer and reader profile of each QoS name used in :mod:`phd_swarm.nodes.topics`.
BY_NAME = {
    "INBOX": (INBOX_PUB, INBOX_SUB),
    "STEP": (STEP_PUB, STEP_SUB),
    "LATCHED": (LATCHED, LATCHED),
    "OBSERVATION": (OBSERVATION, OBSERVATION),
    "CLOCK": (CLOCK, CLOCK),
}


def publisher_qos(name: str) -> QoSProfile:
    """Writer profile of the QoS named ``name`` (a key of :data:`BY_NAME`)."""
    return BY_NAME[name][0]


def subscription_qos(name: str) -> QoSProfile:
    """Reader profile of the QoS named ``name`` (a key of :data:`BY_NAME`)."""
    return BY_NAME[name][1]
