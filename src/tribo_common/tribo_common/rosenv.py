"""Where ROS 2 keeps per-user state: ``$ROS_HOME``, by default ``~/.ros`` (no rclpy)."""

from __future__ import annotations

import os
from pathlib import Path


def ros_home() -> Path:
    """``$ROS_HOME`` if set (``~`` expanded), else ``~/.ros`` (the ROS 2 convention)."""
    value = os.environ.get('ROS_HOME', '').strip()
    return Path(value).expanduser() if value else Path('~/.ros').expanduser()


def default_state_file(package: str, name: str) -> Path:
    """Return the default state file ``$ROS_HOME/<package>/<name>`` of a node."""
    return ros_home() / package / name
