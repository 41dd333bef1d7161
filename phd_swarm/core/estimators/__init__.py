"""Estimators: the built-in ones register on import (:mod:`phd_swarm.core.registry`)."""

from . import grid_phd, papaioannou, shirsat, sung  # noqa: F401  (registration)
