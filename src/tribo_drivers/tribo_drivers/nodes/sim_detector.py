"""Simulated nVCT detector (executable ``sim_detector``): publishes nvct/counts.

Thin rclpy shell over :class:`tribo_nvct.core.simulate.ForwardSimulator`
(true wear curve -> released activity -> oil circuit -> Poisson counts with
background, decay and dead time). The test clock is accelerated by
``time_scale`` (default from sim_detector.yaml: a 240 min test in about
60 s); DetectorCounts.t_start/t_end are *test* time [s], the header stamp is
host time at the end of the dwell. Publishing stops at the end of the test.

Parameters: ``sim_config`` (sim_detector.yaml), ``nvct_config`` (override of
the NVCT.yaml it names), ``time_scale`` (test seconds per wall second; 0 =
value from the YAML), ``seed`` (-1 = value from the YAML), ``topic``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Unpack

import numpy as np
from rclpy.node import Node

from tribo_common.msgconv import time_from_ns
from tribo_common.node_main import NodeOptions, run_node
from tribo_common.params import ParameterError, declare_specs
from tribo_common.qos import data_qos
from tribo_drivers.nodes.specs import SIM_DETECTOR_PARAMS
from tribo_nvct.core.simulate import ForwardSimulator, load_sim_config
from tribo_nvct.errors import NvctError


class SimDetector(Node):
    """Publish one DetectorCounts per simulated dwell on an accelerated clock."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('sim_detector', **kwargs)
        v = declare_specs(self, SIM_DETECTOR_PARAMS)
        sim_path = v.text('sim_config')
        nvct_path = v.text('nvct_config')
        scale = v.number('time_scale')
        seed = v.integer('seed')
        topic = v.text('topic')
        self.wait_subscribers = v.number('wait_subscribers')
        if not sim_path:
            raise ParameterError("parameter 'sim_config' (path of sim_detector.yaml) is required")
        try:
            sc = load_sim_config(sim_path, nvct_path or None)
            self.sim = ForwardSimulator(sc.nvct, sc.truth, sc.settings)
        except NvctError as exc:
            raise ParameterError(f'sim_config: {exc}') from exc
        self.time_scale = float(scale) if scale > 0.0 else sc.time_scale
        self.rng = np.random.default_rng(sc.seed if seed < 0 else int(seed))
        from tribo_msgs.msg import DetectorCounts

        self._Msg = DetectorCounts
        self._pub = self.create_publisher(DetectorCounts, topic, data_qos())
        self._index = 0
        self._created = time.monotonic()
        self._t0: float | None = None
        period = min(0.05, sc.settings.dwell / self.time_scale / 4.0)
        self._timer = self.create_timer(period, self._tick)
        self.get_logger().info(
            f'sim_detector: {self.sim.t_start.size} dwells of {sc.settings.dwell:g} s, '
            f'{self.time_scale:g}x real time'
        )

    def _tick(self) -> None:
        if self._t0 is None:
            waited = time.monotonic() - self._created
            if self._pub.get_subscription_count() == 0 and waited < self.wait_subscribers:
                return  # the test clock starts once someone listens (or the wait is over)
            self._t0 = time.monotonic()
        test_now = (time.monotonic() - self._t0) * self.time_scale
        while self._index < self.sim.t_end.size and self.sim.t_end[self._index] <= test_now:
            d = self.sim.dwell(self._index, self.rng)
            msg = self._Msg()
            msg.header.stamp = time_from_ns(time.time_ns())
            msg.header.frame_id = 'nvct_counter'
            msg.seq = self._index
            msg.t_start = d.t_start
            msg.t_end = d.t_end
            msg.counts = d.counts
            msg.live_time = d.live_time
            self._pub.publish(msg)
            self._index += 1
        if self._index >= self.sim.t_end.size:
            self.get_logger().info('simulated test finished')
            self._timer.cancel()


def main(args: Sequence[str] | None = None) -> None:
    """Entry point of ``sim_detector``."""
    raise SystemExit(run_node(SimDetector, args))


if __name__ == '__main__':
    main()
