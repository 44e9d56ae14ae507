"""The ROS parameter files in config/ and the launch files are true to the nodes.

Every ``<node>: ros__parameters:`` file names only parameters its node
declares, with values of the declared type (a typo or a stale key would be
silently ignored by ROS), and every file a launch file passes exists.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from support import requires_ros

from tribo_common import nodes

CONFIG = Path(__file__).resolve().parents[1] / 'config'
LAUNCH = Path(__file__).resolve().parents[1] / 'src' / 'tribo_bringup' / 'launch'

#: Nodes with a ROS parameter file in config/ (the node table's ``config``).
WITH_FILE = {n.name: n for n in nodes.NODES if n.config}


def _param_files() -> list[tuple[Path, str, dict[str, Any]]]:
    out = []
    for path in sorted(CONFIG.glob('*.yaml')):
        data = yaml.safe_load(path.read_text())
        if not isinstance(data, dict):
            continue
        for node, body in data.items():
            if isinstance(body, dict) and 'ros__parameters' in body:
                # '/**/name' applies in any namespace (a rig moved with __ns)
                out.append((path, node.removeprefix('/**/'), body['ros__parameters']))
    return out


def test_launch_files_name_existing_config_files() -> None:
    named = {n.config for n in nodes.NODES if n.config and n.launch}
    for launch in LAUNCH.glob('*.launch.py'):
        named |= set(re.findall(r"params\('([^']+)'\)", launch.read_text()))
    assert named, 'no parameter files named by the node table or the launch files'
    missing = sorted(n for n in named if not (CONFIG / n).is_file())
    assert not missing, missing


def test_every_node_params_file_is_checked() -> None:
    found = {(path.name, node) for path, node, _ in _param_files()}
    assert found == {(n.config, name) for name, n in WITH_FILE.items()}


@requires_ros
@pytest.mark.ros
@pytest.mark.parametrize(
    ('path', 'node_name', 'params'), _param_files(), ids=lambda v: getattr(v, 'name', '')
)
def test_params_file_keys_are_declared(path: Path, node_name: str, params: dict[str, Any]) -> None:
    import rclpy
    from rclpy.parameter import Parameter

    cls = WITH_FILE[node_name].node_class()
    values = dict(params)
    extra: dict[str, Any] = {}
    if node_name == 'wear_monitor':
        extra['nvct_config'] = str(CONFIG / 'nvct.yaml')  # relative to the workspace root
        extra['state_file'] = ''
    if 'autostart' in values:
        extra['autostart'] = False  # no device is opened
    values.update(extra)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        # The file reaches the node as `--params-file` does (rcl's YAML parser: an empty
        # list arrives without a type); the node declares its parameters, and a value of
        # the wrong type raises here.
        node = cls(
            cli_args=['--ros-args', '--params-file', str(path)],
            parameter_overrides=[Parameter(k, value=v) for k, v in extra.items()],
            context=context,
        )
        try:
            undeclared = sorted(k for k in params if not node.has_parameter(k))
            assert not undeclared, f'{path.name}: {node_name} does not declare {undeclared}'
            for key, value in values.items():
                got = node.get_parameter(key).value
                assert got == pytest.approx(value) if isinstance(value, float) else got == value, (
                    key
                )
        finally:
            close = getattr(node, 'close', None)
            if callable(close):
                close()
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
