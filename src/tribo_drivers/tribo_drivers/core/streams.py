"""Driver pipelines: transport -> decoder -> gap tracker -> batcher -> stamped blocks.

Each stream owns its transport and reconnects by itself: ``poll()`` never raises on device
trouble; it returns what could be decoded, records the error in its counters and retries the
port with exponential back-off (:mod:`tribo_drivers.core.reconnect`).  The nodes call
``poll()`` in a reader thread and publish the results; ``stop()`` interrupts a back-off wait.
"""

from __future__ import annotations

import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, TypeVar

import numpy as np

from tribo_drivers.core import counter_protocol as cp
from tribo_drivers.core.can_protocol import CanCodec, CanStreamSpec
from tribo_drivers.core.daq_protocol import CHANNELS, UNITS, DaqDecoder, DaqSamples, DaqScaling
from tribo_drivers.core.diagnostics import DriverCounters, RateMeter
from tribo_drivers.core.gaps import BlockBatcher, IndexTracker, SampleBlock, block_size_for
from tribo_drivers.core.reconnect import Backoff, ReconnectState
from tribo_drivers.core.timing import SampleClock
from tribo_drivers.core.transports import ByteTransport, CanTransport, Link

if TYPE_CHECKING:
    import can

from tribo_drivers.errors import (
    ChecksumError,
    ConfigError,
    DriverError,
    FrameError,
    ProtocolError,
    TransportError,
)

T = TypeVar('T')


class DeviceStream(ABC, Generic[T]):
    """Open/read/reconnect state machine shared by the drivers.

    Subclasses set ``self.transport``; opening, closing and describing the device
    delegate to it unless a subclass adds to them (a handshake, a decoder reset).
    host_clock: wall clock for stamps [s] (time.time); the back-off uses time.monotonic.
    """

    transport: Link

    def __init__(self, backoff: Backoff | None = None, host_clock: Callable[[], float] = time.time):
        self.backoff = backoff or Backoff()
        self.host_clock = host_clock
        self.counters = DriverCounters()
        self.connection = ReconnectState()
        self.rate = RateMeter()
        self._stop = threading.Event()
        self.open_attempts = 0
        self._pending_open: list[T] = []

    # --- the device, through its transport ---------------------------------------------
    def describe(self) -> str:
        """Return the transport's description, e.g. ``/dev/ttyUSB0@921600``."""
        return self.transport.describe()

    def _is_open(self) -> bool:
        return self.transport.is_open

    def _open(self) -> list[T]:
        self.transport.open()
        return []

    def _close(self) -> None:
        self.transport.close()

    # --- to implement -------------------------------------------------------------------
    @abstractmethod
    def _read(self, timeout: float) -> list[T]: ...

    @abstractmethod
    def _flush(self) -> list[T]: ...

    # --- state machine ------------------------------------------------------------------
    def stop(self) -> None:
        """Interrupt any back-off wait; ``poll`` returns at once from now on."""
        self._stop.set()

    def resume(self) -> None:
        """Allow reading again after a close."""
        self._stop.clear()

    def poll(self, timeout: float = 0.05) -> list[T]:
        """Read once (opening/reconnecting the device first if needed); never raises on faults."""
        if self._stop.is_set():
            return []
        if not self._is_open():
            delay = self.backoff.delay(self.connection.failures)
            if delay > 0 and self._stop.wait(delay):
                return []
            self.open_attempts += 1
            try:
                out = self._open()
            except DriverError as exc:
                self._close()
                self.connection.failed(str(exc))
                self.counters.last_error = str(exc)
                return []
            self.connection.connected()
            self.counters.connected = True
            self.counters.reconnects = self.connection.reconnects
            return out
        try:
            return self._read(timeout)
        except TransportError as exc:
            return self._lost(str(exc))

    def _lost(self, message: str) -> list[T]:
        out = self._flush()
        self._close()
        self.connection.lost(message)
        self.counters.connected = False
        self.counters.disconnects = self.connection.disconnects
        self.counters.last_error = message
        return out

    def open(self) -> None:
        """Open now (lifecycle *configure*); raises the device error instead of backing off."""
        self.resume()
        self.open_attempts += 1
        self._pending_open = self._open()
        self.connection.connected()
        self.counters.connected = True

    def take_pending(self) -> list[T]:
        """Return and forget the items decoded during the last open."""
        out, self._pending_open = self._pending_open, []
        return out

    def close(self) -> list[T]:
        """Close the device (lifecycle *deactivate/cleanup*); returns the flushed remainder."""
        self.stop()
        out = self._flush()
        self._close()
        self.counters.connected = False
        return out


