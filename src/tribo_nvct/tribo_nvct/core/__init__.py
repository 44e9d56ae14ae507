"""Pure-Python core (never imports rclpy)."""
