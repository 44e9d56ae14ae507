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
from typing import Any

from tribo_common import topics
from tribo_common.node_main import run_node
from tribo_common.params import ParameterError, declare
from tribo_drivers.core.can_protocol import CanCodec
from tribo_drivers.core.streams import CanStream, DeviceStream
from tribo_drivers.core.transports import CanTransport
from tribo_drivers.errors import DriverError
from tribo_drivers.nodes.driver_base import SampleBlockDriver

CHANNEL_TOPICS = {
    t.channel: t.name
    for t in (
        topics.ANGULAR_ACCELERATION,
        topics.SPEED,
        topics.NORMAL_FORCE,
        topics.OIL_TEMPERATURE,
    )
}


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
    def __init__(self, **kwargs: Any) -> None:
        super().__init__('can_driver', **kwargs)

    def declare_driver_parameters(self) -> None:
        self.interface = declare(
            self, 'interface', 'socketcan', 'python-can interface (socketcan, slcan, virtual, ...)'
        )
        self.channel = declare(self, 'channel', 'can0', 'python-can channel (can0, /dev/ttyACM0)')
        self.bitrate = declare(
            self, 'bitrate', 500_000, 'CAN bit rate [bit/s]', low=10_000, high=8_000_000
        )
        self.dbc = declare(self, 'dbc', '', 'DBC file (empty: config/tribo.dbc)') or default_dbc()
        self.blocks_per_second = declare(
            self, 'blocks_per_second', 100.0, 'target blocks per s per channel [1/s]', low=1.0,
            high=10_000.0,
        )  # fmt: skip
        self.topics = {
            ch: declare(self, f'{ch}_topic', topic, f'SampleBlock topic of {ch}')
            for ch, topic in CHANNEL_TOPICS.items()
        }
        try:
            self.codec = CanCodec(self.dbc)
        except DriverError as exc:
            raise ParameterError(str(exc)) from exc

    def build_stream(self) -> DeviceStream[Any]:
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
        return dict(self.topics)

    def expected_rate(self) -> float:
        return float(sum(s.frame_rate for s in self.codec.specs.values()))


def main(args: Sequence[str] | None = None) -> None:
    raise SystemExit(run_node(CanDriver, args))


if __name__ == '__main__':
    main()
