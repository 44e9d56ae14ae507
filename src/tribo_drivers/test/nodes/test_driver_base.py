"""The drivers' lifecycle shell (nodes/driver_base.py) on the DAQ driver (needs rclpy)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest

from tribo_drivers.core.emulators import (
    DaqEmulator,
)

pytestmark = pytest.mark.ros
pytest.importorskip('tribo_msgs', reason='needs the built workspace: source env.sh')


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
