"""Radiation counter driver (executable ``counter_driver``): one DetectorCounts per dwell.

Lifecycle node (see :mod:`tribo_drivers.nodes.driver_base`).  On open it sets the dwell with
``$DWELL,<ms>`` and waits for ``$ACK,DWELL,<ms>``; then every ``$CNT`` line (XOR checksum
checked) becomes a tribo_msgs/DetectorCounts on ``nvct/counts`` (times in s, counts), the
input of the nVCT wear evaluation (paper section 3).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Unpack

from tribo_common import topics
from tribo_common.msgconv import time_from_ns
from tribo_common.node_main import NodeOptions, run_node
from tribo_common.params import declare_specs
from tribo_common.qos import profile
from tribo_drivers.core.streams import CounterStream, CountMessage, DeviceStream
from tribo_drivers.core.transports import SerialTransport
from tribo_drivers.nodes.driver_base import DriverNode
from tribo_drivers.nodes.specs import COUNTER_PARAMS


class CounterDriver(DriverNode[CountMessage]):
    """Lifecycle driver of the nVCT radiation counter (ASCII lines over serial)."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('counter_driver', **kwargs)

    def declare_driver_parameters(self) -> None:
        """Declare the counter parameters (port, baudrate [bit/s], dwell [s], ack timeout [s])."""
        v = declare_specs(self, COUNTER_PARAMS)
        self.port = v.text('port')
        self.baudrate = v.integer('baudrate')
        self.dwell = v.number('dwell')
        self.ack_timeout = v.number('ack_timeout')
        self.ack_retries = v.integer('ack_retries')
        self.topic = v.text('topic')
        self._pub: Any = None

    def build_stream(self) -> DeviceStream[CountMessage]:
        """Build the counter stream over the serial port."""
        return CounterStream(
            SerialTransport(self.port, self.baudrate),
            dwell_ms=max(1, round(self.dwell * 1000.0)),
            ack_timeout=self.ack_timeout,
            ack_retries=self.ack_retries,
            backoff=self.backoff,
        )

    def create_publishers(self) -> None:
        """Create the lifecycle publisher of DetectorCounts."""
        from tribo_msgs.msg import DetectorCounts

        self._pub = self.create_lifecycle_publisher(
            DetectorCounts, self.topic, profile(topics.NVCT_COUNTS.qos)
        )

    def destroy_publishers(self) -> None:
        """Destroy the DetectorCounts publisher."""
        if self._pub is not None:
            self.destroy_lifecycle_publisher(self._pub)
        self._pub = None

    def publish_items(self, items: list[CountMessage]) -> None:
        """Publish each count message as DetectorCounts."""
        from tribo_msgs.msg import DetectorCounts

        for m in items:
            msg = DetectorCounts()
            msg.header.stamp = time_from_ns(round(m.stamp * 1e9))
            msg.header.frame_id = 'nvct_counter'
            msg.seq = m.seq
            msg.t_start = m.t_start
            msg.t_end = m.t_end
            msg.counts = m.counts
            msg.live_time = m.live_time
            if self._pub is not None:
                self._pub.publish(msg)

    def expected_rate(self) -> float:
        """Return the nominal count messages per second [1/s] (one per dwell)."""
        return 1.0 / float(self.dwell)


def main(args: Sequence[str] | None = None) -> None:
    """Run the ``counter_driver`` executable."""
    raise SystemExit(run_node(CounterDriver, args))


if __name__ == '__main__':
    main()
