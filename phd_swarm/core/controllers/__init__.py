"""Controllers: the built-in ones register on import (:mod:`phd_swarm.core.registry`)."""

from . import dtds_walk, lloyd, power_lloyd, sat_search_track, sung_planners  # noqa: F401  (registration)
from .base import CellDensity, Controller, Decision, Knowledge

__all__ = ["CellDensity", "Controller", "Decision", "Knowledge"]
