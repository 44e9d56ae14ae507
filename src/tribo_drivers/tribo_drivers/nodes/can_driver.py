"""CAN sensor-module driver (executable ``can_driver``).

Lifecycle node (see :mod:`tribo_drivers.nodes.driver_base`).  Receives the frames of
``config/tribo.dbc`` (decoded with cantools, :mod:`tribo_drivers.core.can_protocol`) on any
python-can ``interface``/``channel`` and publishes SampleBlocks: angular acceleration w1'
[rad/s^2], shaft speed w2 [rad/s] (paper Equ. 1-4), normal force F_N [N] and oil temperature
[K].  Topics are parameters so the CAN channels need not clash with the DAQ's.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Unpack

from tribo_common.node_main import NodeOptions, run_node
from tribo_common.params import ParameterError, declare_specs
from tribo_drivers.core.can_protocol import CanCodec
from tribo_drivers.core.gaps import SampleBlock
from tribo_drivers.core.streams import CanStream, DeviceStream
from tribo_drivers.core.transports import CanTransport
from tribo_drivers.errors import DriverError
from tribo_drivers.nodes.driver_base import SampleBlockDriver
from tribo_drivers.nodes.specs import CAN_CHANNEL_TOPICS, CAN_PARAMS

CHANNEL_TOPICS = CAN_CHANNEL_TOPICS


def default_dbc() -> str:
    """config/tribo.dbc of the workspace ($TRIBO_ROOT, else next to the source tree)."""
    root = os.environ.get('TRIBO_ROOT')
    candidates = [Path(root) / 'config' / 'tribo.dbc'] if root else []
    candidates.append(Path(__file__).resolve().parents[4] / 'config' / 'tribo.dbc')
    for c in candidates:
        if c.is_file():
            return str(c)
    return str(candidates[0])


class CanDriver(SampleBlockDriver):
    """Lifecycle driver of the rig's CAN bus: the DBC's frames decoded into sample blocks."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('can_driver', **kwargs)

    def declare_driver_parameters(self) -> None:
        """Declare the CAN parameters (interface, channel, bitrate [bit/s], DBC file, topics)."""
        v = declare_specs(self, CAN_PARAMS)
        self.interface = v.text('interface')
        self.channel = v.text('channel')
        self.bitrate = v.integer('bitrate')
        self.dbc = v.text('dbc') or default_dbc()
        self.blocks_per_second = v.number('blocks_per_second')
        self.topics = {ch: v.text(f'{ch}_topic') for ch in CHANNEL_TOPICS}
        try:
            self.codec = CanCodec(self.dbc)
        except DriverError as exc:
            raise ParameterError(str(exc)) from exc

    def build_stream(self) -> DeviceStream[SampleBlock]:
        """Build the CAN stream over a python-can bus."""
        kwargs: dict[str, Any] = {}
        if self.interface == 'slcan':
            kwargs['sleep_after_open'] = 0.0
        return CanStream(
            CanTransport(self.interface, self.channel, self.bitrate, **kwargs),
            self.codec,
            self.blocks_per_second,
            backoff=self.backoff,
        )

    def channel_topics(self) -> dict[str, str]:
        """Return the topic of each decoded signal."""
        return dict(self.topics)

    def expected_rate(self) -> float:
        """Return the nominal frame rate [1/s] summed over the DBC's frames."""
        return float(sum(s.frame_rate for s in self.codec.specs.values()))


def main(args: Sequence[str] | None = None) -> None:
    """Run the ``can_driver`` executable."""
    raise SystemExit(run_node(CanDriver, args))


if __name__ == '__main__':
    main()
