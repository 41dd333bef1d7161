"""Pure numpy/scipy core of phd_swarm: the four roles' parts by system, geometry, scoring.

Nothing in this package imports rclpy; the ROS nodes are thin adapters over it.
"""
