"""The wire format of the ``none`` exchange: no inbox, no message.

A robot of a system without an exchange (Sung & Tokekar's single robot) subscribes to no
inbox and sends nothing; a message that reaches it anyway has no kind to arrive on.
"""

from __future__ import annotations

from typing import Any, NoReturn

from phd_swarm.nodes.wire import Wire


def _no_message(*_: Any) -> NoReturn:
    raise ValueError("the 'none' exchange has no messages")


WIRE = Wire(types={}, kind=_no_message, to_ros=_no_message, from_ros=_no_message,
            sender=_no_message, addressee=_no_message)
