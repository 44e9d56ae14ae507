"""Live Foxglove bridge (executable ``live_bridge``): the graph's topics for Foxglove / Lichtblick.

Serves the tribo topics over the Foxglove WebSocket protocol v1 with the
``foxglove-sdk`` server (0.30 names the subprotocol ``foxglove.sdk.v1``, the
same messages as ``foxglove.websocket.v1``; current Foxglove and Lichtblick
offer it, older clients that offer only ``foxglove.websocket.v1`` get HTTP 400), bound to
127.0.0.1 by default (``host``, ``port`` parameters; ``port`` 0 = any free
port, the chosen one is logged and kept in :attr:`LiveBridgeNode.port`).
Open it in Foxglove with "Open connection -> Foxglove WebSocket ->
ws://127.0.0.1:8765" and load ``config/foxglove_layout.json``.

Channels (JSON encoding, JSON schemas with units):

- ``/rig/torsion_moment``, ``/rig/angular_acceleration``, ``/rig/speed``,
  ``/rig/normal_force``, ``/rig/oil_temperature``, ``/friction/moment``:
  down-sampled to ``downsample_rate`` (200 Hz default): per bin the mean (or
  first sample), min and max (schema ``tribo.DownsampledSamples``).
- ``/live/stick``: stick/slip flag per bin from the torsion-moment slope and
  the shaft speed (``w1 = d(C1*phi1)/dt / C1``; stick when ``|w2 - w1| <=
  stick_tolerance``).
- ``/friction/estimate``, ``/nvct/wear``, ``/nvct/counts``: every message
  (full rate), all fields plus ``<x>_lo/_hi`` uncertainty bands (+-2 SE).

The bridge never slows the rig: it subscribes with the lossless data QoS,
its callbacks only bin a block with numpy and hand a few small JSON messages
to the server's own (Rust) threads; while no client listens to a channel the
callback returns at once. A slow client loses its oldest messages
(``message_backlog`` per client), never the ROS side.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Unpack

import foxglove
from foxglove.websocket import WebSocketServer
from rclpy.node import Node

from tribo_bringup import bridge_core as bc
from tribo_bringup.nodes.specs import LIVE_BRIDGE_PARAMS
from tribo_common import topics
from tribo_common.msgconv import StampedMessage, block_from_msg
from tribo_common.node_main import NodeOptions, run_node
from tribo_common.params import ParameterError, declare_specs
from tribo_common.qos import data_qos

if TYPE_CHECKING:
    from tribo_msgs.msg import SampleBlock as SampleBlockMsg

#: Declared parameters (``C1`` from the one rig table): :mod:`tribo_bringup.nodes.specs`.
PARAMS = LIVE_BRIDGE_PARAMS


def _json_channel(
    topic: str, schema: Mapping[str, object], ctx: foxglove.Context, meta: dict[str, str]
) -> foxglove.Channel:
    return foxglove.Channel(
        topic,
        schema=foxglove.Schema(
            name=str(schema['title']), encoding='jsonschema', data=json.dumps(schema).encode()
        ),
        message_encoding='json',
        context=ctx,
        metadata=meta,
    )


class LiveBridgeNode(Node):
    """Foxglove WebSocket server fed by the graph's topics."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('live_bridge', **kwargs)
        v = declare_specs(self, PARAMS)
        host = v.text('host')
        port = v.integer('port')
        rate = v.number('downsample_rate')
        self.mode = v.text('downsample_mode')
        if self.mode not in bc.MODES:
            raise ParameterError(
                f"parameter 'downsample_mode' must be one of {', '.join(bc.MODES)}, "
                f'got {self.mode!r}'
            )
        c1 = v.number('C1')
        tol = v.number('stick_tolerance')
        backlog = v.integer('message_backlog')
        self.ctx = foxglove.Context()
        try:
            server = foxglove.start_server(
                name='tribo',
                host=host,
                port=port,
                context=self.ctx,
                message_backlog_size=backlog,
            )
        except Exception as exc:  # the SDK raises its own types (e.g. address in use)
            raise ParameterError(f'cannot serve on {host}:{port}: {exc}') from exc
        self.server: WebSocketServer | None = server
        self.port = int(server.port)
        self.rate = rate
        meta = {'downsampled': f'{rate:g} Hz {self.mode}'}
        self._samples: dict[str, tuple[foxglove.Channel, bc.Downsampler]] = {
            t: (_json_channel(t, bc.SAMPLES_SCHEMA, self.ctx, meta), bc.Downsampler(rate))
            for t in bc.SAMPLE_TOPICS
        }
        self._stick_ch = _json_channel(bc.STICK_TOPIC, bc.STICK_SCHEMA, self.ctx, meta)
        self._stick = bc.StickDetector(C1=c1, tolerance=tol)
        self._records: dict[str, foxglove.Channel] = {
            t: _json_channel(t, spec.schema, self.ctx, {'rate': 'full'})
            for t, spec in bc.RECORD_TOPICS.items()
        }
        import tribo_msgs.msg as tm

        self.forwarded = 0
        self._subs = [
            self.create_subscription(tm.SampleBlock, t.lstrip('/'), self._on_block(t), data_qos())
            for t in bc.SAMPLE_TOPICS
        ]
        for topic, spec in bc.RECORD_TOPICS.items():
            self._subs.append(
                self.create_subscription(
                    getattr(tm, spec.type_name),
                    topic.lstrip('/'),  # relative: the bridge serves the rig of its namespace
                    self._on_record(topic, spec.fields, spec.bands),
                    data_qos(),
                )
            )
        self.get_logger().info(
            f'Foxglove bridge on ws://{host}:{self.port} '
            f'(10 kHz streams down-sampled to {rate:g} Hz, {self.mode})'
        )

    # -- callbacks (light: bin with numpy, hand small JSON to the server) -----

    def _on_block(self, topic: str) -> Callable[[SampleBlockMsg], None]:
        channel, down = self._samples[topic]
        is_torsion = topic == topics.TORSION_MOMENT.resolve()
        is_speed = topic == topics.SPEED.resolve()

        def on_block(msg: SampleBlockMsg) -> None:
            wanted_stick = (is_torsion or is_speed) and self._stick_ch.has_sinks()
            if not channel.has_sinks() and not wanted_stick:
                down.reset()
                return
            block = block_from_msg(msg)
            points = down.push(block.first_index, block.stamp_ns, block.sample_rate, block.data)
            for p in points:
                channel.log(bc.bin_message(p, block.unit, self.mode), log_time=p.stamp_ns)
            self.forwarded += len(points)
            if wanted_stick:
                flags = (
                    self._stick.add_torsion(points) if is_torsion else self._stick.add_speed(points)
                )
                for f in flags:
                    self._stick_ch.log(bc.stick_message(f), log_time=f.stamp_ns)

        return on_block

    def _on_record(
        self,
        topic: str,
        fields: Mapping[str, tuple[str, str]],
        bands: Mapping[str, tuple[str, str]],
    ) -> Callable[[StampedMessage], None]:
        channel = self._records[topic]

        def on_record(msg: StampedMessage) -> None:
            if not channel.has_sinks():
                return
            channel.log(bc.record_message(msg, fields, bands), log_time=bc.stamp_ns_of(msg))
            self.forwarded += 1

        return on_record

    def close(self) -> None:
        """Stop the WebSocket server (clients see the connection close)."""
        server = getattr(self, 'server', None)
        if server is not None:
            server.stop()
            self.server = None


def main(args: list[str] | None = None) -> None:
    """Entry point of ``live_bridge``."""
    raise SystemExit(run_node(LiveBridgeNode, args))


if __name__ == '__main__':
    main()
