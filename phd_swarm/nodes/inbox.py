"""A robot's one inbox topic: protocol messages packed per sender and tick (InboxMessage).

Robot ``j`` sends everything its exchange has for robot ``i`` in one tick as one
``phd_swarm_msgs/InboxMessage`` on ``/robot_<i>/inbox``: the kinds in order, each message the
ROS message of its kind (:class:`phd_swarm.nodes.wire.Wire`) serialised as CDR, exactly as
``rclpy.serialization.serialize_message`` gives it. One topic per robot rather than one per
kind keeps the DDS endpoints a crowded start creates at N (N - 1) instead of 6 N (N - 1) for
Dames' six kinds, and one message per contact and tick instead of one per protocol message
(docs/decisions.md, "One inbox topic per robot").

:func:`pack` and :func:`unpack` are each other's inverse on (kind, CDR bytes) pieces: the
robot node encodes and decodes the pieces with its wire (:attr:`Wire.encode`,
:attr:`Wire.decode`), without ROS message objects, and the envelope itself too
(:func:`pack_cdr`, :func:`unpack_cdr`: it publishes CDR bytes and its subscription is raw).
:func:`unpack` refuses a malformed envelope (unknown kind, offsets that do not cut the data)
with :class:`phd_swarm.nodes.convert.InvalidMessage` naming what is wrong. :func:`messages`
decodes an envelope into ROS messages with rclpy, e.g. one seen with ``ros2 topic echo
/robot_3/inbox``.
"""

from __future__ import annotations

import struct
from array import array
from collections.abc import Collection, Mapping, Sequence
from itertools import accumulate
from typing import Any

from rclpy.serialization import deserialize_message

from phd_swarm.nodes import auth, cdr, cdr_cut
from phd_swarm.nodes.convert import InvalidMessage, Unauthenticated
from phd_swarm_msgs.msg import InboxMessage

#: Relative name of a robot's inbox topic.
INBOX = "inbox"


def pack(sender: int, pieces: Sequence[tuple[str, bytes]]) -> InboxMessage:
    """One envelope from robot ``sender`` holding ``pieces``: (kind, CDR bytes) pairs."""
    offsets = [0, *accumulate(len(b) for _, b in pieces)]
    # array('B') is what rclpy keeps a uint8[] as: assigning one skips a per-byte check.
    return InboxMessage(sender=int(sender), kinds=[k for k, _ in pieces],
                        offsets=array("I", offsets),
                        data=array("B", b"".join(b for _, b in pieces)))


def pack_cdr(sender: int, pieces: Sequence[tuple[str, bytes]],
             key: bytes | None = None) -> bytes:
    """:func:`pack`, serialised: the CDR of the envelope, for ``Publisher.publish``.

    What a robot publishes every tick to each contact, so it is written out by hand (4x
    faster than :func:`phd_swarm.nodes.cdr.encode`, which gives the same bytes): the
    encapsulation header, ``sender``, the kinds as CDR strings, ``offsets``, ``data``, and
    the ``mac`` under the run's ``key`` (empty without one; :func:`phd_swarm.nodes.auth.seal`).
    """
    n = len(pieces)
    offsets = list(accumulate((len(b) for _, b in pieces), initial=0))
    return auth.seal(key, b"".join((cdr.ENCAPSULATION, struct.pack("<iI", sender, n),
                                    *[cdr.string_cdr(k) for k, _ in pieces],
                                    struct.pack(f"<{n + 2}I", n + 1, *offsets),
                                    struct.pack("<I", offsets[-1]), *[b for _, b in pieces])))


def unpack_cdr(data: bytes, kinds: Collection[str], key: bytes | None = None
               ) -> tuple[int, list[tuple[str, bytes]]]:
    """The sender and the (kind, CDR bytes) pieces of a serialised envelope.

    What a robot's raw inbox subscription receives. With the run's ``key``, the envelope
    must carry its MAC (:class:`~phd_swarm.nodes.convert.Unauthenticated` otherwise, checked
    before anything is decoded). Raises :class:`InvalidMessage` when the bytes are not an
    ``InboxMessage``, or as :func:`unpack` does.
    """
    if key is not None and not auth.is_sealed(key, data):
        raise Unauthenticated("inbox message not signed with this run's key")
    if data[:4] == cdr.ENCAPSULATION:
        # Little-endian CDR, what every robot writes (pack_cdr): cut by hand, ~4x faster.
        try:
            (sender,) = _SENDER.unpack_from(data, 4)
            names, offsets, body, end = cdr_cut.names_offsets_body(data, 8)
            at = cdr_cut.aligned(end)
            (size,) = _U32.unpack_from(data, at)  # the mac (is_sealed checked its bytes)
            if size > len(data) - at - 4:
                raise ValueError(f"a mac of {size} bytes past the end")
        except (struct.error, UnicodeDecodeError, IndexError, ValueError) as exc:
            raise InvalidMessage(f"not an inbox message: {exc}") from None
        return sender, _cut(names, offsets, body, kinds)
    try:
        env = cdr.decode(InboxMessage, data)
    except cdr.CdrError as exc:
        raise InvalidMessage(f"not an inbox message: {exc}") from None
    return env["sender"], _cut(env["kinds"], env["offsets"].tolist(), env["data"].tobytes(),
                               kinds)


_SENDER = struct.Struct("<i")
_U32 = struct.Struct("<I")


def unpack(msg: InboxMessage, kinds: Collection[str]) -> list[tuple[str, bytes]]:
    """The (kind, CDR bytes) pieces of envelope ``msg``; ``kinds`` are those it may hold.

    ``kinds`` is typically the wire's ``types`` (kind -> ROS type). Raises
    :class:`InvalidMessage` on an unknown kind, or offsets that do not cut ``data`` into
    one piece per kind. Whether each piece decodes is the wire's to say.
    """
    return _cut(list(msg.kinds), list(msg.offsets), bytes(msg.data), kinds)


def _cut(names: list[str], offsets: list[int], data: bytes,
         kinds: Collection[str]) -> list[tuple[str, bytes]]:
    if len(offsets) != len(names) + 1 or offsets[0] != 0 or offsets[-1] != len(data) \
            or sorted(offsets) != offsets:
        raise InvalidMessage(f"offsets {offsets[:8]}{'...' if len(offsets) > 8 else ''} do "
                             f"not cut {len(data)} bytes into {len(names)} messages")
    unknown = [k for k in names if k not in kinds]
    if unknown:
        raise InvalidMessage(f"unknown inbox kind {unknown[0]!r} (this exchange takes "
                             f"{', '.join(sorted(kinds)) or 'none'})")
    return [(k, data[a:b]) for k, a, b in zip(names, offsets[:-1], offsets[1:], strict=True)]


def messages(msg: InboxMessage, types: Mapping[str, type]) -> list[tuple[str, Any]]:
    """The (kind, ROS message) pairs of envelope ``msg``; ``types`` maps kind -> ROS type.

    For people and tools (a robot decodes with its wire). Raises :class:`InvalidMessage`
    as :func:`unpack` does, or on a piece that does not deserialise as its kind.
    """
    out = []
    for i, (kind, data) in enumerate(unpack(msg, types)):
        try:
            out.append((kind, deserialize_message(data, types[kind])))
        except Exception as exc:  # rclpy raises a bare RuntimeError on bad CDR
            raise InvalidMessage(f"message {i} ({kind}) does not deserialise: {exc}") from None
    return out
