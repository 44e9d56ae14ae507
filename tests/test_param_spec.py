"""One parameter table: the nodes, the RIG.yaml loader, config/ and the docs agree with the specs.

The rig's parameters are specified once (``tribo_estimation.core.rigspec``),
each node's in its package's ``nodes/specs.py``; the nodes declare from them,
the loader validates with them, ``docs/parameters.md`` is rendered from them.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from support import requires_ros

from tribo_bringup.paramdocs import NODE_PARAMS, render
from tribo_common import nodes
from tribo_common.paramspec import ParamSpec, SpecError
from tribo_estimation.core import config as rig_config
from tribo_estimation.core.model import RigParams
from tribo_estimation.core.rigspec import RIG_FIELDS, RIG_SPEC
from tribo_estimation.errors import InvalidParameterError

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config'

#: Values a test start needs (no device opened, any free port, required files).
OVERRIDES: dict[str, dict[str, Any]] = {
    'live_bridge': {'port': 0},
    'wear_monitor': {'nvct_config': str(CONFIG / 'nvct.yaml'), 'state_file': ''},
    'sim_detector': {'sim_config': str(CONFIG / 'sim_detector.yaml')},
    'daq_driver': {'autostart': False},
    'can_driver': {'autostart': False},
    'counter_driver': {'autostart': False},
}

#: Parameters a node declares outside the specs: ROS's own, the hidden effects.
NOT_FROM_SPEC = re.compile(r'^(use_sim_time|start_type_description_service|effects\..+)$')


def _bounds(s: ParamSpec) -> tuple[Any, ...]:
    return (s.unit, s.default, s.lower, s.upper, s.type, s.read_only)


def test_every_node_module_is_in_the_node_table() -> None:
    """A node module with a main() (an executable) is a row of the node table, and every
    row names an existing module with that main() and class."""
    found = set()
    for py in ROOT.glob('src/*/*/nodes/*.py'):
        text = py.read_text()
        if re.search(r'^def main\(', text, re.M):
            found.add('.'.join(py.relative_to(py.parents[2]).with_suffix('').parts))
    table = {n.module for n in nodes.NODES}
    assert found == table, found ^ table
    for n in nodes.NODES:
        src = ROOT / 'src' / n.package / (n.module.replace('.', '/') + '.py')
        assert f'class {n.class_name}(' in src.read_text(), n.name
    assert set(NODE_PARAMS) == set(nodes.BY_NAME)


@pytest.mark.parametrize('node', sorted(NODE_PARAMS))
def test_node_rig_parameters_are_the_rig_table(node: str) -> None:
    specs = NODE_PARAMS[node]
    names = [s.name for s in specs]
    assert len(names) == len(set(names)), names
    for s in specs:
        if s.name in RIG_SPEC:
            # one table: the same unit, default and bounds in every node (descriptions may say
            # what the node does with the value)
            assert _bounds(s) == _bounds(RIG_SPEC[s.name]), (node, s.name)


def test_tab1_and_loader_ranges_come_from_the_spec() -> None:
    rig = RigParams.tab1()
    for name in RIG_FIELDS:
        assert getattr(rig, name) == RIG_SPEC[name].default, name
    assert RigParams.tab1(F_N=0.0, R=0.1).F_N == 0.0
    assert set(rig_config.REQUIRED_KEYS) | set(rig_config.OPTIONAL_KEYS) == {*RIG_SPEC, 'effects'}
    for key, (lo, hi, unit) in rig_config.RANGES.items():
        s = RIG_SPEC[key]
        assert (lo, hi, unit) == (s.lower, s.upper, s.unit), key


def test_shipped_rig_file_holds_the_defaults() -> None:
    data = yaml.safe_load((CONFIG / 'rig.yaml').read_text())
    for name, s in RIG_SPEC.items():
        assert data[name] == s.default, name


@pytest.mark.parametrize('key', sorted(RIG_SPEC))
def test_loader_refuses_just_outside_the_bounds(key: str) -> None:
    base = {k: RIG_SPEC[k].default for k in rig_config.REQUIRED_KEYS}
    s = RIG_SPEC[key]
    assert s.lower is not None and s.upper is not None
    for bad in (s.upper * 1.01 + 1e-9, s.lower - abs(s.lower) * 0.01 - 1e-9):
        with pytest.raises(InvalidParameterError, match=re.escape(repr(key))):
            rig_config.rig_config_from_dict({**base, key: bad}, 'x.yaml')
    for good in (s.lower, s.upper):  # the bounds themselves are allowed
        rig_config.rig_config_from_dict({**base, key: good}, 'x.yaml')


def test_spec_refuses_a_default_outside_its_bounds() -> None:
    with pytest.raises(SpecError, match='default'):
        ParamSpec('x', 'm', 2.0, 0.0, 1.0, 'a length')
    with pytest.raises(SpecError, match='type'):
        ParamSpec('x', '', 1, description='a flag', type='bool')
    s = ParamSpec('x', 'm', 0.5, 0.0, 1.0, 'a length')
    assert s.violation(1.0) is None
    assert s.violation(1.5) is not None and 'm' in str(s.violation(1.5))
    assert s.violation(math.nan) is not None
    assert s.violation(True) is not None  # a bool is no number


def _param_files() -> list[tuple[str, str, dict[str, Any]]]:
    out = []
    for path in sorted(CONFIG.glob('*.yaml')):
        data = yaml.safe_load(path.read_text())
        if not isinstance(data, dict):
            continue
        for node, body in data.items():
            name = str(node).removeprefix('/**/')
            if isinstance(body, dict) and 'ros__parameters' in body and name in NODE_PARAMS:
                out.append((path.name, name, body['ros__parameters']))
    return out


@pytest.mark.parametrize(('file', 'node', 'params'), _param_files(), ids=lambda v: str(v)[:24])
def test_param_files_validate_against_the_spec(
    file: str, node: str, params: dict[str, Any]
) -> None:
    specs = {s.name: s for s in NODE_PARAMS[node]}
    for key, value in params.items():
        if NOT_FROM_SPEC.match(key):
            continue
        assert key in specs, f'{file}: {key!r} is not a parameter of {node}'
        problem = specs[key].violation(value)
        assert problem is None, f'{file}: {key} {problem}'
        if key in RIG_SPEC:  # the shipped files repeat Tab. 1: they must not drift from it
            assert value == RIG_SPEC[key].default, f'{file}: {key} = {value} is not Tab. 1'


def test_param_files_are_those_of_the_node_table() -> None:
    # sim_detector.yaml is the simulator's own file, not a ROS parameter file
    found = {(file, n) for file, n, _ in _param_files()}
    assert found == {(n.config, n.name) for n in nodes.NODES if n.config}


@pytest.mark.parametrize('path', sorted(CONFIG.glob('rig*.yaml')), ids=lambda p: p.name)
def test_rig_files_validate_against_the_spec(path: Path) -> None:
    data = yaml.safe_load(path.read_text())
    for key, value in data.items():
        if key == 'effects':
            continue
        assert key in RIG_SPEC, f'{path.name}: unknown key {key!r}'
        assert RIG_SPEC[key].violation(value) is None, (path.name, key)
    rig_config.load_rig_config(path)


def test_readme_rig_keys_exist_in_the_spec() -> None:
    text = (ROOT / 'README.md').read_text()
    section = text[text.index('### Configuration') :]
    lines = section.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith('- `rig.yaml`'))
    end = next(i for i in range(start + 1, len(lines)) if not lines[i].startswith('  '))
    bullet = ' '.join(lines[start:end]).split('—', 1)[1]
    spans = re.findall(r'`([^`]+)`', bullet)
    listed = {w.strip() for sp in spans if ',' in sp or sp in RIG_SPEC for w in sp.split(',')}
    listed |= {sp for sp in spans if sp == 'effects'}
    # every documented key exists, and every key is documented
    assert listed == {*RIG_SPEC, 'effects'}, listed ^ {*RIG_SPEC, 'effects'}
    assert 'docs/parameters.md' in section


def test_parameter_docs_are_current() -> None:
    doc = (ROOT / 'docs' / 'parameters.md').read_text()
    assert doc == render(), 'run: python -m tribo_bringup.paramdocs > docs/parameters.md'
    for specs in NODE_PARAMS.values():
        for s in specs:
            assert f'`{s.name}`' in doc


@requires_ros
@pytest.mark.ros
@pytest.mark.parametrize('node_name', sorted(nodes.BY_NAME))
def test_declared_parameters_come_from_the_spec(node_name: str) -> None:
    import rclpy
    from rcl_interfaces.msg import ParameterType
    from rclpy.parameter import Parameter

    cls = nodes.BY_NAME[node_name].node_class()
    specs = {s.name: s for s in NODE_PARAMS[node_name]}
    over = OVERRIDES.get(node_name, {})
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = cls(
            parameter_overrides=[Parameter(k, value=v) for k, v in over.items()],
            context=context,
        )
        try:
            declared = {n for n in node._parameters if not NOT_FROM_SPEC.match(n)}
            assert declared == set(specs), declared ^ set(specs)
            for name, s in specs.items():
                value = node.get_parameter(name).value
                want = list(s.default) if isinstance(s.default, tuple) else s.default
                if name not in over:
                    assert value == want, name
                d = node.describe_parameter(name)
                assert d.read_only == s.read_only, name
                assert s.unit in d.description and s.description in d.description, name
                if s.type == 'str_list':  # typed even when empty (rclpy: [] is a byte array)
                    assert d.type == ParameterType.PARAMETER_STRING_ARRAY, name
                if s.type == 'float' and (s.lower is not None or s.upper is not None):
                    (r,) = d.floating_point_range
                    lo = -math.inf if s.lower is None else s.lower
                    hi = math.inf if s.upper is None else s.upper
                    assert (r.from_value, r.to_value) == (lo, hi), name
                elif s.type == 'int' and (s.lower is not None or s.upper is not None):
                    (ir,) = d.integer_range
                    assert ir.from_value == int(s.lower if s.lower is not None else -(2**63)), name
                    assert ir.to_value == int(s.upper if s.upper is not None else 2**63 - 1), name
        finally:
            close = getattr(node, 'close', None)
            if callable(close):
                close()
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_sim_rig_uses_the_rig_spec_objects() -> None:
    from tribo_drivers.nodes.specs import SIM_RIG_PARAMS

    by_name = {s.name: s for s in SIM_RIG_PARAMS}
    assert all(by_name[n] is RIG_SPEC[n] for n in RIG_SPEC)
    assert RIG_SPEC['F_N'].violation(2e6) is not None  # 2 MN: kN typed as N
    assert RIG_SPEC['nominal_speed'].violation(300.0) is not None  # rpm typed as rad/s


def test_specs_import_no_rclpy() -> None:
    import subprocess
    import sys

    code = (
        'import sys, tribo_estimation.core.config, tribo_bringup.paramdocs; '
        "sys.exit(1 if 'rclpy' in sys.modules else 0)"
    )
    run = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr or 'rclpy imported by the specs or the RIG.yaml loader'


@requires_ros
@pytest.mark.ros
@pytest.mark.parametrize(
    ('name', 'value', 'word'),
    [('F_N', 0.0, 'F_N'), ('F_N', 2e6, 'F_N'), ('nominal_speed', -1.0, 'nominal_speed')],
)
def test_estimator_refuses_values_it_cannot_fit(name: str, value: float, word: str) -> None:
    import rclpy
    from rclpy.parameter import Parameter

    from tribo_common.params import ParameterError
    from tribo_estimation.nodes.friction_estimator import FrictionEstimatorNode

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        with pytest.raises(ParameterError, match=word):
            FrictionEstimatorNode(
                parameter_overrides=[Parameter(name, value=value)], context=context
            )
    finally:
        rclpy.try_shutdown(context=context)
