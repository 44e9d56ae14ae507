"""Recording and replaying the graph's topics (rclpy side of ``tribo record``/``replay``).

Recording subscribes in raw mode (CDR bytes, no deserialisation) with the
lossless data QoS. The subscription callbacks only queue the messages; one
writer thread owns the :class:`tribo_bringup.bagio.BagWriter` (opens it, writes,
flushes every second so that a crash loses at most the last second, and
closes it: a sqlite3 connection may only be used by the thread that made it).
A failure of the writer is kept in :attr:`Recorder.error` and ends the
recording; what was written before stays readable.
Replay publishes the recorded CDR bytes with their recorded timing, scaled by
``rate``.
"""

from __future__ import annotations

import importlib
import queue
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile

from tribo_bringup import bagio
from tribo_bringup.errors import BagError, ConfigError
from tribo_common import topics as topic_table
from tribo_common.node_main import wait_for_subscribers
from tribo_common.qos import data_qos, qos_for_topic, status_qos


def msg_class(msgtype: str) -> type:
    """Import the rclpy message class of a type name like ``tribo_msgs/msg/SampleBlock``.

    Raises
    ------
    BagError
        The message package or type is not available in this environment.
    """
    pkg, kind, name = msgtype.split('/')
    try:
        cls: type = getattr(importlib.import_module(f'{pkg}.{kind}'), name)
        return cls
    except (ImportError, AttributeError) as exc:
        raise BagError(f'message type {msgtype} is not available in this environment') from exc


def _record_qos(topic: str) -> QoSProfile:
    # Volatile for every data and result topic: compatible with any reliable
    # publisher (a TRANSIENT_LOCAL subscription would not match a volatile one).
    entry = topic_table.by_full_name(topic)
    if entry is not None and entry.qos is topic_table.QosKind.STATUS:
        return status_qos()
    return data_qos()


class RecordingError(BagError):
    """Writing the bag failed while recording (disk full, storage error, ...)."""


_STOP = object()

#: Longest wait of a replay, after its last message, for every subscriber to acknowledge
#: the reliable data [s]: a process that exits earlier takes its unacknowledged messages
#: with it (a busy subscriber misses the end of the bag).
ACK_WAIT_S = 10.0


def _in_namespace(topic: str, namespace: str) -> str:
    """Move a root-namespace name (``/rig/speed``) into ``namespace``.

    Absolute table names (``/diagnostics``) stay.
    """
    entry = topic_table.by_full_name(topic)
    if entry is not None and entry.name.startswith('/'):
        return topic
    return topic_table.resolve(topic.lstrip('/'), namespace)


class Recorder(Node):
    """Subscribe to topics (raw CDR) and write them into a bag from one writer thread.

    Args:
        writer: a BagWriter, not yet opened (the writer thread opens it; an MCAP
            writer opened by the caller is accepted too).
        topics: topics to record with their types, root-namespace names (default:
            the graph's topics, :data:`tribo_bringup.bagio.TOPIC_TYPES`).
        discover: also record any other topic of a known type that appears.
        flush_period: wall time between two flushes of the bag [s]: a crash of
            the recorder loses at most the messages of the last period (0: the
            storage's own chunking only, up to 1 MiB for MCAP).
        namespaces: record the topics of the rigs in these namespaces (``''`` or
            ``'/'``: the root namespace; default: the root namespace only).
    """

    def __init__(
        self,
        writer: bagio.BagWriter,
        topics: dict[str, str] | None = None,
        *,
        discover: bool = False,
        flush_period: float = 1.0,
        namespaces: Iterable[str] | None = None,
    ) -> None:
        super().__init__('tribo_recorder')
        if not flush_period >= 0.0:
            raise ConfigError(f'flush period must be >= 0 s, got {flush_period!r}')
        self._writer = writer
        self._flush_period = flush_period
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._subs: dict[str, Any] = {}
        self.received = 0
        #: the writer's failure, if any (recording stopped there)
        self.error: BaseException | None = None
        self.failed = threading.Event()
        self._matched: set[str] = set()
        spaces = [topic_table.normalize_namespace(n) for n in (namespaces or [''])]
        for ns in dict.fromkeys(spaces):
            for topic, msgtype in (topics or bagio.TOPIC_TYPES).items():
                self._subscribe(_in_namespace(topic, ns), msgtype)
        self._thread = threading.Thread(target=self._write_loop, name='bag-writer', daemon=True)
        self._thread.start()
        if discover:
            self.create_timer(1.0, self._discover)
        self.create_timer(0.2, self._announce_matches)

    # --- writer thread ------------------------------------------------------------------
    def _write_loop(self) -> None:
        writer = self._writer
        try:
            if not writer.is_open:
                writer.open()
            next_flush = time.monotonic() + self._flush_period
            while True:
                timeout = max(0.0, next_flush - time.monotonic()) if self._flush_period else 0.5
                try:
                    item = self._queue.get(timeout=timeout)
                except queue.Empty:
                    item = None
                if item is _STOP:
                    break
                if item is not None:
                    topic, stamp, raw = item
                    writer.write(topic, stamp, raw)
                if self._flush_period and time.monotonic() >= next_flush:
                    writer.flush()
                    next_flush = time.monotonic() + self._flush_period
        except BaseException as exc:
            self._fail(exc)
        try:
            writer.close()
        except BaseException as exc:
            self._fail(exc)

    def _fail(self, exc: BaseException) -> None:
        if self.error is None:
            self.error = exc
            self.get_logger().error(f'recording stopped: cannot write {self._writer.path}: {exc}')
        self.failed.set()

    def close(self) -> None:
        """Write what is queued, finish the bag (metadata) and stop the writer thread."""
        if self._thread.is_alive():
            self._queue.put(_STOP)
            self._thread.join()

    # --- subscriptions ------------------------------------------------------------------
    def _announce_matches(self) -> None:
        """Log once per topic when its first publisher is matched (``recording <topic>``)."""
        for topic, sub in self._subs.items():
            if sub is None or topic in self._matched:
                continue
            n = sub.get_publisher_count()
            if n > 0:
                self._matched.add(topic)
                self.get_logger().info(f'recording {topic} ({n} publisher(s) matched)')

    def _subscribe(self, topic: str, msgtype: str) -> None:
        if topic in self._subs:
            return
        try:
            cls = msg_class(msgtype)
        except BagError as exc:
            self.get_logger().warning(f'not recording {topic}: {exc}')
            self._subs[topic] = None
            return
        if not self._writer.add_topic(topic, msgtype):
            self._subs[topic] = None
            return
        self._subs[topic] = self.create_subscription(
            cls, topic, self._callback(topic), _record_qos(topic), raw=True
        )

    def _callback(self, topic: str) -> Callable[[bytes], None]:
        def on_message(raw: bytes) -> None:
            if self.failed.is_set():
                return
            self._queue.put((topic, self.get_clock().now().nanoseconds, raw))
            self.received += 1

        return on_message

    def _discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self._subs or not types:
                continue
            self._subscribe(topic, types[0])


