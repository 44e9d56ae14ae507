"""The model_monitor node investigates a window whose budget ended (in-process rclpy).

A record of config/rig_hidden_frictional_lag.yaml is handed to the node's aligned
input as one chunk; the node's time budget (1 ms) ends before any family is
screened, so its window is ``incomplete``. Checked: the node publishes that window
and then, from its second thread, the investigation of the same window, which names
the hidden lag.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import pytest

pytestmark = pytest.mark.ros

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

rclpy = pytest.importorskip('rclpy', reason='needs rclpy: run under `make test`')
pytest.importorskip('tribo_msgs.msg', reason='needs the built workspace (source env.sh)')


def test_an_incomplete_window_is_investigated_and_published_again(
    sim_record: Callable[..., object], monkeypatch: pytest.MonkeyPatch
) -> None:
    from rclpy.parameter import Parameter

    from tribo_estimation.core.align import AlignedChunk
    from tribo_estimation.core.discrepancy.monitor import WindowResult
    from tribo_estimation.nodes import model_monitor as mm

    rec = sim_record(3.0, 10_000.0, rig='rig_hidden_frictional_lag.yaml', seed=4)
    sent: list[WindowResult] = []
    real = mm.to_msg

    def spy(r: WindowResult, offset: float = 0.0) -> object:
        sent.append(r)
        return real(r, offset)

    monkeypatch.setattr(mm, 'to_msg', spy)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        # two families keep the investigation short (the full library: the pipeline tests)
        over = {
            'window': 2.5,
            'hop': 2.5,
            'time_budget': 1e-3,
            'candidates': ['viscous_friction', 'frictional_lag'],
        }
        node = mm.ModelMonitorNode(
            parameter_overrides=[Parameter(k, value=v) for k, v in over.items()],
            context=context,
        )
        try:
            chunk = AlignedChunk(
                0, 0.0, 10_000.0, rec.torsion_moment, rec.angular_acceleration, rec.speed
            )
            node._feed([chunk])
            deadline = time.monotonic() + 120.0
            while len(sent) < 2 and time.monotonic() < deadline:
                time.sleep(0.2)
        finally:
            node.close()
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    assert len(sent) == 2, sent
    window, inquiry = sent
    # the window: its screening was cut by the budget, so it asks for an investigation
    assert not window.complete and 'incomplete' in window.quality, window
    # the investigation: the same window, every family screened, against its null law
    assert inquiry.quality.startswith('investigation') and inquiry.complete, inquiry
    assert (inquiry.t_start, inquiry.t_end) == (window.t_start, window.t_end)
    # the same baseline (the same steps on the same samples), and the hidden lag named
    assert (inquiry.mu0, inquiry.residual_rms) == (window.mu0, window.residual_rms)
    assert inquiry.verdict == 'named' and inquiry.candidate == 'frictional_lag', inquiry
    assert node.published == 2
