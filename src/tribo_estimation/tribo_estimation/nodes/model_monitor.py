"""ROS 2 node ``model_monitor``: the discrepancy workflow on a rolling window of the live rig.

Subscribes ``/rig/torsion_moment``, ``/rig/angular_acceleration``, ``/rig/speed``
(tribo_msgs/SampleBlock), aligns them by sample index (a gap or a restart
empties the window: windows never bridge missing samples) and every ``hop``
seconds evaluates the last ``window`` seconds with the missing-physics pipeline
(live budget): baseline fit of the paper's model (Equ. 1-8), noise floor, where the
residual concentrates, and the verdict (the effect family the window names, or the
best partial explanation). Publishes one
``/model/discrepancy`` (tribo_msgs/ModelDiscrepancy, reliable and latched)
per window.

Thin shell: the work is
:class:`tribo_estimation.core.discrepancy.monitor.WindowMonitor`. The
subscriptions only align and buffer; the windows are evaluated on a worker
thread (always the newest due window: if one evaluation overruns the hop, the
windows it missed are skipped, never queued); the worker first evaluates one short
simulated window (``WindowMonitor.warm_up``). A window whose time budget ended before
every family was screened (``complete`` False: flag ``incomplete``) is investigated
on a second thread with every family screened (``WindowMonitor.investigate``, several
hops), one at a time (a window arriving while one runs is not investigated); its
verdict is published as one more message for that window (flag ``investigation``).
Parameters: the RIG.yaml names (SI units, as the friction estimator) plus the monitor
settings, declared from their specs (:data:`PARAMS`); read-only after start.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence
from typing import Unpack

import numpy as np
from rclpy.node import Node

from tribo_common import topics
from tribo_common.msgconv import Block, float64_array, time_from_ns
from tribo_common.node_main import NodeOptions, PublishGate, run_node
from tribo_common.params import ParameterError, declare_specs
from tribo_common.qos import history_qos
from tribo_common.rig_streams import RIG_INPUTS, require_contact, subscribe_rig_streams
from tribo_estimation.core.align import AlignedChunk, AlignEvent
from tribo_estimation.core.discrepancy.monitor import (
    MonitorConfig,
    WindowData,
    WindowMonitor,
    WindowResult,
)
from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
from tribo_estimation.core.plausibility import IDLE_RELEASE_S, CheckedStream, Scales
from tribo_estimation.errors import EstimationError
from tribo_estimation.nodes.specs import MODEL_MONITOR_PARAMS
from tribo_msgs.msg import ModelDiscrepancy

#: Output topic.
OUTPUT_TOPIC = topics.MODEL_DISCREPANCY.name

#: Input topics and their channel names (:data:`tribo_common.rig_streams.RIG_INPUTS`).
TOPICS: dict[str, str] = RIG_INPUTS

#: Declared parameters (the rig's from the one rig table): :mod:`tribo_estimation.nodes.specs`.
PARAMS = MODEL_MONITOR_PARAMS

#: Longest wait of :meth:`ModelMonitorNode.close` for the window and the investigation
#: being evaluated [s] (``ros2 launch`` escalates to SIGTERM 5 s after its SIGINT).
CLOSE_WAIT_S = 2.0


class ModelMonitorNode(Node):
    """Live model monitor (see the module docstring)."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('model_monitor', **kwargs)
        v = declare_specs(self, PARAMS)
        require_contact(v)
        try:
            rig = RigParams.from_mapping(v.numbers(RigParams.field_names()))
            drive = DriveProfile(v.number('nominal_speed'), v.number('ramp_time'))
            self._friction = FrictionLaw(v.number('mu0'), v.number('mu_inf'), v.number('k'))
            cfg = MonitorConfig(
                window=v.number('window'),
                hop=v.number('hop'),
                candidates=tuple(str(c) for c in v.strings('candidates') if str(c)),
                time_budget=v.number('time_budget'),
                alpha=v.number('alpha'),
                replicas=v.integer('replicas'),
            )
        except EstimationError as exc:
            raise ParameterError(str(exc)) from exc
        self._monitor = WindowMonitor(rig, drive, k=v.number('k'), config=cfg)
        scales = None
        if v.flag('check_input'):
            scales = Scales.of(rig, self._friction, v.number('nominal_speed'))
        self._input = CheckedStream(scales, 'rig topics')
        self._idle_timer = self.create_timer(0.5 * IDLE_RELEASE_S, self._on_idle)
        self._lock = threading.Lock()
        self._cond = threading.Condition(self._lock)
        self._pending: tuple[WindowData, float] | None = None
        self._inquiry: tuple[WindowData, float, WindowResult] | None = None
        self._inquiring = False
        self._closing = False
        self.published = 0
        self._pub = self.create_publisher(ModelDiscrepancy, OUTPUT_TOPIC, history_qos())
        self._gate = PublishGate()
        self._subs = subscribe_rig_streams(self, self._on_block)
        self._worker = threading.Thread(target=self._work, name='model_monitor', daemon=True)
        self._worker.start()
        self._investigator = threading.Thread(
            target=self._investigate, name='model_monitor_investigation', daemon=True
        )
        self._investigator.start()
        self.get_logger().info(
            f'model monitor: {cfg.window:g} s window every {cfg.hop:g} s, '
            f'{len(cfg.candidates) or "all"} effect families, alpha {cfg.alpha:g}, '
            f'{cfg.replicas} replicas, budget {cfg.time_budget:g} s'
        )

    # ------------------------------------------------------------------ input
    def _on_block(self, b: Block) -> None:
        """Align and check one block; hand the newest due window to the worker."""
        try:
            events = self._input.push(
                b.channel, b.first_index, b.sample_rate, b.stamp_ns * 1e-9, b.data
            )
        except EstimationError as exc:
            # a failed input check repeats on every block: log it every 5 s
            self.get_logger().error(f'{b.channel}: block dropped: {exc}', throttle_duration_sec=5.0)
            return
        self._feed(events)

    def _on_idle(self) -> None:
        """Release the samples the input checks hold once the input has paused."""
        try:
            events = self._input.release(IDLE_RELEASE_S)
        except EstimationError as exc:
            self.get_logger().error(f'input check: {exc}', throttle_duration_sec=5.0)
            return
        self._feed(events)

    def _feed(self, events: list[AlignEvent]) -> None:
        """Pass checked events to the window monitor; queue the due window."""
        for note in self._input.take_warnings():
            self.get_logger().warning(f'plausibility: {note}')
        for ev in events:
            if not isinstance(ev, AlignedChunk):
                self.get_logger().warning(f'{ev}: the monitor window starts again')
                self._monitor.reset()
                continue
            n = len(ev)
            # the drive's time base: s since the stream started (the ramp refers to it)
            t = (ev.first_index + np.arange(n)) / ev.sample_rate
            offset = ev.t0 - ev.first_index / ev.sample_rate  # stream stamp - drive time [s]
            try:
                due = self._monitor.add(
                    t, ev.torsion, ev.accel, ev.speed, sample_rate=ev.sample_rate
                )
            except EstimationError as exc:
                self.get_logger().error(f'samples dropped: {exc}')
                self._monitor.reset()
                continue
            for w in due:
                with self._cond:
                    self._pending = (w, offset)  # a window not yet taken is skipped
                    self._cond.notify_all()

    # ----------------------------------------------------------------- worker
    def _work(self) -> None:
        try:  # load the compiled kernels and the pipeline before the first window is due
            self._monitor.warm_up(self._friction)
        except EstimationError as exc:
            self.get_logger().warning(f'warm-up failed: {exc}')
        while True:
            with self._cond:
                while self._pending is None and not self._closing:
                    self._cond.wait(timeout=0.5)
                if self._closing and self._pending is None:
                    return
                item = self._pending
                self._pending = None
            if item is None:
                continue
            w, offset = item
            try:
                res = self._monitor.evaluate(w)
            except EstimationError as exc:
                self.get_logger().error(f'window ending {w.time[-1]:.2f} s: {exc}')
                continue
            except Exception as exc:  # keep a long test running; the window is reported lost
                self.get_logger().error(f'window ending {w.time[-1]:.2f} s: crashed: {exc!r}')
                continue
            if not self._gate.publish(self._pub, to_msg(res, offset)):
                return
            with self._cond:
                self.published += 1
            if not res.complete:
                with self._cond:
                    if not self._inquiring and self._inquiry is None:
                        self._inquiry = (w, offset, res)
                        self._cond.notify_all()

    def _investigate(self) -> None:
        """Screen every family on the windows the worker hands over (one at a time)."""
        while True:
            with self._cond:
                while self._inquiry is None and not self._closing:
                    self._cond.wait(timeout=0.5)
                if self._closing:
                    return
                item = self._inquiry
                self._inquiry = None
                self._inquiring = True
            try:
                if item is None:
                    continue
                w, offset, first = item
                try:
                    res = self._monitor.investigate(w, first.null)
                except Exception as exc:  # the windows go on; this investigation is lost
                    self.get_logger().error(
                        f'investigation of the window ending {w.time[-1]:.2f} s: {exc!r}'
                    )
                    continue
                if not self._gate.publish(self._pub, to_msg(res, offset)):
                    return
                with self._cond:
                    self.published += 1
            finally:
                with self._cond:
                    self._inquiring = False

    def close(self) -> None:
        """Stop both threads: a window or investigation that ends in time is published.

        Nothing is published after this returns (both threads publish through a
        :class:`~tribo_common.node_main.PublishGate`), so the context may be shut down
        next even while an evaluation still runs (its thread is a daemon).
        """
        with self._cond:
            self._closing = True
            self._cond.notify_all()
        deadline = time.monotonic() + CLOSE_WAIT_S
        for thread in (self._worker, self._investigator):
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
        self._gate.close()


