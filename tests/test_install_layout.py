"""The install space has the layout `ros2 run` expects on a full ROS install."""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest

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


def console_scripts(pkg: str) -> list[str]:
    """Executable names declared in a package's setup.py."""
    tree = ast.parse((ROOT / 'src' / pkg / 'setup.py').read_text())
    names: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and ' = ' in node.value:
            name, target = node.value.split(' = ', 1)
            if ':' in target:
                names.append(name.strip())
    return names


pytestmark = pytest.mark.skipif(not INSTALL.is_dir(), reason='workspace not built (make setup)')


@pytest.mark.parametrize('pkg', PACKAGES)
def test_ament_index_marker(pkg: str) -> None:
    marker = INSTALL / pkg / 'share' / 'ament_index' / 'resource_index' / 'packages' / pkg
    assert marker.is_file(), f'missing ament index marker {marker}'
    assert (INSTALL / pkg / 'share' / pkg / 'package.xml').is_file()


EXPECTED = {
    'tribo_drivers': {'sim_rig', 'sim_detector', 'daq_driver', 'counter_driver', 'can_driver'},
    'tribo_estimation': {'friction_estimator', 'model_monitor'},
    'tribo_nvct': {'wear_monitor'},
    'tribo_bringup': {'tribo', 'live_bridge'},
}


@pytest.mark.parametrize('pkg', sorted(EXPECTED))
def test_executables_in_lib_pkg(pkg: str) -> None:
    declared = set(console_scripts(pkg))
    assert EXPECTED[pkg] <= declared, f'{pkg}: setup.py lacks {EXPECTED[pkg] - declared}'
    for exe in sorted(declared):
        path = INSTALL / pkg / 'lib' / pkg / exe
        assert path.is_file(), f'{path} missing (ros2 run {pkg} {exe} would fail)'
        assert os.access(path, os.X_OK), f'{path} is not executable'


@pytest.mark.parametrize('pkg', sorted(EXPECTED))
def test_entry_points_resolve(pkg: str) -> None:
    """Each console script's target module exists and defines main()."""
    tree = ast.parse((ROOT / 'src' / pkg / 'setup.py').read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and ' = ' in node.value:
            _, target = node.value.split(' = ', 1)
            if ':' not in target:
                continue
            module, func = target.split(':')
            src = ROOT / 'src' / pkg / (module.replace('.', '/') + '.py')
            assert src.is_file(), f'{target}: {src} missing'
            defs = {
                n.name for n in ast.parse(src.read_text()).body if isinstance(n, ast.FunctionDef)
            }
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


#: Modules of tribo_common that import no rclpy: the cores may use them (one parameter
#: spec, one YAML loader, one topic table, ROS_HOME); the rest of tribo_common is rclpy.
RCLPY_FREE_COMMON = ('paramspec', 'yamlio', 'topics', 'rosenv')


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
