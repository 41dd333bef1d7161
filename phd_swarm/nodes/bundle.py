"""Team topics: a sender's messages of one step as one ``MessageBundle`` for the observers.

The world, the monitor and the recorder read what every robot writes once per step. Read
topic by topic, that is 7 readers per robot in the recorder (706 at 100 robots), and Fast
DDS offers every sample a participant receives to each of its readers in turn
(docs/benchmarks.md, "Where the recorder's CPU goes"): the observers' cost grew with the
square of the team. So each robot writes its status on the team topic ``/team/status`` and
everything else of its step (goal, estimates, its system's outputs) as one bundle on
``/team/outputs``; the world writes its per-robot poses and measurement sets of a step as
one bundle on ``/world/outputs``. Each observer holds a few readers whatever the team size,
and receives one sample per robot and step instead of seven. Jazzy has no keyed topics;
the key is the sender in the message (docs/decisions.md, "Team topics").

A bundle's messages keep their own topic names (``/robot_3/estimates``): the recorder
writes each under that name, so a log is shaped as before, per robot, and old logs read as
new ones. The per-robot topics a person inspects stay: a robot or the world writes a
message there too whenever a reader is matched (:func:`publish_watched`).

:func:`pack_cdr` writes a bundle's CDR by hand (it is written once per robot and step);
:func:`unpack_cdr` cuts one, refusing malformed bytes with
:class:`phd_swarm.nodes.convert.InvalidMessage` naming what is wrong.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from itertools import accumulate
from typing import Any

from phd_swarm.nodes import cdr, cdr_cut
from phd_swarm.nodes.convert import InvalidMessage
from phd_swarm_msgs.msg import MessageBundle

#: Sender id of the world's bundles.
WORLD = -1


def pack_cdr(sec: int, nanosec: int, frame_id: str, sender: int, step: int,
             pieces: Sequence[tuple[str, bytes]]) -> bytes:
    """The CDR of a ``MessageBundle``: (topic, CDR bytes) ``pieces`` of ``sender`` at ``step``.

    ``sec``/``nanosec`` stamp the header (the step's sim time). The same bytes as
    :func:`phd_swarm.nodes.cdr.encode` gives (tested), 3-4x faster.
    """
    n = len(pieces)
    offsets = list(accumulate((len(b) for _, b in pieces), initial=0))
    return b"".join((cdr.ENCAPSULATION, struct.pack("<iI", sec, nanosec),
                     cdr.string_cdr(frame_id), struct.pack("<iII", sender, step, n),
                     *[cdr.string_cdr(t) for t, _ in pieces],
                     struct.pack(f"<{n + 2}I", n + 1, *offsets),
                     struct.pack("<I", offsets[-1]), *[b for _, b in pieces]))


def unpack_cdr(data: bytes) -> tuple[int, int, list[tuple[str, bytes]]]:
    """The sender, the step and the (topic, CDR bytes) messages of a serialised bundle.

    Cuts little-endian CDR (what every sender of ours writes, :func:`pack_cdr`) by hand,
    ~6x faster than the general codec (the monitor and the recorder cut one bundle per robot
    and step); other bytes go through :func:`phd_swarm.nodes.cdr.decode`. Raises
    :class:`InvalidMessage` when the bytes are not a ``MessageBundle`` or its offsets do not
    cut its data into one message per topic.
    """
    if data[:4] == cdr.ENCAPSULATION:
        try:
            sender, step, topics, offsets, body = _cut_le(data)
        except (struct.error, UnicodeDecodeError, IndexError, ValueError) as exc:
            raise InvalidMessage(f"not a message bundle: {exc}") from None
    else:
        try:
            b = cdr.decode(MessageBundle, data)
        except cdr.CdrError as exc:
            raise InvalidMessage(f"not a message bundle: {exc}") from None
        sender, step, topics = b["sender"], b["step"], b["topics"]
        offsets, body = b["offsets"].tolist(), b["data"].tobytes()
    if len(offsets) != len(topics) + 1 or offsets[0] != 0 or offsets[-1] != len(body) \
            or sorted(offsets) != offsets:
        raise InvalidMessage(f"bundle of sender {sender}: offsets "
                             f"{offsets[:8]}{'...' if len(offsets) > 8 else ''} do not cut "
                             f"{len(body)} bytes into {len(topics)} messages")
    return sender, step, [(t, body[i:j]) for t, i, j
                          in zip(topics, offsets[:-1], offsets[1:], strict=True)]


_HEAD = struct.Struct("<iI")  # sender, step


def _cut_le(data: bytes) -> tuple[int, int, list[str], list[int], bytes]:
    """The fields of a little-endian ``MessageBundle`` (offsets from the body's start, 4)."""
    _, at = cdr_cut.string_at(data, 12)  # header: stamp (8 bytes), then frame_id
    at = cdr_cut.aligned(at)
    sender, step = _HEAD.unpack_from(data, at)
    topics, offsets, body, _ = cdr_cut.names_offsets_body(data, at + 8)
    return sender, step, topics, offsets, body


def publish_watched(pub: Any, data: bytes) -> None:
    """Publish CDR ``data`` on ``pub`` if a reader is matched (a person or tool watching).

    The per-robot topics next to the team topics: nothing is written where nobody reads,
    and ``ros2 topic echo /robot_3/estimates`` sees the steps from when it matched.
    """
    if pub.get_subscription_count():
        pub.publish(data)