class DaqStream(DeviceStream[SampleBlock]):
    """Serial DAQ: 20-byte frames -> SampleBlocks of the three channels (SI units)."""

    transport: ByteTransport

    def __init__(
        self,
        transport: ByteTransport,
        scaling: DaqScaling,
        sample_rate: float = 10_000.0,
        block_size: int | None = None,
        backoff: Backoff | None = None,
        host_clock: Callable[[], float] = time.time,
        confirm_jump: int | None = None,
    ) -> None:
        super().__init__(backoff, host_clock)
        if not sample_rate > 0:
            raise ConfigError(f'sample_rate must be > 0 Hz, got {sample_rate}')
        self.transport = transport
        self.sample_rate = sample_rate
        self.decoder = DaqDecoder(scaling)
        self.tracker = IndexTracker(
            bits=32, confirm_jump=confirm_jump or max(int(sample_rate), 1) * 60
        )
        self.clock = SampleClock(sample_rate)
        self.batcher = BlockBatcher(
            dict(UNITS), sample_rate, block_size or block_size_for(sample_rate, 200.0)
        )

    def _close(self) -> None:
        super()._close()
        self.decoder.reset()

    def _stamp(self, index: int) -> float:
        return self.clock.time_of(index)

    def _flush(self) -> list[SampleBlock]:
        blocks = self._ingest(self.decoder.flush(), None)
        if self.clock.offset is None:
            return blocks
        tail = self.batcher.flush(self._stamp)
        self._count(tail)
        return blocks + tail

    def _count(self, blocks: list[SampleBlock]) -> None:
        n = len(blocks) // len(CHANNELS)
        self.counters.blocks += n

    def _read(self, timeout: float) -> list[SampleBlock]:
        data = self.transport.read(timeout)
        now = self.host_clock()
        if not data:  # the line is idle: the frame held back for a possible overlap is complete
            return self._flush()
        return self._ingest(self.decoder.feed(data), now)

    def _ingest(self, samples: DaqSamples, now: float | None) -> list[SampleBlock]:
        """Track, stamp and batch decoded frames; ``now`` is their arrival time [s] if known."""
        st = self.decoder.stats
        c = self.counters
        c.crc_errors = st.crc_errors
        c.discarded_bytes = st.discarded_bytes
        if len(samples) == 0:
            return []
        tr = self.tracker.update(samples.sample_index)
        g = self.tracker.counters
        c.frames = g.accepted
        c.gaps, c.lost, c.duplicates = g.gaps, g.lost, g.duplicates
        c.outliers, c.restarts = g.outliers, g.restarts
        if tr.index.size == 0:
            return []
        if tr.restart.any():
            self.clock.reset()
        if now is not None or self.clock.offset is None:
            self.clock.observe(self.host_clock() if now is None else now, int(tr.index[-1]))
        values = {ch: getattr(samples, ch)[tr.keep] for ch in CHANNELS}
        c.samples += int(tr.index.size)
        self.rate.add(time.monotonic(), int(tr.index.size))
        blocks = self.batcher.push(tr.index, values, self._stamp)
        self._count(blocks)
        return blocks


@dataclass(frozen=True)
class CountMessage:
    """One dwell, ready for tribo_msgs/DetectorCounts (SI: s, counts)."""

    stamp: float
    seq: int
    t_start: float
    t_end: float
    counts: int
    live_time: float


