"""Shared lifecycle shell of the hardware drivers (rclpy side; the logic is in core/).

Lifecycle: *configure* reads the parameters, builds the core stream and opens the port
(a device that is not there yet is retried with back-off once active); *activate* starts the
reader thread that polls the stream and publishes; *deactivate* stops it and releases the
port (publishing the partial block first: good data is never dropped); *cleanup* destroys
the publishers.  ``autostart`` (default true) configures and activates at start for use
without a lifecycle manager.  ``/diagnostics`` is published in every state.
"""

from __future__ import annotations

import threading
import time
from abc import abstractmethod
from typing import Any, Generic, TypeVar, Unpack

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.lifecycle import Node as LifecycleNode
from rclpy.lifecycle import State, TransitionCallbackReturn

from tribo_common import topics
from tribo_common.msgconv import make_sample_block
from tribo_common.node_main import NodeOptions, PublishGate
from tribo_common.params import ParameterError, declare_specs
from tribo_common.qos import data_qos, status_qos
from tribo_drivers.core.diagnostics import DriverCounters, driver_status
from tribo_drivers.core.gaps import SampleBlock
from tribo_drivers.core.reconnect import Backoff
from tribo_drivers.core.streams import DeviceStream
from tribo_drivers.errors import DriverError
from tribo_drivers.nodes.specs import DRIVER_PARAMS

#: Item type of a driver's stream (sample blocks, count messages).
ItemT = TypeVar('ItemT')


