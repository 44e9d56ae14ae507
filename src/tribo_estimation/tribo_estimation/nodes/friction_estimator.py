"""ROS 2 node ``friction_estimator``: online block-wise friction estimation (paper 2.5).

Subscribes ``rig/torsion_moment``, ``rig/angular_acceleration``, ``rig/speed``
(tribo_msgs/SampleBlock), aligns them by sample index (gaps are reported and
never bridged), publishes the observer's friction moment
``M = I1*w1' + K1*w1 + C1*phi1`` on ``friction/moment`` as the data arrive and
one ``friction/estimate`` (tribo_msgs/FrictionEstimate) per block (relative names
from :mod:`tribo_common.topics`).

Thin shell: the work is :class:`tribo_estimation.core.blockfit.StreamingPipeline`.
The subscriptions only align and run the observer; the fits run on a worker
thread, so input is never held up by a fit. Parameters are the RIG.yaml names
(SI units) plus ``block_length`` [s] and ``fit_k``, declared from their specs
(:data:`PARAMS`); they are read-only after start.
"""

from __future__ import annotations

import math
import queue
import threading
from collections.abc import Sequence
from typing import Unpack

from rclpy.node import Node

from tribo_common import topics
from tribo_common.msgconv import Block, make_sample_block, time_from_ns
from tribo_common.node_main import NodeOptions, PublishGate, run_node
from tribo_common.params import ParameterError, declare_specs
from tribo_common.qos import data_qos, history_qos
from tribo_common.rig_streams import RIG_INPUTS, require_contact, subscribe_rig_streams
from tribo_estimation.core.blockfit import (
    BlockConfig,
    BlockResult,
    MomentChunk,
    PendingBlock,
    StreamingPipeline,
)
from tribo_estimation.core.model import FrictionLaw, RigParams
from tribo_estimation.core.plausibility import IDLE_RELEASE_S, Scales
from tribo_estimation.errors import EstimationError
from tribo_estimation.nodes.specs import FRICTION_ESTIMATOR_PARAMS
from tribo_msgs.msg import FrictionEstimate, SampleBlock

#: Input topics and their channel names (:data:`tribo_common.rig_streams.RIG_INPUTS`).
TOPICS: dict[str, str] = RIG_INPUTS

#: Declared parameters (the rig's from the one rig table): :mod:`tribo_estimation.nodes.specs`.
PARAMS = FRICTION_ESTIMATOR_PARAMS


