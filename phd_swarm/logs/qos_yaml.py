"""A publisher's QoS as rosbag2 writes it: one entry of ``offered_qos_profiles`` YAML.

The recorder stores the profiles of a channel's publishers with it (as rosbag2 does, so
that a replay offers the same QoS): :func:`qos_yaml`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

_HISTORY = {0: "system_default", 1: "keep_last", 2: "keep_all", 3: "unknown"}
_RELIABILITY = {0: "system_default", 1: "reliable", 2: "best_effort", 3: "unknown",
                4: "best_available"}
_DURABILITY = {0: "system_default", 1: "transient_local", 2: "volatile", 3: "unknown",
               4: "best_available"}
_LIVELINESS = {0: "system_default", 1: "automatic", 2: "manual_by_node",
               3: "manual_by_topic", 4: "unknown", 5: "best_available"}


def _policy(value: Any, names: Mapping[int, str]) -> str:
    return names.get(int(getattr(value, "value", value)), "unknown")


def _duration(value: Any) -> tuple[int, int]:
    """(sec, nsec) of an rclpy Duration (``.nanoseconds``) or a number of nanoseconds."""
    ns = int(getattr(value, "nanoseconds", value or 0))
    return ns // 1_000_000_000, ns % 1_000_000_000


def qos_yaml(profile: Any) -> str:
    """``profile`` as one entry of rosbag2's ``offered_qos_profiles`` YAML list.

    ``profile`` is duck-typed like ``rclpy.qos.QoSProfile``: ``history``, ``depth``,
    ``reliability``, ``durability`` (enums with ``.value``, or ints) and optionally
    ``deadline``, ``lifespan``, ``liveliness``, ``liveliness_lease_duration`` (Durations
    with ``.nanoseconds``, or ints [ns]) and ``avoid_ros_namespace_conventions``. Policies
    are written by name (``keep_last``, ``reliable``, ...) as Jazzy's rosbag2 does
    (metadata version 9), in the layout of yaml-cpp's ``Dump``. Profiles of several
    publishers make a longer list when their texts are joined with a newline.
    """
    lines = [
        f"- history: {_policy(profile.history, _HISTORY)}",
        f"  depth: {int(profile.depth)}",
        f"  reliability: {_policy(profile.reliability, _RELIABILITY)}",
        f"  durability: {_policy(profile.durability, _DURABILITY)}",
    ]
    for key in ("deadline", "lifespan"):
        sec, nsec = _duration(getattr(profile, key, 0))
        lines += [f"  {key}:", f"    sec: {sec}", f"    nsec: {nsec}"]
    lines.append(f"  liveliness: {_policy(getattr(profile, 'liveliness', 0), _LIVELINESS)}")
    sec, nsec = _duration(getattr(profile, "liveliness_lease_duration", 0))
    lines += ["  liveliness_lease_duration:", f"    sec: {sec}", f"    nsec: {nsec}"]
    avoid = bool(getattr(profile, "avoid_ros_namespace_conventions", False))
    lines.append(f"  avoid_ros_namespace_conventions: {'true' if avoid else 'false'}")
    return "\n".join(lines)


