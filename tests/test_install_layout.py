"""The install space has the layout `ros2 run` expects on a full ROS install."""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest

from tribo_common import nodes

ROOT = Path(__file__).resolve().parents[1]
INSTALL = ROOT / 'install'
PACKAGES = (
    'tribo_msgs',
    'tribo_common',
    'tribo_drivers',
    'tribo_estimation',
    'tribo_nvct',
    'tribo_bringup',
)


def console_scripts(pkg: str) -> dict[str, str]:
    """Executable name -> ``module:function`` of a package: its node table rows, and the
    ``tribo`` CLI of tribo_bringup (the one console script that is not a node)."""
    scripts = dict(line.split(' = ', 1) for line in nodes.console_scripts(pkg))
    if pkg == 'tribo_bringup':
        scripts['tribo'] = 'tribo_bringup.cli:main'
    return scripts


pytestmark = pytest.mark.skipif(not INSTALL.is_dir(), reason='workspace not built (make setup)')


@pytest.mark.parametrize('pkg', PACKAGES)
def test_ament_index_marker(pkg: str) -> None:
    marker = INSTALL / pkg / 'share' / 'ament_index' / 'resource_index' / 'packages' / pkg
    assert marker.is_file(), f'missing ament index marker {marker}'
    assert (INSTALL / pkg / 'share' / pkg / 'package.xml').is_file()


#: Every package that installs executables: the node table's packages and the CLI's.
EXEC_PACKAGES = sorted({n.package for n in nodes.NODES} | {'tribo_bringup'})


def test_setup_py_takes_its_console_scripts_from_the_node_table() -> None:
    for pkg in EXEC_PACKAGES:
        text = (ROOT / 'src' / pkg / 'setup.py').read_text()
        assert 'console_scripts(PACKAGE)' in text, pkg
    assert len(nodes.BY_NAME) == len(nodes.NODES), 'node names must be unique'


@pytest.mark.parametrize('pkg', EXEC_PACKAGES)
def test_executables_in_lib_pkg(pkg: str) -> None:
    declared = console_scripts(pkg)
    assert declared, pkg
    for exe in sorted(declared):
        path = INSTALL / pkg / 'lib' / pkg / exe
        assert path.is_file(), f'{path} missing (ros2 run {pkg} {exe} would fail)'
        assert os.access(path, os.X_OK), f'{path} is not executable'
    # the installed scripts run the table's module:function (the built entry points)
    assert _built_entry_points(pkg) == declared


def _built_entry_points(pkg: str) -> dict[str, str]:
    """The console scripts of the built distribution of ``pkg`` (what `ros2 run` loads)."""
    import importlib.metadata

    where = [str(p) for p in (INSTALL / pkg / 'lib').glob('python3*/site-packages')]
    where.append(str(ROOT / 'build' / pkg))  # --symlink-install: the egg-info of the build
    for dist in importlib.metadata.distributions(path=where):
        if dist.metadata['Name'].replace('-', '_') == pkg:
            return {e.name: e.value for e in dist.entry_points if e.group == 'console_scripts'}
    raise AssertionError(f'{pkg}: no built distribution in {where}')


@pytest.mark.parametrize('pkg', EXEC_PACKAGES)
def test_entry_points_resolve(pkg: str) -> None:
    """Each console script's target module exists and defines main()."""
    for target in console_scripts(pkg).values():
        module, func = target.split(':')
        src = ROOT / 'src' / pkg / (module.replace('.', '/') + '.py')
        assert src.is_file(), f'{target}: {src} missing'
        defs = {n.name for n in ast.parse(src.read_text()).body if isinstance(n, ast.FunctionDef)}
        assert func in defs, f'{target}: no function {func}() in {src}'


def test_messages_built() -> None:
    share = INSTALL / 'tribo_msgs' / 'share' / 'tribo_msgs' / 'msg'
    for name in (
        'SampleBlock',
        'DetectorCounts',
        'FrictionEstimate',
        'WearState',
        'ModelDiscrepancy',
    ):
        assert (share / f'{name}.msg').is_file(), f'{name}.msg not installed'


