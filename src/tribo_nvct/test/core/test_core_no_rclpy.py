"""Architecture rule: tribo_nvct.core never imports rclpy."""

from __future__ import annotations

import ast
from pathlib import Path

CORE = Path(__file__).resolve().parents[2] / 'tribo_nvct' / 'core'


def test_core_has_no_rclpy_import() -> None:
    files = sorted(CORE.glob('*.py'))
    assert len(files) >= 8
    for f in files:
        tree = ast.parse(f.read_text())
        for node in ast.walk(tree):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            assert not any(n.split('.')[0] == 'rclpy' for n in names), f'{f.name} imports rclpy'
