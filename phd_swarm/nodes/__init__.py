"""rclpy adapters over phd_swarm.core: one Node subclass per module."""