class CounterStream(DeviceStream[CountMessage]):
    """Radiation counter: DWELL/ACK handshake on open, then one CountMessage per CNT line."""

    transport: ByteTransport

    def __init__(
        self,
        transport: ByteTransport,
        dwell_ms: int = 1000,
        ack_timeout: float = 1.0,
        ack_retries: int = 3,
        backoff: Backoff | None = None,
        host_clock: Callable[[], float] = time.time,
    ) -> None:
        super().__init__(backoff, host_clock)
        if dwell_ms <= 0:
            raise ConfigError(f'dwell must be > 0 ms, got {dwell_ms}')
        if ack_timeout <= 0 or ack_retries < 1:
            raise ConfigError('ack_timeout must be > 0 s and ack_retries >= 1')
        self.transport = transport
        self.dwell_ms = dwell_ms
        self.ack_timeout = ack_timeout
        self.ack_retries = ack_retries
        self.splitter = cp.LineSplitter()
        self.tracker = IndexTracker(bits=32, confirm_jump=1000, confirm=False)
        self.acked_dwell_ms: int | None = None

    def _close(self) -> None:
        super()._close()
        self.splitter.reset()

    def _flush(self) -> list[CountMessage]:
        return []

    def _open(self) -> list[CountMessage]:
        super()._open()
        self.splitter.reset()
        backlog: list[CountMessage] = []
        for _attempt in range(self.ack_retries):
            self.transport.write(cp.format_dwell(self.dwell_ms))
            end = time.monotonic() + self.ack_timeout
            while time.monotonic() < end:
                if self._stop.is_set():
                    raise TransportError('stopped during the DWELL handshake')
                data = self.transport.read(min(0.05, max(end - time.monotonic(), 0.001)))
                for line in self.splitter.feed(data):
                    kind, msg = self._line(line)
                    if msg is not None:
                        backlog.append(msg)
                    elif kind == 'ACK':
                        ack = cp.parse_ack_dwell(line)
                        if ack != self.dwell_ms:
                            raise ProtocolError(
                                f'counter acknowledged dwell {ack} ms, requested {self.dwell_ms} ms'
                            )
                        self.acked_dwell_ms = ack
                        return backlog
        raise ProtocolError(
            f'no $ACK,DWELL,{self.dwell_ms} from {self.describe()} after {self.ack_retries} tries'
        )

    def _line(self, line: bytes) -> tuple[str, CountMessage | None]:
        """Classify one line; CNT lines become messages, bad ones are counted."""
        c = self.counters
        if not line.strip():
            return '', None
        try:
            fields = cp.parse_sentence(line)
        except ChecksumError as exc:
            c.crc_errors += 1
            c.last_error = str(exc)
            return '', None
        except FrameError as exc:
            c.frame_errors += 1
            c.last_error = str(exc)
            return '', None
        kind = cp.sentence_kind(fields)
        if kind != 'CNT':
            return kind, None
        try:
            rec = cp.parse_cnt(line)
        except DriverError as exc:
            c.frame_errors += 1
            c.last_error = str(exc)
            return kind, None
        tr = self.tracker.update(np.array([rec.seq], dtype=np.int64))
        g = self.tracker.counters
        c.frames = g.accepted
        c.gaps, c.lost, c.duplicates, c.restarts = g.gaps, g.lost, g.duplicates, g.restarts
        if not tr.keep[0]:
            return kind, None
        c.samples += 1
        c.blocks += 1
        self.rate.add(time.monotonic())
        msg = CountMessage(
            self.host_clock(), rec.seq, rec.t_start, rec.t_end, rec.counts, rec.live_time
        )
        return kind, msg

    def _read(self, timeout: float) -> list[CountMessage]:
        data = self.transport.read(timeout)
        out: list[CountMessage] = []
        for line in self.splitter.feed(data):
            _, msg = self._line(line)
            if msg is not None:
                out.append(msg)
        self.counters.discarded_bytes = self.splitter.overflows
        return out


