"""The launch files without ROS 2 launch installed: every argument has a description,
and the actions they build (namespace, fresh or resumed wear test, the rig waiting
for the recorder) follow the arguments. `launch`/`launch_ros` are replaced by
small recording stand-ins; the files are run as `ros2 launch` would import them."""

from __future__ import annotations

import ast
import importlib.util
import sys
import types
from pathlib import Path
from typing import Any, ClassVar

import pytest

from tribo_common.nodes import BY_NAME, launched_by

LAUNCH = Path(__file__).resolve().parents[1] / 'src' / 'tribo_bringup' / 'launch'


@pytest.mark.parametrize('name', ['sim.launch.py', 'hardware.launch.py'])
def test_every_launch_argument_has_a_description(name: str) -> None:
    tree = ast.parse((LAUNCH / name).read_text())
    calls = [
        n for n in ast.walk(tree)
        if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'DeclareLaunchArgument'
    ]  # fmt: skip
    assert calls
    for c in calls:
        desc = [k for k in c.keywords if k.arg == 'description']
        assert desc, ast.unparse(c)


class _Action:
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args, self.kwargs = args, kwargs


class _Config:
    values: ClassVar[dict[str, str]] = {}

    def __init__(self, name: str) -> None:
        self.name = name

    def perform(self, context: Any) -> str:
        return self.values[self.name]


def _load(name: str, monkeypatch: pytest.MonkeyPatch) -> Any:
    mods = {
        'launch': types.ModuleType('launch'),
        'launch.actions': types.ModuleType('launch.actions'),
        'launch.substitutions': types.ModuleType('launch.substitutions'),
        'launch_ros': types.ModuleType('launch_ros'),
        'launch_ros.actions': types.ModuleType('launch_ros.actions'),
        'ament_index_python': types.ModuleType('ament_index_python'),
        'ament_index_python.packages': types.ModuleType('ament_index_python.packages'),
    }
    mods['launch'].LaunchDescription = lambda actions: actions  # type: ignore[attr-defined]
    mods['launch'].LaunchContext = object  # type: ignore[attr-defined]
    for attr in ('DeclareLaunchArgument', 'ExecuteProcess', 'OpaqueFunction'):
        setattr(mods['launch.actions'], attr, type(attr, (_Action,), {}))
    mods['launch.substitutions'].LaunchConfiguration = _Config  # type: ignore[attr-defined]
    for attr in ('Node', 'LifecycleNode'):
        setattr(mods['launch_ros.actions'], attr, type(attr, (_Action,), {}))
    mods['ament_index_python.packages'].get_package_share_directory = (  # type: ignore[attr-defined]
        lambda pkg: '/share/' + pkg
    )
    for key, mod in mods.items():
        monkeypatch.setitem(sys.modules, key, mod)
    spec = importlib.util.spec_from_file_location(name.replace('.', '_'), LAUNCH / name)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _actions(name: str, monkeypatch: pytest.MonkeyPatch, **args: str) -> list[Any]:
    module = _load(name, monkeypatch)
    described = module.generate_launch_description()
    defaults = {
        a.args[0]: a.kwargs['default_value']
        for a in described
        if type(a).__name__.startswith('Decl')
    }
    _Config.values = {**defaults, **args}
    (opaque,) = [a for a in described if type(a).__name__ == 'OpaqueFunction']
    return list(opaque.kwargs['function'](None))


def _params(action: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for p in action.kwargs['parameters']:
        if isinstance(p, dict):
            out.update(p)
    return out


def test_sim_launch_defaults_start_a_fresh_test_in_the_root_namespace(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    acts = _actions('sim.launch.py', monkeypatch)
    nodes = {a.kwargs['name']: a for a in acts if type(a).__name__ == 'Node'}
    # the node table's 'sim' rows, simulators included, none of them a lifecycle node
    assert set(nodes) == {n.name for n in launched_by('sim')}
    assert {'sim_rig', 'sim_detector', 'model_monitor'} <= set(nodes)
    for name, a in nodes.items():
        assert (a.kwargs['package'], a.kwargs['executable']) == (BY_NAME[name].package, name)
    assert all(a.kwargs['namespace'] == '' for a in nodes.values())
    wear = _params(nodes['wear_monitor'])
    assert wear['fresh_start'] is True and 'state_file' not in wear
    assert _params(nodes['sim_rig'])['min_subscribers'] == 0
    assert not [a for a in acts if type(a).__name__ == 'ExecuteProcess']


def test_sim_launch_namespace_resume_and_record(monkeypatch: pytest.MonkeyPatch) -> None:
    acts = _actions(
        'sim.launch.py', monkeypatch, namespace='rigB', resume='true', record='true',
        state_file='/tmp/w.json', bag='session',
    )  # fmt: skip
    nodes = {a.kwargs['name']: a for a in acts if type(a).__name__ == 'Node'}
    assert all(a.kwargs['namespace'] == '/rigB' for a in nodes.values())
    wear = _params(nodes['wear_monitor'])
    assert wear['fresh_start'] is False and wear['state_file'] == '/tmp/w.json'
    # the rig waits for the estimator and the recorder before its first sample
    assert _params(nodes['sim_rig'])['min_subscribers'] == 2
    (rec,) = [a for a in acts if type(a).__name__ == 'ExecuteProcess']
    cmd = rec.kwargs['cmd']
    assert cmd[:3] == ['ros2', 'bag', 'record'] and cmd[cmd.index('-o') + 1] == 'session'
    assert '/rigB/rig/torsion_moment' in cmd and '/rigB/nvct/wear' in cmd


def test_hardware_launch_resumes_by_default(monkeypatch: pytest.MonkeyPatch) -> None:
    acts = _actions('hardware.launch.py', monkeypatch, namespace='/rigA/')
    kinds = {a.kwargs['name']: type(a).__name__ for a in acts}
    # the drivers are lifecycle nodes, as the node table says; no simulator
    assert kinds == {
        n.name: 'LifecycleNode' if n.lifecycle else 'Node' for n in launched_by('hardware')
    }
    assert sorted(kinds.values()) == ['LifecycleNode'] * 3 + ['Node'] * 2
    assert all(a.kwargs['namespace'] == '/rigA' for a in acts)
    (wear,) = [a for a in acts if a.kwargs['name'] == 'wear_monitor']
    assert _params(wear)['fresh_start'] is False
