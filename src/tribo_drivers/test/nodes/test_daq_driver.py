"""The daq_driver node end to end (needs rclpy + tribo_msgs: ``source env.sh``)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from tribo_drivers.core.emulators import (
    DaqEmulator,
    default_daq_signal,
)

pytestmark = pytest.mark.ros
pytest.importorskip('tribo_msgs', reason='needs the built workspace: source env.sh')


def test_daq_node_publishes_contiguous_blocks(listener: Any, drivers: Any) -> None:
    from diagnostic_msgs.msg import DiagnosticArray

    from tribo_common.qos import data_qos
    from tribo_msgs.msg import SampleBlock

    emu = DaqEmulator(2000.0, start_index=1000)
    emu.start()
    blocks: list[Any] = []
    diags: list[Any] = []
    listener.create_subscription(SampleBlock, '/rig/torsion_moment', blocks.append, data_qos())
    listener.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 10)
    proc = drivers.start(
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
        drivers.spin_until(listener, lambda: len(blocks) > 150 and len(diags) > 2, 20.0)
    finally:
        drivers.stop(proc)
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
