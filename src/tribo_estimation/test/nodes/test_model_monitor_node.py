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


def test_windows_missed_during_an_overrun_are_skipped_not_queued(
    sim_record: Callable[..., object],
) -> None:
    # the first window's evaluation is held until two more windows have become due:
    # the worker then takes the newest of them, and the one between is never evaluated
    import threading

    from rclpy.parameter import Parameter

    from tribo_estimation.core.align import AlignedChunk
    from tribo_estimation.core.discrepancy.monitor import WindowData
    from tribo_estimation.errors import EstimationError
    from tribo_estimation.nodes import model_monitor as mm

    fs = 2_000.0
    rec = sim_record(2.0, fs, seed=2)
    ends: list[float] = []
    entered, release = threading.Event(), threading.Event()

    def held(w: WindowData) -> object:
        ends.append(float(w.time[-1]))
        entered.set()
        release.wait(timeout=60.0)
        raise EstimationError('not evaluated in this test')  # nothing to publish

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        over = {'window': 1.0, 'hop': 0.5}
        node = mm.ModelMonitorNode(
            parameter_overrides=[Parameter(k, value=v) for k, v in over.items()],
            context=context,
        )
        try:
            node._monitor.evaluate = held  # type: ignore[method-assign]

            def chunk(a: float, b: float) -> AlignedChunk:
                i, j = round(a * fs), round(b * fs)
                return AlignedChunk(
                    i, a, fs, rec.torsion_moment[i:j], rec.angular_acceleration[i:j],
                    rec.speed[i:j],
                )  # fmt: skip

            node._feed([chunk(0.0, 1.0)])  # the first window is due (ends at 1 s)
            assert entered.wait(timeout=60.0), 'the worker never took the first window'
            node._feed([chunk(1.0, 1.5)])  # due while the first is evaluated: ends at 1.5 s
            node._feed([chunk(1.5, 2.0)])  # and the next (2 s): it replaces the 1.5 s one
            release.set()
            deadline = time.monotonic() + 60.0
            while len(ends) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(0.3)  # a queued third evaluation would start within this
        finally:
            release.set()
            node.close()
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    # the windows end on the last sample before 1 s and 2 s (within one sample)
    assert len(ends) == 2, ends
    assert ends[0] == pytest.approx(1.0, abs=1.5 / fs), ends
    assert ends[1] == pytest.approx(2.0, abs=1.5 / fs), ends
