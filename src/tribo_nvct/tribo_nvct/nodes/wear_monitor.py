"""nVCT wear monitor node (executable ``wear_monitor``): nvct/counts -> nvct/wear.

Thin rclpy shell over :class:`tribo_nvct.core.streaming.WearEvaluator`
(paper section 3, Equ. 8-10). One tribo_msgs/WearState per dwell, SI units
(m^3, m, m^3/s). The evaluator state (the accepted dwells) is written
atomically to ``state_file`` and reloaded at start, so a crash or restart
during a 3 h test loses nothing: a dwell is written at once unless the last
write is less than ``save_interval_s`` old (an accelerated simulation or a
replay delivering many dwells per second), then within that interval, and at
shutdown. A hard kill loses at most the dwells of the last ``save_interval_s``
of wall time, and only in such bursts: at the rig's one dwell per minute every
dwell is on disk before its WearState is published. A state file written with
another configuration is kept as ``<state_file>.<time>.bak`` and a new state
started.

Parameters: ``nvct_config`` (NVCT.yaml path, required), ``state_file``
(JSON path, default ``$ROS_HOME/tribo_nvct/wear_state.json`` with ``ROS_HOME``
defaulting to ``~/.ros``; empty = no persistence), ``rate_window_s`` (span of the current
wear-rate regression [s]), ``save_interval_s`` (least wall time between two
state writes [s]), ``counts_topic``, ``wear_topic``, ``fresh_start`` (ignore and
back up an existing state). WearState is published with the latched result
QoS (:func:`tribo_common.qos.history_qos`): a late subscriber gets the history.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Unpack

from rclpy.node import Node

from tribo_common.msgconv import time_from_ns
from tribo_common.node_main import NodeOptions, run_node
from tribo_common.params import ParameterError, declare_specs
from tribo_common.qos import data_qos, history_qos
from tribo_common.rosenv import default_state_file
from tribo_nvct.core.config import NvctConfig, load_config
from tribo_nvct.core.counting import Dwell
from tribo_nvct.core.streaming import WearEvaluator
from tribo_nvct.errors import NvctError, StateError
from tribo_nvct.nodes.specs import WEAR_MONITOR_PARAMS

if TYPE_CHECKING:
    from tribo_msgs.msg import DetectorCounts


def _nan_if_none(x: float | None) -> float:
    return math.nan if x is None else float(x)


#: Declared parameters: :mod:`tribo_nvct.nodes.specs`.
PARAMS = WEAR_MONITOR_PARAMS


class WearMonitor(Node):
    """Subscribe DetectorCounts, publish WearState per dwell, persist the state."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('wear_monitor', **kwargs)
        default_state = str(default_state_file('tribo_nvct', 'wear_state.json'))
        v = declare_specs(
            self,
            (s.with_default(default_state) if s.name == 'state_file' else s for s in PARAMS),
        )
        cfg_path = v.text('nvct_config')
        self.state_file = v.text('state_file')
        self.rate_window = v.number('rate_window_s')
        self.save_interval = v.number('save_interval_s')
        counts_topic = v.text('counts_topic')
        wear_topic = v.text('wear_topic')
        fresh = v.flag('fresh_start')
        if not cfg_path:
            raise ParameterError("parameter 'nvct_config' (path of NVCT.yaml) is required")
        try:
            self.cfg: NvctConfig = load_config(cfg_path)
        except NvctError as exc:
            raise ParameterError(f'nvct_config: {exc}') from exc
        self.evaluator = self._restore(bool(fresh))
        self._dirty = False
        self._last_save = -math.inf
        self._flush_timer = self.create_timer(max(self.save_interval, 0.05), self._flush)
        from tribo_msgs.msg import DetectorCounts, WearState

        self._WearState = WearState
        self._pub = self.create_publisher(WearState, wear_topic, history_qos())
        self._sub = self.create_subscription(
            DetectorCounts, counts_topic, self._on_counts, data_qos()
        )
        self.get_logger().info(
            f'wear_monitor: {self.cfg.nuclide.name}, k_A={self.cfg.k_A:.3g}, '
            f'contact {self.cfg.contact_area * 1e12:.4g} um^2, '
            f'{len(self.evaluator.points)} dwells restored'
        )

    def _restore(self, fresh: bool) -> WearEvaluator:
        path = Path(self.state_file) if self.state_file else None
        if path is None or not path.exists():
            return WearEvaluator(self.cfg, self.rate_window)
        if not fresh:
            try:
                ev = WearEvaluator.load(self.cfg, path)
                ev.rate_window_s = float(self.rate_window)
                return ev
            except StateError as exc:
                self.get_logger().error(f'cannot resume from {path}: {exc}')
        backup = path.with_name(f'{path.name}.{time.strftime("%Y%m%dT%H%M%S")}.bak')
        os.replace(path, backup)
        self.get_logger().warning(f'previous state kept as {backup}; starting a new test')
        return WearEvaluator(self.cfg, self.rate_window)

    def _flush(self) -> None:
        """Write the state file if dwells arrived since the last write."""
        if not (self._dirty and self.state_file):
            return
        try:
            self.evaluator.save(self.state_file)
        except OSError as exc:
            self.get_logger().error(f'cannot save state to {self.state_file}: {exc}')
            return
        self._dirty = False
        self._last_save = time.monotonic()

    def close(self) -> None:
        """Write any unsaved dwells (called by run_node at shutdown)."""
        self._flush()

    def _on_counts(self, msg: DetectorCounts) -> None:
        try:
            dwell = Dwell(
                float(msg.t_start), float(msg.t_end), int(msg.counts), float(msg.live_time)
            )
            point = self.evaluator.add(dwell, int(msg.seq))
        except NvctError as exc:
            self.get_logger().warning(f'dwell rejected: {exc}')
            return
        if point is None:
            return  # repeat of an already processed dwell
        self._dirty = True
        if time.monotonic() - self._last_save >= self.save_interval:
            self._flush()
        out = self._WearState()
        out.header.stamp = time_from_ns(time.time_ns())
        out.header.frame_id = 'nvct'
        out.t = point.t_end
        out.tagged_volume = point.tagged_volume
        out.tagged_volume_se = point.tagged_volume_se
        out.wear_volume = point.volume
        out.wear_volume_se = point.volume_se
        out.wear_height = point.height
        out.wear_height_se = point.height_se
        rate = self.evaluator.current_rate()
        out.wear_rate = rate.rate
        out.wear_rate_se = rate.se
        nan = math.nan
        out.running_in_volume = out.running_in_volume_se = nan
        out.progressive_rate = out.progressive_rate_se = nan
        if point.t_end >= self.cfg.window_s[1]:
            ev = self.evaluator.evaluation(fit_model=False)
            out.running_in_volume = _nan_if_none(ev.running_in_volume)
            out.running_in_volume_se = _nan_if_none(ev.running_in_volume_se)
            out.progressive_rate = _nan_if_none(ev.progressive_rate)
            out.progressive_rate_se = _nan_if_none(ev.progressive_rate_se)
        out.oil_mixed = 'not_mixed' not in point.flags
        out.quality = point.quality
        self._pub.publish(out)


def main(args: Sequence[str] | None = None) -> None:
    """Entry point of ``wear_monitor``."""
    raise SystemExit(run_node(WearMonitor, args))


if __name__ == '__main__':
    main()
