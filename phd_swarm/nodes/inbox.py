"""A robot's one inbox topic: protocol messages packed per sender and tick (InboxMessage).

Robot ``j`` sends everything its exchange has for robot ``i`` in one tick as one
``phd_swarm_msgs/InboxMessage`` on ``/robot_<i>/inbox``: the kinds in order, each message the
ROS message of its kind (:class:`phd_swarm.nodes.wire.Wire`) serialised as CDR. One topic
per robot rather than one per kind keeps the DDS endpoints a crowded start creates at
N (N - 1) instead of 6 N (N - 1) for Dames' six kinds, and one message per contact and tick
instead of one per protocol message (docs/decisions.md, "One inbox topic per robot").

:func:`pack` and :func:`unpack` are each other's inverse; :func:`unpack` refuses a malformed
envelope with :class:`phd_swarm.nodes.convert.InvalidMessage` naming what is wrong.
"""

from __future__ import annotations

from array import array
from collections.abc import Mapping, Sequence
from typing import Any

from rclpy.serialization import deserialize_message, serialize_message

from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm_msgs.msg import InboxMessage

#: Relative name of a robot's inbox topic.
INBOX = "inbox"


def pack(sender: int, messages: Sequence[tuple[str, Any]]) -> InboxMessage:
    """One envelope from robot ``sender`` holding ``messages``: (kind, ROS message) pairs."""
    blobs = [serialize_message(m) for _, m in messages]
    offsets = [0]
    for b in blobs:
        offsets.append(offsets[-1] + len(b))
    # array('B') is what rclpy keeps a uint8[] as: assigning one skips a per-byte check.
    return InboxMessage(sender=int(sender), kinds=[k for k, _ in messages],
                        offsets=array("I", offsets), data=array("B", b"".join(blobs)))


def unpack(msg: InboxMessage, types: Mapping[str, type]) -> list[tuple[str, Any]]:
    """The (kind, ROS message) pairs of envelope ``msg``; ``types`` maps kind -> ROS type.

    Raises :class:`InvalidMessage` on an unknown kind, offsets that do not cut ``data`` into
    one piece per kind, or a piece that does not deserialise as its kind.
    """
    kinds = list(msg.kinds)
    offsets = list(msg.offsets)
    data = bytes(msg.data)
    if len(offsets) != len(kinds) + 1 or offsets[0] != 0 or offsets[-1] != len(data) \
            or any(b < a for a, b in zip(offsets[:-1], offsets[1:], strict=True)):
        raise InvalidMessage(f"offsets {offsets[:8]}{'...' if len(offsets) > 8 else ''} do "
                             f"not cut {len(data)} bytes into {len(kinds)} messages")
    out = []
    for i, kind in enumerate(kinds):
        typ = types.get(kind)
        if typ is None:
            raise InvalidMessage(f"unknown inbox kind {kind!r} (this exchange takes "
                                 f"{', '.join(sorted(types)) or 'none'})")
        try:
            out.append((kind, deserialize_message(data[offsets[i]:offsets[i + 1]], typ)))
        except Exception as exc:  # rclpy raises a bare RuntimeError on bad CDR
            raise InvalidMessage(f"message {i} ({kind}) does not deserialise: {exc}") from None
    return out
