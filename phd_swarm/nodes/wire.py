"""What an exchange's messages look like on ROS topics: inbox kinds, types, conversions.

The robot node (:mod:`phd_swarm.nodes.robot`) publishes the envelopes an exchange returns to
the receiver's inbox topic ``/robot_<dst>/inbox``, packed per receiver and tick with their
kinds (:mod:`phd_swarm.nodes.inbox`), and feeds what arrives on its own inbox back to the
exchange. How a core message becomes a ROS message, and the CDR bytes of one in an inbox
message, is the exchange's business, so each exchange part names its :class:`Wire` in its
registration (``wire="module:NAME"``, :mod:`phd_swarm.core.registry`): a string, so the
core stays free of rclpy. A new exchange brings its message definitions (``msg_defs/``)
and a wire module; the node is not edited.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any

from rclpy.serialization import deserialize_message, serialize_message

from phd_swarm.core.registry import Part
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm.nodes.face import load_named


@dataclass(frozen=True)
class Wire:
    """The ROS side of an exchange's messages.

    Attributes
    ----------
    types : mapping of str to type
        Inbox kind -> ROS message type (the type of that kind's messages in an inbox message).
    kind : callable
        Core message -> its inbox kind.
    to_ros : callable
        ``to_ros(msg, dt, frame_id)`` -> ROS message.
    from_ros : callable
        ``from_ros(ros_msg, grid, max_measurements)`` -> core message; raises
        :class:`phd_swarm.nodes.convert.InvalidMessage` naming the field.
    sender : callable
        Core message -> the robot id that sent it.
    addressee : callable
        Core message -> the one robot it is for, or None if any contact may take it
        (a message addressed to another robot is rejected).
    encode : callable, optional
        ``encode(msg, dt, frame_id)`` -> the CDR bytes of the kind's ROS message, bytes
        that ``rclpy.serialization.deserialize_message`` reads as ``to_ros(msg, dt,
        frame_id)`` (what the robot node packs into inbox messages). By default
        ``serialize_message(to_ros(msg, dt, frame_id))``; a wire gives its own to skip
        building ROS messages (:mod:`phd_swarm.nodes.cdr`).
    decode : callable, optional
        ``decode(kind, data, grid, max_measurements)`` -> core message from the CDR bytes
        of a ``kind`` message (what the robot node takes out of inbox messages); raises
        :class:`~phd_swarm.nodes.convert.InvalidMessage` naming the field, also for bytes
        that do not deserialise. By default ``from_ros`` of
        ``rclpy.serialization.deserialize_message(data, types[kind])``.
    """

    types: Mapping[str, type]
    kind: Callable[[Any], str]
    to_ros: Callable[[Any, float, str], Any]
    from_ros: Callable[[Any, Any, int], Any]
    sender: Callable[[Any], int]
    addressee: Callable[[Any], int | None]
    encode: Callable[[Any, float, str], bytes] | None = None
    decode: Callable[[str, bytes, Any, int], Any] | None = None

    def __post_init__(self) -> None:
        if self.encode is None:
            object.__setattr__(self, "encode", partial(_encode_via_ros, self.to_ros))
        if self.decode is None:
            object.__setattr__(self, "decode",
                               partial(_decode_via_ros, self.types, self.from_ros))


def _encode_via_ros(to_ros: Callable, msg: Any, dt: float, frame_id: str) -> bytes:
    return serialize_message(to_ros(msg, dt, frame_id))


def _decode_via_ros(types: Mapping[str, type], from_ros: Callable, kind: str, data: bytes,
                    grid: Any, max_measurements: int) -> Any:
    try:
        ros_msg = deserialize_message(data, types[kind])
    except Exception as exc:  # rclpy raises a bare RuntimeError on bad CDR
        raise InvalidMessage(f"does not deserialise: {exc}") from None
    return from_ros(ros_msg, grid, max_measurements)


def wire_for(exchange: Part) -> Wire:
    """The :class:`Wire` an exchange part names (its ``wire`` hook, ``"module:NAME"``).

    The module part may be the path of a ``.py`` file (a plugin's wire), loaded as faces
    are (:func:`phd_swarm.nodes.face.load_named`).

    Raises
    ------
    ValueError
        If the part names none (it cannot run on ROS) or the name does not resolve.
    """
    ref = exchange.wire or None
    if not isinstance(ref, str) or ":" not in ref:
        raise ValueError(f"exchange {exchange.name!r} has no ROS wire format "
                         f"(register it with wire='module:NAME')")
    wire = load_named(ref, f"exchange {exchange.name!r}: wire")
    if not isinstance(wire, Wire):
        raise ValueError(f"exchange {exchange.name!r}: {ref!r} is not a Wire")
    return wire