#: Modules of tribo_common that import no rclpy: the cores and the packages' setup.py may
#: use them (one parameter spec, one YAML loader, one topic table, one node table,
#: ROS_HOME, the bag reader and its errors); the rest of tribo_common is rclpy.
RCLPY_FREE_COMMON = (
    'paramspec', 'yamlio', 'topics', 'nodes', 'rosenv', 'bag_types', 'bag_read', 'bag_salvage',
    'errors',
)  # fmt: skip


def _imports(py: Path) -> list[str]:
    mods: list[str] = []
    for node in ast.walk(ast.parse(py.read_text())):
        if isinstance(node, ast.Import):
            mods += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            mods += [node.module] + [f'{node.module}.{a.name}' for a in node.names]
    return mods


def _forbidden(mod: str) -> bool:
    top, _, rest = mod.partition('.')
    if top in ('rclpy', 'tribo_msgs'):
        return True
    if top == 'tribo_common':
        return rest.split('.')[0] not in RCLPY_FREE_COMMON
    return False


def test_cores_never_import_rclpy() -> None:
    """Core modules (physics, estimation, decoding) are plain Python: no rclpy, no
    messages, and of tribo_common only its rclpy-free modules, which in turn import
    neither rclpy nor the rest of tribo_common."""
    offenders = []
    for core in ROOT.glob('src/*/*/core'):
        for py in core.rglob('*.py'):
            mods = [m for m in _imports(py) if m != 'tribo_common']
            if any(_forbidden(m) for m in mods):
                offenders.append(str(py.relative_to(ROOT)))
    assert not offenders, f'core modules import rclpy/messages: {offenders}'
    common = ROOT / 'src' / 'tribo_common' / 'tribo_common'
    for name in RCLPY_FREE_COMMON:
        mods = _imports(common / f'{name}.py')
        assert not any(_forbidden(m) or m.startswith('rclpy') for m in mods), (name, mods)


def test_config_and_launch_files_installed_into_share() -> None:
    share = INSTALL / 'tribo_bringup' / 'share' / 'tribo_bringup'
    for launch in sorted((ROOT / 'src' / 'tribo_bringup' / 'launch').glob('*.launch.py')):
        assert (share / 'launch' / launch.name).is_file(), launch.name
    # every config example, so `ros2 launch tribo_bringup sim.launch.py` finds them
    wanted = sorted(p.name for p in (ROOT / 'config').iterdir() if p.is_file())
    installed = sorted(p.name for p in (share / 'config').iterdir())
    assert installed == wanted
    assert (share / 'config' / 'rig.yaml').read_text() == (ROOT / 'config' / 'rig.yaml').read_text()


def _exec_depends(pkg: str) -> set[str]:
    import xml.etree.ElementTree as ET

    root = ET.parse(ROOT / 'src' / pkg / 'package.xml').getroot()
    return {e.text or '' for e in root.iter() if e.tag in ('exec_depend', 'depend')}


def test_bringup_manifest_names_the_launch_and_bag_tools() -> None:
    deps = _exec_depends('tribo_bringup')
    for dep in ('launch', 'launch_ros', 'ament_index_python', 'ros2launch', 'ros2bag'):
        assert dep in deps, dep


def test_third_party_packages_are_declared() -> None:
    """Each third-party Python package is an exec_depend (rosdep key) of the package that
    imports it, or, without a rosdep key, named in its manifest's pip comment."""
    wanted = {
        'tribo_estimation': {'python3-numba'},
        'tribo_bringup': {'python3-numba', 'rosbags', 'foxglove-sdk'},
        'tribo_drivers': {'python3-serial', 'python3-can', 'cantools'},
    }
    for pkg, names in wanted.items():
        text = (ROOT / 'src' / pkg / 'package.xml').read_text()
        deps = _exec_depends(pkg)
        for name in names:
            assert name in deps or (f' {name} (' in text and 'pip' in text), (pkg, name)
    readme = (ROOT / 'README.md').read_text()
    for name in ('rosbags', 'foxglove-sdk', 'cantools'):
        assert name in readme, name


@pytest.mark.parametrize('pkg', PACKAGES[1:])
def test_setup_installs_only_files_of_the_package(pkg: str) -> None:
    text = (ROOT / 'src' / pkg / 'setup.py').read_text()
    assert '../' not in text, f'{pkg}/setup.py installs files from outside the package'
