"""What the recorder needs to know of a topic before it subscribes: class, stamp, QoS.

:func:`message_class` finds a type's Python class, :func:`starts_with_stamp` whether its
CDR begins with a stamp (the recorder's ``publish_time``), :func:`table_spec` a topic's
type and QoS in :mod:`phd_swarm.nodes.topics`, and :func:`reader_qos`, :func:`adapted_qos`
and :func:`accepts` the reader profile it records with (the table's, deepened; rosbag2's
rule for topics outside the table).
"""

from __future__ import annotations

import importlib
import re
from functools import cache
from typing import Any

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from phd_swarm.logs.schemas import SEPARATOR, DefinitionNotFoundError, message_definition
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.qos import subscription_qos

#: Reader depth for topics outside the table.
DEFAULT_DEPTH = 100

#: Least reader depth on table topics: deeper than the table's readers, so that a burst
#: (every robot's inbox traffic of a step) is not overwritten before the executor takes it.
#: Depth does not affect QoS compatibility.
MIN_TABLE_DEPTH = 1000

_ROBOT_TOPIC = re.compile(rf"^/{T.ROBOT_PREFIX}\d+/(.+)$")
_STAMP_TYPES = ("std_msgs/Header", "builtin_interfaces/Time")


def message_class(ros_type: str) -> type:
    """The Python class of ``pkg/msg/Type`` (ValueError if it is not installed)."""
    pkg, kind, name = (ros_type.split("/") + ["", ""])[:3]
    try:
        return getattr(importlib.import_module(f"{pkg}.{kind}"), name)
    except (ImportError, AttributeError, ValueError):
        raise ValueError(f"no Python message class for {ros_type!r}") from None


@cache
def starts_with_stamp(ros_type: str) -> bool:
    """Whether the first field of ``ros_type`` is a ``std_msgs/Header`` or a ``Time``.

    Then the CDR bytes 4-12 (after the 4-byte encapsulation header) are the stamp's
    ``int32 sec`` and ``uint32 nanosec``.
    """
    try:
        text = message_definition(ros_type)
    except DefinitionNotFoundError:
        return False
    for line in text.split(f"\n{SEPARATOR}\n", 1)[0].splitlines():
        words = line.split("#", 1)[0].split(None, 1)
        if len(words) < 2 or "=" in words[1]:
            continue  # blank, comment or constant
        return words[0] in (*_STAMP_TYPES, "Header")
    return False


def table_spec(topic: str, robot_table: dict[str, tuple[str, ...]] = T.ROBOT_TOPICS
               ) -> tuple[str, str] | None:
    """(type, QoS name) of ``topic`` in :mod:`phd_swarm.nodes.topics`, or None.

    ``robot_table``: a robot's topics by relative name (:func:`~phd_swarm.nodes.topics.
    robot_topics` of the run's declared outputs; by default those of every robot).
    """
    if topic in T.TEAM_TOPICS:
        typ, qos_name, *_ = T.TEAM_TOPICS[topic]
        return typ, qos_name
    match = _ROBOT_TOPIC.match(topic)
    if match and match.group(1) in robot_table:
        typ, qos_name, *_ = robot_table[match.group(1)]
        return typ, qos_name
    return None


def adapted_qos(offers: list[Any]) -> QoSProfile:
    """A reader profile that matches every offered profile in ``offers`` (rosbag2's rule).

    Reliable if every publisher is reliable, transient-local if every publisher is; keep
    last :data:`DEFAULT_DEPTH`. Without offers: reliable and volatile.
    """
    reliable = all(o.reliability == ReliabilityPolicy.RELIABLE for o in offers)
    latched = bool(offers) and all(o.durability == DurabilityPolicy.TRANSIENT_LOCAL
                                   for o in offers)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=DEFAULT_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def reader_qos(qos_name: str) -> QoSProfile:
    """The recorder's reader profile for table QoS ``qos_name``: the table's, deepened.

    Keep-all profiles stay keep-all (depth does not apply to them).
    """
    table = subscription_qos(qos_name)
    if table.history == HistoryPolicy.KEEP_ALL:
        return table
    return QoSProfile(history=table.history, depth=max(table.depth, MIN_TABLE_DEPTH),
                      reliability=table.reliability, durability=table.durability)


def accepts(reader: QoSProfile, offers: list[Any]) -> bool:
    """Whether a ``reader`` profile matches every offered profile in ``offers``.

    Only reliability and durability decide it here: a reliable reader needs reliable
    writers, a transient-local reader transient-local writers (deadline and liveliness are
    left at their defaults by phd_swarm).
    """
    for offer in offers:
        if reader.reliability == ReliabilityPolicy.RELIABLE \
                and offer.reliability != ReliabilityPolicy.RELIABLE:
            return False
        if reader.durability == DurabilityPolicy.TRANSIENT_LOCAL \
                and offer.durability != DurabilityPolicy.TRANSIENT_LOCAL:
            return False
    return True
