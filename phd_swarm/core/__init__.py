"""Pure numpy/scipy core of phd_swarm: models, grid PHD, partitions, Lloyd, metrics.

Nothing in this package imports rclpy; the ROS nodes are thin adapters over it.
"""
