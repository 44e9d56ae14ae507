"""core/ must never import rclpy (it runs without ROS)."""

from __future__ import annotations

import ast
from pathlib import Path

CORE = Path(__file__).resolve().parents[2] / 'tribo_drivers' / 'core'


def test_core_does_not_import_rclpy() -> None:
    files = sorted(CORE.glob('*.py'))
    assert len(files) > 5
    for f in files:
        for node in ast.walk(ast.parse(f.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or '']
            assert not any(n.split('.')[0] in ('rclpy', 'tribo_msgs') for n in names), f
