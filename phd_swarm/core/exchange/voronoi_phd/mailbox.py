"""A robot's mail: messages received by step, kind and sender, and what it sent, for re-sends.

Lost messages: a keep-alive (a repeated state, see :mod:`.liveness`) is also a request. A
robot keeps the envelopes it sent in the current and the previous step (not its states).
A keep-alive, a state of a step the receiver has sent messages in that repeats one it holds
or comes after it finished that step, is answered with what the receiver sent that peer in
that step and the peer may still miss: a robot sends the messages of a phase only once it
holds the previous phase's from all its contacts, so the peer's own messages show which
phases it is past (:func:`may_miss`). States are never re-sent as answers: an answered
state could be answered again. A message that arrives again is not applied again: the
first copy of each (step, kind, sender) is kept.
"""

from __future__ import annotations

from collections import defaultdict

from ...scan import Scan
from ..base import Envelope
from .messages import (
    CellMsg,
    EtaPartialMsg,
    EtaTotalMsg,
    Message,
    StateMsg,
    TransferKind,
    TransferMsg,
)

#: A mailbox key: (step, kind) or, for eta sums, (step, kind, active robot id).
Key = tuple


class Mailbox:
    """Messages of the current and earlier steps, and the envelopes sent, of one robot.

    Messages are filed by :func:`mail_route`'s key and then by sender; the first copy of
    each is kept. The envelopes sent in the current and the previous step are logged
    (:meth:`record`), so that a peer's keep-alive can be answered with what it may miss
    (:meth:`owed_to`); answers wait in a queue until the robot's next ``advance``.
    """

    def __init__(self, robot_id: int) -> None:
        self.robot_id = robot_id
        self._boxes: dict[Key, dict[int, Message]] = defaultdict(dict)
        #: What this robot sent in the current and the previous step, by step.
        self._sent: dict[int, list[Envelope]] = {}
        self._log: list[Envelope] = []
        self._queue: list[Envelope] = []

    def clear(self) -> None:
        """Forget every message, sent and received (a robot rejoining the team)."""
        self._boxes.clear()
        self._sent, self._log, self._queue = {}, [], []

    # ----------------------------------------------------------------- received
    def box(self, key: Key) -> dict[int, Message]:
        """Messages filed under ``key``, by sender, in arrival order (created if absent)."""
        return self._boxes[key]

    def count(self, key: Key) -> int:
        """Number of senders filed under ``key`` (without creating the box)."""
        box = self._boxes.get(key)
        return 0 if box is None else len(box)

    def drop_before(self, step: int) -> None:
        """Forget the messages of the steps before ``step``."""
        for key in [k for k in self._boxes if k[0] < step]:
            del self._boxes[key]

    def held_from(self, src: int, step: int) -> set[str]:
        """Kinds of message of step ``step`` held from robot ``src`` (see :func:`may_miss`).

        ``partial`` stands for its partial sums for this robot's update, ``total`` for its
        totals of its own update. Empty when the step's mail is gone (a later step started).
        """
        boxes = self._boxes
        keys = (("cell", (step, "cell")), ("own", (step, "own")),
                ("phantom", (step, "phantom")), ("scan", (step, "scan")),
                ("partial", (step, "partial", self.robot_id)), ("total", (step, "total", src)))
        return {kind for kind, key in keys if src in boxes.get(key, ())}

    # --------------------------------------------------------------------- sent
    def start_step(self, step: int, previous: int) -> None:
        """Log the envelopes of step ``step`` from now on; keep those of step ``previous``."""
        kept = self._sent.get(previous)
        self._sent = {} if kept is None else {previous: kept}
        self._log = self._sent[step] = []

    def record(self, out: list[Envelope]) -> None:
        """Log envelopes sent in the current step."""
        self._log.extend(out)

    def owed_to(self, dst: int, step: int) -> list[Envelope]:
        """What this robot sent robot ``dst`` in step ``step`` that it may still miss."""
        held = self.held_from(dst, step)
        return [e for e in self._sent.get(step, ()) if e.dst == dst and may_miss(e.msg, held)]

    def queue(self, answers: list[Envelope]) -> None:
        """Hold answers to keep-alives until :meth:`take_queue`."""
        self._queue.extend(answers)

    @property
    def queued(self) -> bool:
        """Whether answers wait in the queue."""
        return bool(self._queue)

    def take_queue(self) -> list[Envelope]:
        """The queued answers, oldest first; the queue is emptied."""
        out, self._queue = self._queue, []
        return out


def mail_route(msg: Message) -> tuple[int, Key]:
    """Sender of ``msg`` and the key of the mailbox it goes to: (step, kind[, active id])."""
    route = _ROUTES.get(type(msg))
    if route is None:
        raise TypeError(f"not a protocol message: {type(msg).__name__}")
    return route(msg)


#: Mailbox routes by exact message type (the hot path of a robot's ``receive``); the sender
#: they give is :func:`.messages.sender_of`'s (tested).
_ROUTES = {
    StateMsg: lambda m: (m.robot_id, (m.step, "state")),
    CellMsg: lambda m: (m.robot_id, (m.step, "cell")),
    Scan: lambda m: (m.robot_id, (m.step, "scan")),
    TransferMsg: lambda m: (m.from_id, (m.step, "own" if m.kind == TransferKind.OWNERSHIP
                                        else "phantom")),
    EtaPartialMsg: lambda m: (m.sender_id, (m.step, "partial", m.active_id)),
    EtaTotalMsg: lambda m: (m.active_id, (m.step, "total", m.active_id)),
}


def may_miss(msg: Message, held: set[str]) -> bool:
    """Whether a peer from which the kinds ``held`` arrived may still miss ``msg`` from us.

    A robot sends the messages of a phase only once it holds those of the phase before
    from all its contacts: its ownership transfer shows that it had every cell, its phantom
    transfer every ownership transfer, and any message of the update (measurement set,
    partial or total eta) every phantom transfer. In the update, its partial sums for our
    measurements show that it had our measurement set, and its totals that it had our
    partial sums.
    """
    kind = type(msg)
    if kind is CellMsg:
        return not held - {"cell"}
    if kind is TransferMsg:
        later = _AFTER_OWN if msg.kind == TransferKind.OWNERSHIP else _UPDATE
        return not held & later
    if kind is Scan:
        return "partial" not in held
    if kind is EtaPartialMsg:
        return "total" not in held
    return True


_UPDATE = frozenset({"scan", "partial", "total"})
_AFTER_OWN = _UPDATE | {"phantom"}


__all__ = ["Mailbox", "mail_route", "may_miss"]
