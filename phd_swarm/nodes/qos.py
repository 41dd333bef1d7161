"""The QoS profiles of phd_swarm, named in one place (house style, STYLE.md §3).

Writers and readers of a topic may keep different history depths (depth does not affect
compatibility): a transient-local writer keeps a short history for late joiners, a reader a
deep queue so that a burst is never overwritten before the executor takes it.

- ``INBOX`` (protocol traffic, /robot_<i>/inbox): reliable, transient-local. A robot
  creates its publisher to a new contact's inbox when it first needs it and writes at once;
  the transient-local history delivers that message when the two match. Every message
  matters for equality with the centralised filter.
- ``STEP`` (every message written once per step: measurement sets, poses, statuses, cells,
  goals, estimates, density grids, truth, team state, metrics, the team PHD): reliable,
  transient-local; the reader **keep-all**, the writer keep-last :data:`STEP_HISTORY`.
  A keep-all reader never drops a sample it has not handed to the executor, so a slow
  recorder or monitor gets every step instead of losing the oldest ones (issue 15: with
  KEEP_LAST 8 on both sides a 20-robot run lost 1-2 % of its step messages); it
  acknowledges a sample when the sample is in its queue, not when the executor takes it.
  The writer keeps the last :data:`STEP_HISTORY` samples for repairs and for a reader
  that matches a little late: a sample a reader lost in transport is re-sent from there
  when the reader asks (Fast DDS heartbeats every 3 s), long before it is 512 samples old
  (4 minutes of a 2 Hz run, 20 s of the fastest lockstep runs), and a run's readers match
  before step 0 (robots and the recorder wait for them). The writer was keep-all until
  issue 40, which Fast DDS bounds only by 5,000 samples per writer: acknowledged samples
  stayed for late joiners, and every process grew for the first 5,000 steps of a run (the
  hour's soak, docs/benchmarks.md: the monitor by ~350 MB, its team PHD alone).
- ``LATCHED`` (state a late joiner must see and nothing more): reliable + transient-local,
  depth 1: the occupancy-grid views of the PHD (``/monitor/density_grid``,
  ``/robot_<id>/density_grid``), as RViz2's Map display (transient-local by default) and
  nav2's map server have it. A new grid replaces an unacknowledged one, so a slow viewer
  holds nobody back, and a viewer that joins late gets the latest grid at once.
- ``OBSERVATION`` (markers, ``/diagnostics``): reliable, shallow, volatile; a slow viewer
  holds nobody back.
- ``CLOCK``: reliable, volatile, keep-all on the writer (so that a reliable recorder gets
  every tick); rclpy's time source subscribes best effort, depth 1, which matches and never
  holds the writer back.
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


def _keep_all(durability: DurabilityPolicy) -> QoSProfile:
    # depth is ignored with KEEP_ALL; Fast DDS bounds the history by its resource limits.
    return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=0,
                      reliability=ReliabilityPolicy.RELIABLE, durability=durability)


PROTOCOL = _profile(1000, DurabilityPolicy.VOLATILE)

#: 64: one inbox topic carries every kind (Dames' six) to a contact; it was 16 per kind.
INBOX_PUB = _profile(64, DurabilityPolicy.TRANSIENT_LOCAL)
INBOX_SUB = _profile(1000, DurabilityPolicy.TRANSIENT_LOCAL)

#: Samples a step writer keeps (see ``STEP`` above): bounded memory, room for repairs.
STEP_HISTORY = 512

STEP_PUB = _profile(STEP_HISTORY, DurabilityPolicy.TRANSIENT_LOCAL)
STEP_SUB = _keep_all(DurabilityPolicy.TRANSIENT_LOCAL)

LATCHED = _profile(1, DurabilityPolicy.TRANSIENT_LOCAL)

OBSERVATION = _profile(10, DurabilityPolicy.VOLATILE)

CLOCK = _keep_all(DurabilityPolicy.VOLATILE)
CLOCK_SUB = _profile(10, DurabilityPolicy.VOLATILE)

SENSOR = qos_profile_sensor_data

#: Writer and reader profile of each QoS name used in :mod:`phd_swarm.nodes.topics`.
BY_NAME = {
    "INBOX": (INBOX_PUB, INBOX_SUB),
    "STEP": (STEP_PUB, STEP_SUB),
    "LATCHED": (LATCHED, LATCHED),
    "OBSERVATION": (OBSERVATION, OBSERVATION),
    "CLOCK": (CLOCK, CLOCK_SUB),
}


def publisher_qos(name: str) -> QoSProfile:
    """Writer profile of the QoS named ``name`` (a key of :data:`BY_NAME`)."""
    return BY_NAME[name][0]


def subscription_qos(name: str) -> QoSProfile:
    """Reader profile of the QoS named ``name`` (a key of :data:`BY_NAME`)."""
    return BY_NAME[name][1]
