"""Sensor models: the built-in ones register on import (:mod:`phd_swarm.core.registry`)."""

from . import disk, disk_false_positive, square_range_bearing  # noqa: F401  (registration)
