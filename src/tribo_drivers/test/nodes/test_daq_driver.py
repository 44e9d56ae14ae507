"""Driver nodes end to end (needs rclpy + tribo_msgs: ``source env.sh``)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tribo_drivers.core.emulators import (
    CanEmulator,
    CounterEmulator,
    DaqEmulator,
    SlcanPtyDevice,
    default_daq_signal,
)

pytestmark = pytest.mark.ros
pytest.importorskip('tribo_msgs', reason='needs the built workspace: source env.sh')

ROOT = Path(__file__).resolve().parents[3]
DOMAIN = os.environ['ROS_DOMAIN_ID']  # per test worker (root conftest.py)


def ros_env() -> dict[str, str]:
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = DOMAIN
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['TRIBO_ROOT'] = str(ROOT)
    return env


def start_node(module: str, params: dict[str, Any]) -> subprocess.Popen[bytes]:
    args = [sys.executable, '-m', f'tribo_drivers.nodes.{module}', '--ros-args']
    for k, v in params.items():
        args += ['-p', f'{k}:={v}']
    return subprocess.Popen(args, env=ros_env(), start_new_session=True)


def stop_node(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(5)


@pytest.fixture()
def listener() -> Any:
    os.environ['ROS_DOMAIN_ID'] = DOMAIN
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    import rclpy

    rclpy.init()
    node = rclpy.create_node('driver_test_listener')
    yield node
    node.destroy_node()
    rclpy.try_shutdown()


def spin_until(node: Any, cond: Callable[[], bool], timeout: float) -> None:
    import rclpy

    end = time.monotonic() + timeout
    while time.monotonic() < end and not cond():
        rclpy.spin_once(node, timeout_sec=0.05)


def test_daq_node_publishes_contiguous_blocks(listener: Any) -> None:
    from diagnostic_msgs.msg import DiagnosticArray

    from tribo_common.qos import data_qos
    from tribo_msgs.msg import SampleBlock

    emu = DaqEmulator(2000.0, start_index=1000)
    emu.start()
    blocks: list[Any] = []
    diags: list[Any] = []
    listener.create_subscription(SampleBlock, '/rig/torsion_moment', blocks.append, data_qos())
    listener.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 10)
    proc = start_node(
        'daq_driver',
        {
            'port': emu.path,
            'sample_rate': 2000.0,
            'block_size': 20,
            'torque_gain': 1e-3,
            'torque_offset': 5.0,
        },
    )
    try:
        spin_until(listener, lambda: len(blocks) > 150 and len(diags) > 2, 20.0)
    finally:
        stop_node(proc)
        emu.close()
    assert proc.returncode == 0
    assert len(blocks) > 150
    firsts = [b.first_index for b in blocks]
    sizes = [len(b.data) for b in blocks]
    # no gaps in a clean stream: each block starts where the previous ended
    assert all(f + n == g for f, n, g in zip(firsts, sizes, firsts[1:], strict=False))
    idx = np.arange(firsts[0], firsts[-1] + sizes[-1])
    want = (default_daq_signal(idx)[0] - 5.0) * 1e-3
    got = np.concatenate([np.asarray(b.data) for b in blocks])
    np.testing.assert_allclose(got, want, rtol=1e-12)  # float64 rounding only
    assert blocks[0].unit == 'N m' and blocks[0].sample_rate == 2000.0
    stamps = np.array([b.header.stamp.sec + 1e-9 * b.header.stamp.nanosec for b in blocks])
    assert abs(time.time() - stamps[-1]) < 30.0  # host wall-clock time
    # stamps follow the sample index: 20 samples at 2 kHz = 10 ms per block (1 ms tolerance
    # for the min-latency estimator's early corrections)
    assert np.median(np.diff(stamps)) == pytest.approx(0.010, abs=1e-3)
    status = [s for d in diags for s in d.status if s.name.startswith('daq_driver')]
    assert status and status[-1].level == b'\x00', status[-1].message
    values = {kv.key: kv.value for kv in status[-1].values}
    assert float(values['rate']) == pytest.approx(2000.0, rel=0.2)  # 2 s window at 2 kHz
    assert values['crc_errors'] == '0' and values['gaps'] == '0'


def test_counter_node(listener: Any) -> None:
    from tribo_common.qos import data_qos
    from tribo_msgs.msg import DetectorCounts

    emu = CounterEmulator(1000)
    emu.start()
    got: list[Any] = []
    listener.create_subscription(DetectorCounts, '/nvct/counts', got.append, data_qos())
    proc = start_node('counter_driver', {'port': emu.path, 'dwell': 0.1})
    try:
        spin_until(listener, lambda: len(got) >= 5, 20.0)
    finally:
        stop_node(proc)
        emu.close()
    assert proc.returncode == 0
    assert len(got) >= 5
    sent = {r.seq: r for r in emu.sent}
    for m in got:
        assert m.counts == sent[m.seq].counts
        assert m.t_end - m.t_start == pytest.approx(0.1, abs=1e-9)
    assert [m.seq for m in got] == list(range(got[0].seq, got[0].seq + len(got)))


def test_can_node_over_slcan(listener: Any) -> None:
    from tribo_common.qos import data_qos
    from tribo_drivers.core.can_protocol import ACCEL_ID, FORCE_TEMP_ID, SPEED_ID, CanCodec
    from tribo_msgs.msg import SampleBlock

    dev = SlcanPtyDevice()
    dev.start()
    codec = CanCodec(ROOT / 'config' / 'tribo.dbc')
    emu = CanEmulator(
        codec, dev.send, rates={ACCEL_ID: 200.0, SPEED_ID: 200.0, FORCE_TEMP_ID: 50.0}
    )
    temps: list[Any] = []
    listener.create_subscription(SampleBlock, '/can/oil_temperature', temps.append, data_qos())
    proc = start_node(
        'can_driver',
        {'interface': 'slcan', 'channel': dev.path, 'bitrate': 500000,
         'oil_temperature_topic': '/can/oil_temperature'},
    )  # fmt: skip
    try:
        spin_until(listener, lambda: dev.is_open, 10.0)
        emu.start()
        spin_until(listener, lambda: len(temps) >= 20, 20.0)
    finally:
        emu.stop()
        stop_node(proc)
        dev.close()
    assert len(temps) >= 20
    assert temps[0].unit == 'K'
    data = np.concatenate([np.asarray(t.data) for t in temps])
    assert np.all((data > 313.0) & (data < 314.2))  # 40.00..40.99 degC in kelvin


def test_daq_lifecycle_configure_activate_deactivate_cleanup(listener: Any) -> None:
    """configure opens the port, activate streams, deactivate stops publishing, cleanup
    releases the stream; a second configure/activate resumes with the lost samples
    accounted as a gap (the next block starts at the right index)."""
    import rclpy
    from rclpy.lifecycle import TransitionCallbackReturn
    from rclpy.parameter import Parameter

    from tribo_common.qos import data_qos
    from tribo_drivers.nodes.daq_driver import DaqDriver
    from tribo_msgs.msg import SampleBlock

    emu = DaqEmulator(2000.0)
    emu.start()
    blocks: list[Any] = []
    listener.create_subscription(SampleBlock, '/rig/torsion_moment', blocks.append, data_qos())
    params = {'port': emu.path, 'sample_rate': 2000.0, 'block_size': 20, 'autostart': False}
    node = DaqDriver(parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    ex = rclpy.executors.SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(listener)

    def spin(seconds: float, until: Callable[[], bool] = lambda: False) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end and not until():
            ex.spin_once(timeout_sec=0.05)

    try:
        assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert node.stream is not None  # configure opened the port
        spin(1.0)
        assert blocks == []  # configured but inactive: nothing published
        assert node.trigger_activate() == TransitionCallbackReturn.SUCCESS
        spin(10.0, lambda: len(blocks) >= 20)
        assert len(blocks) >= 20
        assert node.trigger_deactivate() == TransitionCallbackReturn.SUCCESS
        spin(0.5)
        n_after_deactivate = len(blocks)
        spin(1.0)
        assert len(blocks) == n_after_deactivate  # inactive: no more data
        assert node.trigger_cleanup() == TransitionCallbackReturn.SUCCESS
        assert node.stream is None  # cleanup released the port
        spin(0.5)  # the emulator keeps streaming into the closed port
        assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert node.trigger_activate() == TransitionCallbackReturn.SUCCESS
        spin(10.0, lambda: len(blocks) >= n_after_deactivate + 20)
        resumed = blocks[n_after_deactivate:]
        assert len(resumed) >= 20
        before = blocks[n_after_deactivate - 1]
        # samples sent while released are lost and shown as a gap, never bridged
        assert resumed[0].first_index > before.first_index + len(before.data)
        firsts = [b.first_index for b in resumed]
        sizes = [len(b.data) for b in resumed]
        assert all(f + n == g for f, n, g in zip(firsts, sizes, firsts[1:], strict=False))
    finally:
        emu.close()  # first, while the driver still reads (a full pty would block the writer)
        node.trigger_deactivate()
        node.destroy_node()
