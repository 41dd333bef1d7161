"""The error of the distributed filter (:mod:`phd_swarm.core.exchange.voronoi_phd`)."""


class ProtocolError(RuntimeError):
    """An invariant of the distributed filter was violated (a bug or inconsistent views)."""
