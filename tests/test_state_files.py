"""The wear monitor keeps its state under $ROS_HOME (default ~/.ros), and a simulated
`tribo run` starts a fresh wear test unless asked to resume."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from support import ROOT, requires_ros, tribo_cmd

pytestmark = [requires_ros, pytest.mark.ros]


@pytest.mark.parametrize('ros_home', ['set', 'unset'])
def test_default_state_file_is_under_ros_home(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ros_home: str
) -> None:
    import rclpy
    from rclpy.parameter import Parameter

    from tribo_nvct.nodes.wear_monitor import WearMonitor

    if ros_home == 'set':
        monkeypatch.setenv('ROS_HOME', str(tmp_path / 'roshome'))
        want = tmp_path / 'roshome' / 'tribo_nvct' / 'wear_state.json'
    else:
        monkeypatch.delenv('ROS_HOME', raising=False)
        monkeypatch.setenv('HOME', str(tmp_path / 'home'))
        want = tmp_path / 'home' / '.ros' / 'tribo_nvct' / 'wear_state.json'
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = WearMonitor(
            context=context,
            parameter_overrides=[Parameter('nvct_config', value=str(ROOT / 'config/nvct.yaml'))],
        )
        try:
            assert Path(node.state_file) == want
        finally:
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def _run(state: Path, *extra: str) -> str:
    r = subprocess.run(
        tribo_cmd(
            'run', '--nodes', 'sim_detector', 'wear_monitor', '--duration', '2',
            '--wear-state', str(state), *extra,
        ),
        capture_output=True, text=True, timeout=120, cwd=ROOT,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return r.stderr


def _restored(log: str) -> int:
    found = re.search(r'(\d+) dwells restored', log)
    assert found, log
    return int(found.group(1))


@pytest.mark.slow
def test_simulated_run_starts_fresh_unless_resumed(tmp_path: Path) -> None:
    state = tmp_path / 'wear_state.json'
    assert _restored(_run(state)) == 0
    assert state.is_file()
    assert _restored(_run(state, '--resume')) > 0  # the saved test goes on
    assert _restored(_run(state)) == 0  # a new test; the old one kept as a backup
    assert list(tmp_path.glob('wear_state.json.*.bak'))


@pytest.mark.slow
def test_tribo_run_starts_the_daq_driver(tmp_path: Path) -> None:
    """`tribo run --no-sim --daq PORT` runs the lifecycle DAQ driver in the graph (a
    machine without ros2 launch runs a real rig); here on the DAQ emulator's pty."""
    import os

    from tribo_bringup import bagio
    from tribo_drivers.core.emulators import DaqEmulator

    emu = DaqEmulator(10_000.0)
    emu.start()
    bag = tmp_path / 'daq'
    try:
        r = subprocess.run(
            tribo_cmd(
                'run', '--no-sim', '--daq', emu.path, '--duration', '4', '--record', str(bag),
                '--wear-state', str(tmp_path / 'w.json'),
            ),
            capture_output=True, text=True, timeout=120, cwd=ROOT,
            env={**os.environ, 'TRIBO_ROOT': str(ROOT)},
        )  # fmt: skip
    finally:
        emu.close()
    assert r.returncode == 0, r.stderr
    assert 'daq_driver' in r.stderr
    checks = {c.topic: c for c in bagio.check_streams(bag)}
    for topic in bagio.RIG_TOPICS:
        # the driver streamed into the bag without loss (how much of the 4 s depends on
        # how fast the graph came up on a loaded machine: 0.7 s seen; 0.2 s asked)
        c = checks[topic]
        assert c.samples >= 2_000 and c.missing == 0 and c.gaps == 0, (checks, r.stderr)