class _CanSub:
    """Per-frame-type state of the CAN stream."""

    def __init__(self, spec: CanStreamSpec, blocks_per_second: float) -> None:
        self.spec = spec
        self.tracker = IndexTracker(
            bits=16, step=spec.samples_per_frame, confirm_jump=(1 << 15) - 1
        )
        self.clock = SampleClock(spec.sample_rate)
        units = {ch: unit for ch, (_, unit, _) in spec.channels.items()}
        self.batcher = BlockBatcher(
            units, spec.sample_rate, block_size_for(spec.sample_rate, blocks_per_second)
        )
        self.last_host: float | None = None


class CanStream(DeviceStream[SampleBlock]):
    """CAN sensor modules: frames -> per-channel SampleBlocks (SI; temperature in K)."""

    transport: CanTransport

    def __init__(
        self,
        transport: CanTransport,
        codec: CanCodec,
        blocks_per_second: float = 100.0,
        backoff: Backoff | None = None,
        host_clock: Callable[[], float] = time.time,
        max_frames_per_poll: int = 2000,
    ) -> None:
        super().__init__(backoff, host_clock)
        self.transport = transport
        self.codec = codec
        self.subs = {fid: _CanSub(spec, blocks_per_second) for fid, spec in codec.specs.items()}
        self.max_frames_per_poll = max_frames_per_poll

    def _flush(self) -> list[SampleBlock]:
        out: list[SampleBlock] = []
        for sub in self.subs.values():
            if sub.clock.offset is not None:
                out.extend(sub.batcher.flush(sub.clock.time_of))
        return out

    def _read(self, timeout: float) -> list[SampleBlock]:
        out: list[SampleBlock] = []
        msg = self.transport.recv(timeout)
        n = 0
        while msg is not None:
            out.extend(self._frame(msg))
            n += 1
            if n >= self.max_frames_per_poll:
                break
            msg = self.transport.recv(0.0)
        if n == 0:
            out.extend(self._flush())
        return out

    def _frame(self, msg: can.Message) -> list[SampleBlock]:
        c = self.counters
        if getattr(msg, 'is_error_frame', False) or getattr(msg, 'is_remote_frame', False):
            return []
        try:
            sample = self.codec.decode(int(msg.arbitration_id), bytes(msg.data))
        except FrameError as exc:
            c.frame_errors += 1
            c.last_error = str(exc)
            return []
        if sample is None:  # a frame of another module on the bus
            return []
        sub = self.subs[sample.frame_id]
        host = float(msg.timestamp) if getattr(msg, 'timestamp', 0.0) else self.host_clock()
        expected = None
        if sub.last_host is not None:
            expected = max(host - sub.last_host, 0.0) * sub.spec.frame_rate
        tr = sub.tracker.update(np.array([sample.seq], dtype=np.int64), expected)
        self._sync_counters()
        if tr.index.size == 0:
            return []
        sub.last_host = host
        if tr.restart.any():
            sub.clock.reset()
        per = sub.spec.samples_per_frame
        first = int(tr.index[0])
        idx = np.arange(first, first + per, dtype=np.int64)
        sub.clock.observe(host, int(idx[-1]))
        c.frames += 1
        c.samples += per
        self.rate.add(time.monotonic())
        values = {ch: np.asarray(v, dtype=np.float64) for ch, v in sample.values.items()}
        blocks = sub.batcher.push(idx, values, sub.clock.time_of)
        c.blocks += len(blocks)
        return blocks

    def _sync_counters(self) -> None:
        c = self.counters
        subs = [s.tracker.counters for s in self.subs.values()]
        c.gaps = sum(g.gaps for g in subs)
        c.lost = sum(g.lost for g in subs)
        c.duplicates = sum(g.duplicates for g in subs)
        c.outliers = sum(g.outliers for g in subs)
        c.restarts = sum(g.restarts for g in subs)
