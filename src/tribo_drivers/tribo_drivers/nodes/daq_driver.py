"""Serial DAQ driver (executable ``daq_driver``): torsion moment, acceleration, speed.

Lifecycle node (see :mod:`tribo_drivers.nodes.driver_base`).  Reads the 20-byte frames of
:mod:`tribo_drivers.core.daq_protocol` from ``port`` at ``baudrate`` and publishes
SampleBlocks on ``rig/torsion_moment`` [N m] (C1*phi1), ``rig/angular_acceleration``
[rad/s^2] (w1') and ``rig/speed`` [rad/s] (w2) (relative names,
:mod:`tribo_common.topics`), the measured quantities of the paper's Equ. 1-4.
Scaling per channel: value = (raw - offset) * gain.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from tribo_common import topics
from tribo_common.node_main import run_node
from tribo_common.params import ParameterError, declare
from tribo_drivers.core.daq_protocol import DaqScaling
from tribo_drivers.core.streams import DaqStream, DeviceStream
from tribo_drivers.core.transports import SerialTransport
from tribo_drivers.errors import DriverError
from tribo_drivers.nodes.driver_base import SampleBlockDriver

TOPICS = {t.channel: t.name for t in topics.RIG_STREAMS}
SCALING = (
    ('torque', 'torsion moment', 'N m', 1e-6),
    ('accel', 'angular acceleration', 'rad/s^2', 1e-3),
    ('speed', 'shaft speed', 'rad/s', 1e-4),
)


class DaqDriver(SampleBlockDriver):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__('daq_driver', **kwargs)

    def declare_driver_parameters(self) -> None:
        self.port = declare(self, 'port', '/dev/ttyUSB0', 'serial device of the DAQ')
        self.baudrate = declare(
            self, 'baudrate', 2_000_000, 'serial baud rate [bit/s]', low=1200, high=20_000_000
        )
        self.sample_rate = declare(
            self, 'sample_rate', 10_000.0, 'DAQ sample rate [Hz]', low=1.0, high=1e6
        )
        self.block_size = declare(
            self, 'block_size', 50, 'samples per published block [-]', low=1, high=1_000_000
        )
        offsets, gains = [], []
        for key, what, unit, gain in SCALING:
            offsets.append(
                declare(
                    self, f'{key}_offset', 0.0, f'{what} offset [counts]', low=-(2**31), high=2**31
                )
            )
            gains.append(declare(self, f'{key}_gain', gain, f'{what} gain [{unit}/count]'))
        try:
            self.scaling = DaqScaling(tuple(offsets), tuple(gains))  # type: ignore[arg-type]
        except DriverError as exc:
            raise ParameterError(str(exc)) from exc
        if self.sample_rate * 20 * 10 > self.baudrate:
            self.get_logger().warning(
                f'baudrate {self.baudrate} bit/s is too low for {self.sample_rate} frames/s '
                '(20 bytes of 10 bits each per frame)'
            )

    def build_stream(self) -> DeviceStream[Any]:
        return DaqStream(
            SerialTransport(self.port, self.baudrate),
            self.scaling,
            self.sample_rate,
            self.block_size,
            backoff=self.backoff,
        )

    def channel_topics(self) -> dict[str, str]:
        return dict(TOPICS)

    def expected_rate(self) -> float:
        return float(self.sample_rate)


def main(args: Sequence[str] | None = None) -> None:
    raise SystemExit(run_node(DaqDriver, args))


if __name__ == '__main__':
    main()
