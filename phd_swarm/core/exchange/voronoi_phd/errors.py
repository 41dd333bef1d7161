"""The error of the distributed filter (:mod:`phd_swarm.core.exchange.voronoi_phd`).

Every exchange's :class:`~phd_swarm.core.exchange.base.ProtocolError`: the robot node
catches it without knowing the exchange.
"""

from ..base import ProtocolError

__all__ = ["ProtocolError"]
