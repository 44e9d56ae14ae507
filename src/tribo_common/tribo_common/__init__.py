"""rclpy helpers shared by the tribo nodes (this package may import rclpy)."""
