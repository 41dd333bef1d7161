"""The recorder's side of the team topics: each message written under its own robot topic.

Robots send their statuses on ``/team/status`` and their step outputs as one bundle on
``/team/outputs``; the world sends its per-robot poses and measurement sets as one bundle
on ``/world/outputs`` (:mod:`phd_swarm.nodes.bundle`). The recorder reads those few topics
and writes every message under the per-robot topic it belongs to (``/robot_3/status``,
``/robot_3/estimates``...), so that a log holds the same channels as when every robot topic
had its own reader, and old and new logs read alike.

:class:`TeamRoutes` maps each carried topic to its recording callback (the one a
subscription of that topic would have had) and gives the callbacks of the team topics.
A message that belongs to no topic of the run (an unknown robot id, a topic outside the
sender's namespace, malformed bytes) is not written; it is counted and named in a warning.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from phd_swarm.nodes import bundle
from phd_swarm.nodes import topics as T
from phd_swarm.nodes.convert import InvalidMessage

_U32_LE = struct.Struct("<I")
_U32_BE = struct.Struct(">I")

Record = Callable[[bytes], None]


def status_state(data: bytes) -> int:
    """``state`` of a CDR-serialised ``RobotStatus`` (after the header's stamp and frame id).

    The field is a ``uint8`` (no alignment) right after the frame id string (a ``uint32``
    length that counts the terminating NUL, then the bytes).
    """
    u32 = _U32_LE if data[1] & 1 else _U32_BE
    (n,) = u32.unpack_from(data, 12)
    return data[16 + n]


def status_robot(data: bytes) -> int:
    """``robot_id`` of a CDR-serialised ``RobotStatus``: the ``uint32`` after ``state``.

    Aligned to 4 bytes counted from the end of the 4-byte encapsulation header.
    """
    u32 = _U32_LE if data[1] & 1 else _U32_BE
    (n,) = u32.unpack_from(data, 12)
    at = 17 + n
    return u32.unpack_from(data, at + (-(at - 4) % 4))[0]


class TeamRoutes:
    """Carried topic -> recording callback, by team topic (see the module docstring).

    Parameters
    ----------
    warn : callable
        Takes a warning line (the node's logger); called for the first rejected message
        of each team topic and then every 100th.
    """

    def __init__(self, warn: Callable[[str], None]) -> None:
        self._warn = warn
        self._routes: dict[str, dict[str, Record]] = {}
        #: Messages of the team topics not written, by team topic.
        self.rejected: dict[str, int] = {}

    def add(self, via: str, topic: str, record: Record) -> None:
        """Write the messages of ``topic`` that arrive on team topic ``via`` with ``record``."""
        self._routes.setdefault(via, {})[topic] = record

    @property
    def topics(self) -> list[str]:
        """Every carried topic, in the order added."""
        return [t for routes in self._routes.values() for t in routes]

    @property
    def team_topics(self) -> list[str]:
        """The team topics that carry something."""
        return list(self._routes)

    def callback(self, via: str) -> Record:
        """The subscription callback of team topic ``via`` (raw CDR in)."""
        routes = self._routes[via]
        if via == T.TEAM_STATUS:
            def on_status(data: bytes) -> None:
                try:
                    record = routes.get(T.robot_topic(status_robot(data), "status"))
                except (IndexError, struct.error):
                    record = None
                if record is None:
                    self._reject(via, "a status of no robot of this run, or malformed")
                else:
                    record(data)
            return on_status
        prefixes = {}

        def on_bundle(data: bytes) -> None:
            try:
                sender, _, pieces = bundle.unpack_cdr(data)
            except InvalidMessage as exc:
                self._reject(via, str(exc))
                return
            prefix = prefixes.get(sender)
            if prefix is None:
                prefix = prefixes[sender] = ("/" if sender == bundle.WORLD
                                             else T.robot_namespace(sender) + "/")
            for topic, piece in pieces:
                record = routes.get(topic) if topic.startswith(prefix) else None
                if record is None:
                    self._reject(via, f"a message of sender {sender} for {topic!r}, which "
                                      "is none of its topics in this run")
                else:
                    record(piece)
        return on_bundle

    def _reject(self, via: str, why: str) -> None:
        n = self.rejected[via] = self.rejected.get(via, 0) + 1
        if n == 1 or n % 100 == 0:
            self._warn(f"not recorded from {via} ({n} so far): {why}")

    def summary(self) -> dict[str, Any]:
        """Rejected counts by team topic (for the recorder's metadata)."""
        return dict(self.rejected)
