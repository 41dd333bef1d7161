"""phd_swarm: distributed multi-robot search and tracking with the PHD filter on ROS 2."""

__version__ = "0.1.0"
