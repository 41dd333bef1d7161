"""What an exchange's messages look like on ROS topics: inbox kinds, types, conversions.

The robot node (:mod:`phd_swarm.nodes.robot`) publishes the envelopes an exchange returns to
the receiver's inbox topic ``/robot_<dst>/inbox``, packed per receiver and tick with their
kinds (:mod:`phd_swarm.nodes.inbox`), and feeds what arrives on its own inbox back to the
exchange. How a core message becomes a ROS message is the exchange's
business, so each exchange part names its :class:`Wire` in its registration
(``wire="module:NAME"``, :mod:`phd_swarm.core.registry`): a string, so the core stays free
of rclpy. A new exchange brings its message definitions (``msg_defs/``) and a wire module;
the node is not edited.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from phd_swarm.core.registry import Part


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
    """

    types: Mapping[str, type]
    kind: Callable[[Any], str]
    to_ros: Callable[[Any, float, str], Any]
    from_ros: Callable[[Any, Any, int], Any]
    sender: Callable[[Any], int]
    addressee: Callable[[Any], int | None]


def wire_for(exchange: Part) -> Wire:
    """The :class:`Wire` an exchange part names (``extras["wire"] = "module:NAME"``).

    Raises
    ------
    ValueError
        If the part names none (it cannot run on ROS) or the name does not resolve.
    """
    ref = exchange.extras.get("wire")
    if not isinstance(ref, str) or ":" not in ref:
        raise ValueError(f"exchange {exchange.name!r} has no ROS wire format "
                         f"(register it with wire='module:NAME')")
    module, _, name = ref.partition(":")
    try:
        wire = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"exchange {exchange.name!r}: wire {ref!r} cannot be loaded: "
                         f"{exc}") from None
    if not isinstance(wire, Wire):
        raise ValueError(f"exchange {exchange.name!r}: {ref!r} is not a Wire")
    return wire
