"""ROS 2 node shells (rclpy lives only here)."""