def to_msg(r: WindowResult, offset: float = 0.0) -> ModelDiscrepancy:
    """Return the ModelDiscrepancy message of one window.

    Parameters
    ----------
    r : WindowResult
        The evaluated window.
    offset : float
        Maps the monitor's time base to stream time (the stamps of the
        SampleBlocks) [s].

    Returns
    -------
    ModelDiscrepancy
        The message.
    """
    m = ModelDiscrepancy()
    t_end = r.t_end + offset
    if math.isfinite(t_end):
        m.header.stamp = time_from_ns(round(t_end * 1e9))
    m.header.frame_id = 'model'
    m.t_start = float(r.t_start + offset)
    m.t_end = float(t_end)
    m.n_samples = int(r.n_samples)
    m.mu0 = float(r.mu0)
    m.mu_inf = float(r.mu_inf)
    m.drive_speed = float(r.drive_speed)
    m.residual_rms = float(r.residual_rms)
    m.residual_rms_accel = float(r.residual_rms_accel)
    m.noise_floor = float(r.noise_floor)
    m.ratio = float(r.ratio)
    m.concentration = r.concentration
    m.concentration_share = float(r.concentration_share)
    m.candidate = r.candidate
    m.param_names = list(r.params)
    m.param_values = float64_array([r.params[k] for k in r.params])
    m.param_units = [r.units.get(k, '') for k in r.params]
    m.candidate_rms = float(r.candidate_rms)
    m.identifiable = bool(r.identifiable)
    m.identifiable_reason = r.identifiable_reason
    m.processing_time = float(r.processing_time)
    m.quality = r.quality
    return m


def main(args: Sequence[str] | None = None) -> int:
    """Entry point of the ``model_monitor`` executable."""
    return run_node(ModelMonitorNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
