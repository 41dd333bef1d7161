"""Exchanges: the built-in ones register on import (:mod:`phd_swarm.core.registry`)."""

from . import voronoi_phd  # noqa: F401  (registration)