class Replayer(Node):
    """Publish the messages of a bag with their recorded timing.

    Args:
        bag: bag path.
        topics: topics to replay (default: all in the bag).
        rate: playback speed factor (2.0 = twice as fast; 0 = as fast as possible).
    """

    def __init__(self, bag: str | Path, topics: Iterable[str] | None = None, rate: float = 1.0):
        super().__init__('tribo_replay')
        if rate < 0:
            raise ConfigError(f'--rate must be >= 0, got {rate}')
        self.bag = Path(bag)
        self.rate = rate
        self.topics = set(topics) if topics is not None else None
        self._pubs: dict[str, Publisher] = {}
        self.published = 0

    def publisher_for(self, topic: str, msgtype: str) -> Publisher:
        """Create (once) the publisher of a topic."""
        pub = self._pubs.get(topic)
        if pub is None:
            pub = self.create_publisher(msg_class(msgtype), topic, qos_for_topic(topic))
            self._pubs[topic] = pub
        return pub

    def play(
        self,
        wait_subscribers: float = 0.0,
        min_subscribers: int = 1,
        progress: Callable[[int, float], None] | None = None,
        stop: threading.Event | None = None,
    ) -> int:
        """Publish the bag; returns the number of messages published."""
        # create all publishers first so subscribers can match before data flows
        counts: dict[str, str] = {}
        for m in bagio.iter_messages(self.bag, self.topics, deserialize=False, on_error='warn'):
            counts.setdefault(m.topic, m.msgtype)
            if len(counts) >= len(bagio.TOPIC_TYPES):
                break
        for topic, msgtype in counts.items():
            self.publisher_for(topic, msgtype)
        short = (
            wait_for_subscribers(
                {t: self._pubs[t] for t in counts}, wait_subscribers, min_subscribers, stop
            )
            if wait_subscribers > 0
            else {}
        )
        if short and (stop is None or not stop.is_set()):
            self.get_logger().warning(
                f'fewer than {min_subscribers} subscriber(s) after {wait_subscribers:g} s on '
                f'{", ".join(f"{t} ({n})" for t, n in short.items())}: publishing anyway'
            )
        wait = (stop or threading.Event()).wait
        t_wall0 = time.monotonic()
        t_bag0: int | None = None
        last_report = t_wall0
        for m in bagio.iter_messages(self.bag, self.topics, deserialize=False):
            if stop is not None and stop.is_set():
                break
            if t_bag0 is None:
                t_bag0 = m.timestamp_ns
            if self.rate > 0:
                due = t_wall0 + (m.timestamp_ns - t_bag0) * 1e-9 / self.rate
                delay = due - time.monotonic()
                if delay > 0:
                    wait(delay)
            self.publisher_for(m.topic, m.msgtype).publish(m.msg)
            self.published += 1
            now = time.monotonic()
            if progress is not None and now - last_report >= 2.0:
                progress(self.published, (m.timestamp_ns - t_bag0) * 1e-9)
                last_report = now
        if stop is None or not stop.is_set():
            late = self.wait_for_acks(ACK_WAIT_S, stop)
            if late:
                self.get_logger().warning(
                    f'not acknowledged by every subscriber within {ACK_WAIT_S:g} s: '
                    f'{", ".join(late)} (a subscriber may miss the last messages)'
                )
        return self.published

    def wait_for_acks(self, timeout: float, stop: threading.Event | None = None) -> list[str]:
        """Wait until every subscriber acknowledged every message published so far.

        At most ``timeout`` [s] (or until ``stop`` is set); returns the topics whose
        data is not acknowledged yet (empty: all delivered).
        """
        deadline = time.monotonic() + timeout
        pending = dict(self._pubs)
        while pending:
            pending = {
                t: p for t, p in pending.items() if not p.wait_for_all_acked(Duration(seconds=0))
            }
            if not pending or time.monotonic() >= deadline or (stop is not None and stop.is_set()):
                break
            time.sleep(0.05)
        return sorted(pending)
