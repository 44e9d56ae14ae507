"""The counter_driver node end to end (needs rclpy + tribo_msgs: ``source env.sh``)."""

from __future__ import annotations

from typing import Any

import pytest

from tribo_drivers.core.emulators import (
    CounterEmulator,
)

pytestmark = pytest.mark.ros
pytest.importorskip('tribo_msgs', reason='needs the built workspace: source env.sh')


def test_counter_node(listener: Any, drivers: Any) -> None:
    from tribo_common.qos import data_qos
    from tribo_msgs.msg import DetectorCounts

    emu = CounterEmulator(1000)
    emu.start()
    got: list[Any] = []
    listener.create_subscription(DetectorCounts, '/nvct/counts', got.append, data_qos())
    proc = drivers.start('counter_driver', {'port': emu.path, 'dwell': 0.1})
    try:
        drivers.spin_until(listener, lambda: len(got) >= 5, 20.0)
    finally:
        drivers.stop(proc)
        emu.close()
    assert proc.returncode == 0
    assert len(got) >= 5
    sent = {r.seq: r for r in emu.sent}
    for m in got:
        assert m.counts == sent[m.seq].counts
        assert m.t_end - m.t_start == pytest.approx(0.1, abs=1e-9)
    assert [m.seq for m in got] == list(range(got[0].seq, got[0].seq + len(got)))
