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
from typing import Unpack

from tribo_common import topics
from tribo_common.node_main import NodeOptions, run_node
from tribo_common.params import ParameterError, declare_specs
from tribo_drivers.core.daq_protocol import DaqScaling
from tribo_drivers.core.gaps import SampleBlock
from tribo_drivers.core.streams import DaqStream, DeviceStream
from tribo_drivers.core.transports import SerialTransport
from tribo_drivers.errors import DriverError
from tribo_drivers.nodes.driver_base import SampleBlockDriver
from tribo_drivers.nodes.specs import DAQ_PARAMS, DAQ_SCALING

TOPICS = {t.channel: t.name for t in topics.RIG_STREAMS}
SCALING = DAQ_SCALING


class DaqDriver(SampleBlockDriver):
    """Lifecycle driver of the rig's DAQ (binary frames of torque, acceleration, speed)."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('daq_driver', **kwargs)

    def declare_driver_parameters(self) -> None:
        """Declare the DAQ parameters (port, baudrate [bit/s], sample rate [Hz], scaling)."""
        v = declare_specs(self, DAQ_PARAMS)
        self.port = v.text('port')
        self.baudrate = v.integer('baudrate')
        self.sample_rate = v.number('sample_rate')
        self.block_size = v.integer('block_size')
        offsets = [v.number(f'{key}_offset') for key, *_ in SCALING]
        gains = [v.number(f'{key}_gain') for key, *_ in SCALING]
        try:
            self.scaling = DaqScaling(
                (offsets[0], offsets[1], offsets[2]), (gains[0], gains[1], gains[2])
            )
        except DriverError as exc:
            raise ParameterError(str(exc)) from exc
        if self.sample_rate * 20 * 10 > self.baudrate:
            self.get_logger().warning(
                f'baudrate {self.baudrate} bit/s is too low for {self.sample_rate} frames/s '
                '(20 bytes of 10 bits each per frame)'
            )

    def build_stream(self) -> DeviceStream[SampleBlock]:
        """Build the DAQ stream over the serial port."""
        return DaqStream(
            SerialTransport(self.port, self.baudrate),
            self.scaling,
            self.sample_rate,
            self.block_size,
            backoff=self.backoff,
        )

    def channel_topics(self) -> dict[str, str]:
        """Return the topic of each DAQ channel."""
        return dict(TOPICS)

    def expected_rate(self) -> float:
        """Return the nominal sample rate [Hz]."""
        return float(self.sample_rate)


def main(args: Sequence[str] | None = None) -> None:
    """Run the ``daq_driver`` executable."""
    raise SystemExit(run_node(DaqDriver, args))


if __name__ == '__main__':
    main()
