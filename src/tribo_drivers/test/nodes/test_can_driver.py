"""The can_driver node over slcan end to end (needs rclpy + tribo_msgs: ``source env.sh``)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tribo_drivers.core.can_protocol import CanCodec
from tribo_drivers.core.emulators import (
    CanEmulator,
    SlcanPtyDevice,
)

pytestmark = pytest.mark.ros
pytest.importorskip('tribo_msgs', reason='needs the built workspace: source env.sh')


def test_can_node_over_slcan(listener: Any, drivers: Any, codec: CanCodec) -> None:
    from tribo_common.qos import data_qos
    from tribo_drivers.core.can_protocol import ACCEL_ID, FORCE_TEMP_ID, SPEED_ID
    from tribo_msgs.msg import SampleBlock

    dev = SlcanPtyDevice()
    dev.start()
    emu = CanEmulator(
        codec, dev.send, rates={ACCEL_ID: 200.0, SPEED_ID: 200.0, FORCE_TEMP_ID: 50.0}
    )
    temps: list[Any] = []
    listener.create_subscription(SampleBlock, '/can/oil_temperature', temps.append, data_qos())
    proc = drivers.start(
        'can_driver',
        {'interface': 'slcan', 'channel': dev.path, 'bitrate': 500000,
         'oil_temperature_topic': '/can/oil_temperature'},
    )  # fmt: skip
    try:
        drivers.spin_until(listener, lambda: dev.is_open, 10.0)
        emu.start()
        drivers.spin_until(listener, lambda: len(temps) >= 20, 20.0)
    finally:
        emu.stop()
        drivers.stop(proc)
        dev.close()
    assert len(temps) >= 20
    assert temps[0].unit == 'K'
    data = np.concatenate([np.asarray(t.data) for t in temps])
    assert np.all((data > 313.0) & (data < 314.2))  # 40.00..40.99 degC in kelvin