class FrictionEstimatorNode(Node):
    """Online friction estimator (see the module docstring)."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('friction_estimator', **kwargs)
        v = declare_specs(self, PARAMS)
        require_contact(v)
        try:
            rig = RigParams.from_mapping(v.numbers(RigParams.field_names()))
            friction = FrictionLaw(v.number('mu0'), v.number('mu_inf'), v.number('k'))
            cfg = BlockConfig(
                block_length=v.number('block_length'),
                fit_k=v.flag('fit_k'),
                nominal_speed=v.number('nominal_speed')
                if v.number('nominal_speed') != 0.0
                else None,
                ramp_time=v.number('ramp_time'),
            )
        except EstimationError as exc:
            raise ParameterError(str(exc)) from exc
        scales = (
            Scales.of(rig, friction, cfg.nominal_speed or 0.0) if v.flag('check_input') else None
        )
        self._pipe = StreamingPipeline(rig, friction, cfg, scales, source='rig topics')
        self._lock = threading.Lock()
        self._queue: queue.Queue[PendingBlock | None] = queue.Queue()
        qos = data_qos()
        self._pub_moment = self.create_publisher(SampleBlock, topics.FRICTION_MOMENT.name, qos)
        self._pub_est = self.create_publisher(
            FrictionEstimate, topics.FRICTION_ESTIMATE.name, history_qos()
        )
        self._gate = PublishGate()
        self._subs = subscribe_rig_streams(self, self._on_block)
        self._stop = threading.Event()
        self._worker = threading.Thread(target=self._work, name='friction_fit', daemon=True)
        self._worker.start()
        self._idle_timer = self.create_timer(0.5 * IDLE_RELEASE_S, self._on_idle)
        self.published = 0
        w0 = 'tachometer mean' if cfg.nominal_speed is None else f'{cfg.nominal_speed:g} rad/s'
        self.get_logger().info(
            f'friction estimator: {cfg.block_length:g} s blocks, '
            f'F_N*R = {rig.F_N * rig.R:g} N m, w0 = {w0}'
        )

    # ------------------------------------------------------------------ input
    def _on_block(self, b: Block) -> None:
        """Align one block and run the observer; queue the completed blocks for the fit."""
        try:
            with self._lock:
                out = self._pipe.push(
                    b.channel, b.first_index, b.sample_rate, b.stamp_ns * 1e-9, b.data
                )
        except EstimationError as exc:
            # a failed input check repeats on every block: log it every 5 s, not 500 times/s
            self.get_logger().error(f'{b.channel}: block dropped: {exc}', throttle_duration_sec=5.0)
            return
        self._emit(*out)

    def _on_idle(self) -> None:
        """Release the samples the input checks hold once the input has paused."""
        try:
            with self._lock:
                out = self._pipe.release(IDLE_RELEASE_S)
        except EstimationError as exc:
            self.get_logger().error(f'input check: {exc}', throttle_duration_sec=5.0)
            return
        self._emit(*out)

    def _emit(
        self, moments: list[MomentChunk], blocks: list[PendingBlock], notes: list[str]
    ) -> None:
        """Publish observer output, log notes, queue completed blocks for the fit."""
        for note in notes:
            self.get_logger().warning(note)
        for mc in moments:
            self._pub_moment.publish(
                make_sample_block(
                    mc.moment,
                    first_index=mc.first_index,
                    sample_rate=mc.sample_rate,
                    stamp_ns=round(mc.t0 * 1e9),
                    channel='friction_moment',
                    unit='N m',
                )
            )
        for blk in blocks:
            self._queue.put(blk)

    # ----------------------------------------------------------------- worker
    def _work(self) -> None:
        try:
            self._pipe.warm_up()  # load the compiled kernel before the first block ends
        except EstimationError as exc:
            self.get_logger().warning(f'warm-up failed: {exc}')
        while not self._stop.is_set():
            try:
                blk = self._queue.get(timeout=0.2)
            except queue.Empty:
                continue
            if blk is None:
                break
            try:
                res = self._pipe.evaluate(blk)
            except EstimationError as exc:  # e.g. speed in rpm: a configuration problem
                self.get_logger().error(f'block {blk.index}: {exc}')
                continue
            except Exception as exc:  # keep a long test running; the block is reported lost
                self.get_logger().error(f'block {blk.index}: fit crashed: {exc!r}')
                continue
            if not self._gate.publish(self._pub_est, to_msg(res)):
                return
            self.published += 1

    def close(self) -> None:
        """Stop the worker after the block being fitted; nothing is published after this."""
        self._queue.put(None)
        self._stop.set()
        self._worker.join(timeout=5.0)
        self._gate.close()


def to_msg(r: BlockResult) -> FrictionEstimate:
    """FrictionEstimate message of one block result."""
    m = FrictionEstimate()
    m.header.stamp = (
        time_from_ns(round(r.t_start * 1e9)) if math.isfinite(r.t_start) else m.header.stamp
    )
    m.header.frame_id = 'friction'
    m.t_start = float(r.t_start)
    m.t_end = float(r.t_end)
    m.first_index = int(r.first_index)
    m.mu0 = float(r.mu0)
    m.mu0_se = float(r.mu0_se)
    m.mu_inf = float(r.mu_inf)
    m.mu_inf_se = float(r.mu_inf_se)
    m.k = float(r.k)
    m.k_se = float(r.k_se)
    m.moment_min = float(r.moment_min)
    m.moment_max = float(r.moment_max)
    m.moment_mean = float(r.moment_mean)
    m.motion = r.motion
    m.n_sticks = int(r.n_sticks)
    m.stick_fraction = float(r.stick_fraction)
    m.rms_residual = float(r.rms_residual)
    m.quality = r.quality_str
    return m


def main(args: Sequence[str] | None = None) -> int:
    """Entry point of the ``friction_estimator`` executable."""
    return run_node(FrictionEstimatorNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
