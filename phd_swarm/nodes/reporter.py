"""A node's report on ``/diagnostics``: the publisher and the once-a-second wall-clock timer.

The world, each robot and the recorder make one :class:`DiagnosticsReporter` with what
they read of themselves (a health value of :mod:`phd_swarm.nodes.diagnostics`) and the
builder that turns it into a ``DiagnosticStatus``. The timer runs on the steady clock, like
the robot's tick timer, so reports follow wall time whatever the sim time does and never
touch what a step computes; a report only reads.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.clock import Clock, ClockType
from rclpy.serialization import serialize_message

from phd_swarm.nodes import topics as T
from phd_swarm.nodes.diagnostics import PERIOD, diagnostic_array
from phd_swarm.nodes.qos import publisher_qos


class DiagnosticsReporter:
    """Publish ``build(read(), previous)`` on ``/diagnostics`` every :data:`PERIOD` s.

    Parameters
    ----------
    node : rclpy.node.Node
        The reporting node (publisher, timer and the stamp's clock are its own).
    read : callable
        ``read()`` -> the node's health now, or None to skip this report (e.g. a recorder
        whose log is closed).
    build : callable
        ``build(health, previous)`` -> the ``DiagnosticStatus`` (``previous``: the health
        of the last report, None at first).

    Attributes
    ----------
    last : DiagnosticStatus or None
        The status last published.
    sent : collections.deque of bytes
        The CDR of the last few reports, as published (the recorder leaves its own out of
        the log: each would change the next one's count of messages written).
    """

    def __init__(self, node: Any, read: Callable[[], Any],
                 build: Callable[[Any, Any], DiagnosticStatus]) -> None:
        self._node = node
        self._read = read
        self._build = build
        self._previous: Any = None
        self.last: DiagnosticStatus | None = None
        self.sent: deque[bytes] = deque(maxlen=8)
        self._pub = node.create_publisher(DiagnosticArray, T.DIAGNOSTICS,
                                          publisher_qos(T.TEAM_TOPICS[T.DIAGNOSTICS][1]))
        self._timer = node.create_timer(PERIOD, self.report,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))

    def report(self) -> DiagnosticStatus | None:
        """Read, build and publish one report now; returns the status (None if skipped)."""
        health = self._read()
        if health is None:
            return None
        status = self._build(health, self._previous)
        self._previous = health
        data = serialize_message(diagnostic_array(self._node.get_clock().now().to_msg(),
                                                  [status]))
        self.sent.append(data)
        self._pub.publish(data)
        self.last = status
        return status

    def stop(self) -> None:
        """Stop reporting (the timer goes; the publisher stays until the node does)."""
        if self._timer is not None:
            self._node.destroy_timer(self._timer)
            self._timer = None