class DriverNode(LifecycleNode, Generic[ItemT]):
    """Base class: subclasses build the stream and publish its items."""

    def __init__(self, name: str, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__(name, **kwargs)
        v = declare_specs(self, DRIVER_PARAMS)
        self.autostart = v.flag('autostart')
        self.poll_timeout = v.number('poll_timeout')
        self.diagnostic_period = v.number('diagnostic_period')
        self.backoff_initial = v.number('backoff_initial')
        self.backoff_max = v.number('backoff_max')
        self.hardware_id = v.text('hardware_id')
        self.declare_driver_parameters()
        try:
            self.backoff = Backoff(
                self.backoff_initial, 2.0, max(self.backoff_max, self.backoff_initial)
            )
        except DriverError as exc:
            raise ParameterError(str(exc)) from exc
        self.stream: DeviceStream[ItemT] | None = None
        self._thread: threading.Thread | None = None
        self._running = threading.Event()
        self._gate = PublishGate()
        self._prev: DriverCounters | None = None
        self._diag_pub = self.create_publisher(
            DiagnosticArray, topics.DIAGNOSTICS.name, status_qos()
        )
        self._diag_timer = self.create_timer(self.diagnostic_period, self._publish_diagnostics)
        if self.autostart:
            self._autostart_timer = self.create_timer(0.0, self._autostart)

    # --- subclass hooks -----------------------------------------------------------------
    @abstractmethod
    def declare_driver_parameters(self) -> None:
        """Declare the driver's own parameters (called by ``__init__``)."""

    @abstractmethod
    def build_stream(self) -> DeviceStream[ItemT]:
        """Build the core stream from the parameters (raises DriverError if they do not fit)."""

    @abstractmethod
    def create_publishers(self) -> None:
        """Create the lifecycle publishers of the items."""

    @abstractmethod
    def destroy_publishers(self) -> None:
        """Destroy the item publishers."""

    @abstractmethod
    def publish_items(self, items: list[ItemT]) -> None:
        """Publish a batch of the stream's items."""

    @abstractmethod
    def expected_rate(self) -> float:
        """Nominal items (samples, lines) per second for the rate check [1/s]."""

    # --- lifecycle ----------------------------------------------------------------------
    def _autostart(self) -> None:
        self._autostart_timer.cancel()
        self.trigger_configure()
        self.trigger_activate()

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        """Build the stream and open the device (a missing device is retried once active)."""
        try:
            self.stream = self.build_stream()
        except DriverError as exc:
            self.get_logger().error(f'configuration rejected: {exc}')
            return TransitionCallbackReturn.FAILURE
        try:
            self.stream.open()
            self.get_logger().info(f'opened {self.stream.describe()}')
        except DriverError as exc:
            self.stream.counters.last_error = str(exc)
            self.get_logger().warning(f'{exc}; will retry with back-off when active')
        self.create_publishers()
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        """Activate the publishers and start the reader thread."""
        if self.stream is None:
            return TransitionCallbackReturn.FAILURE
        ret = super().on_activate(state)
        self.stream.resume()
        self._running.set()
        self._thread = threading.Thread(target=self._reader, name='driver-reader', daemon=True)
        self._thread.start()
        return ret

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        """Stop the reader, publish the partial block and release the port."""
        self._stop_reader()
        if self.stream is not None:
            rest = self.stream.close()
            if rest and self.context.ok():
                self.publish_items(rest)
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        """Stop the reader, close the stream and destroy the publishers."""
        self._stop_reader()
        if self.stream is not None:
            self.stream.close()
        self.stream = None
        self.destroy_publishers()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        """Close the driver (reader stopped, port released)."""
        self.close()
        return TransitionCallbackReturn.SUCCESS

    def close(self) -> None:
        """Stop the reader and release the port (run_node calls it before the shutdown).

        Nothing is published after this returns.
        """
        self._stop_reader()
        self._gate.close()
        if self.stream is not None:
            self.stream.close()

    def _stop_reader(self) -> None:
        self._running.clear()
        if self.stream is not None:
            self.stream.stop()
        if self._thread is not None:
            self._thread.join(5.0)
            self._thread = None

    def _publish_or_stop(self, items: list[ItemT]) -> bool:
        """Publish ``items``; return False once the node is closed."""
        with self._gate.batch() as ok:
            if ok:
                self.publish_items(items)
            return ok

    def _reader(self) -> None:
        stream = self.stream
        assert stream is not None
        items = stream.take_pending()
        if items and not self._publish_or_stop(items):
            return
        was_connected = stream.counters.connected
        while self._running.is_set():
            items = stream.poll(self.poll_timeout)
            if items and not self._publish_or_stop(items):
                return
            if stream.counters.connected != was_connected:
                was_connected = stream.counters.connected
                if was_connected:
                    self.get_logger().info(f'connected to {stream.describe()}')
                else:
                    self.get_logger().warning(
                        f'lost {stream.describe()}: {stream.counters.last_error}'
                    )

    # --- diagnostics --------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        stream = self.stream
        name = f'{self.get_name()}: {stream.describe() if stream else "unconfigured"}'
        if stream is None:
            status = DiagnosticStatus(
                level=DiagnosticStatus.STALE, name=name, message='not configured',
                hardware_id=self.hardware_id,
            )  # fmt: skip
        else:
            counters = stream.counters.copy()
            st = driver_status(
                name,
                self.hardware_id or stream.describe(),
                counters,
                stream.rate.rate(time.monotonic()),
                self.expected_rate() if self._running.is_set() else 0.0,
                self._prev,
            )
            self._prev = counters
            status = DiagnosticStatus(
                level=bytes([int(st.level)]),
                name=st.name,
                message=st.message if self._running.is_set() else f'inactive; {st.message}',
                hardware_id=st.hardware_id,
                values=[KeyValue(key=k, value=v) for k, v in st.values],
            )
        arr.status = [status]
        self._diag_pub.publish(arr)


class SampleBlockDriver(DriverNode[SampleBlock]):
    """A driver whose items are sample blocks, published per channel as SampleBlock.

    Subclasses provide :meth:`channel_topics` (channel -> topic; empty topic: not
    published) and the stream.
    """

    def __init__(self, name: str, **kwargs: Unpack[NodeOptions]) -> None:
        self._pubs: dict[str, Any] = {}
        super().__init__(name, **kwargs)

    @abstractmethod
    def channel_topics(self) -> dict[str, str]:
        """Topic of each channel of the stream (empty: the channel is not published)."""

    def create_publishers(self) -> None:
        """Create one SampleBlock lifecycle publisher per published channel."""
        from tribo_msgs.msg import SampleBlock as SampleBlockMsg

        self._pubs = {
            ch: self.create_lifecycle_publisher(SampleBlockMsg, topic, data_qos())
            for ch, topic in self.channel_topics().items()
            if topic
        }

    def destroy_publishers(self) -> None:
        """Destroy the SampleBlock publishers."""
        for pub in self._pubs.values():
            self.destroy_lifecycle_publisher(pub)
        self._pubs = {}

    def publish_items(self, items: list[SampleBlock]) -> None:
        """Publish each sample block on its channel's topic."""
        for b in items:
            pub = self._pubs.get(b.channel)
            if pub is None:
                continue
            pub.publish(
                make_sample_block(
                    b.data,
                    first_index=b.first_index,
                    sample_rate=b.sample_rate,
                    stamp_ns=round(b.stamp * 1e9),
                    channel=b.channel,
                    unit=b.unit,
                )
            )
