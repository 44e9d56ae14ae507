"""Byte and CAN transports: serial port (pyserial), file replay, python-can bus.

Every failure of the underlying library (port absent, unplugged, busy, EIO) is turned into
:class:`tribo_drivers.errors.TransportError` so the stream layer can close, back off and
reconnect; a transport never lets a library exception escape.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import can

from tribo_drivers.errors import ConfigError, TransportError


class Link(Protocol):
    """What every transport (serial, replay, CAN) offers the streams: open, close, state."""

    @property
    def is_open(self) -> bool:
        """Tell whether the link is open."""

    def open(self) -> None:
        """Open the link (raises TransportError if it cannot)."""

    def close(self) -> None:
        """Close the link; never raises."""

    def describe(self) -> str:
        """Return a short description for messages, e.g. ``/dev/ttyUSB0@921600``."""


class ByteTransport(Link, Protocol):
    """A byte stream that can be opened, read with a timeout, written and closed."""

    def read(self, timeout: float) -> bytes:
        """Return the bytes received within ``timeout`` [s] (b'' if none)."""

    def write(self, data: bytes) -> None:
        """Send ``data``."""


class SerialTransport:
    """Serial port through pyserial (USB-serial adapters, pseudo-terminals).

    port: device path or pyserial URL; baudrate [bit/s].  ``read`` waits up to ``timeout``
    seconds for the first byte and then returns everything already buffered.
    """

    def __init__(self, port: str, baudrate: int = 2_000_000, max_read: int = 1 << 16) -> None:
        if not port:
            raise ConfigError('serial port must not be empty')
        if baudrate <= 0:
            raise ConfigError(f'baudrate must be > 0 bit/s, got {baudrate}')
        self.port = port
        self.baudrate = baudrate
        self.max_read = max_read
        self._serial: Any = None

    @property
    def is_open(self) -> bool:
        """Tell whether the serial port is open."""
        return self._serial is not None

    def describe(self) -> str:
        """Return ``interface:channel``."""
        return f'{self.port}@{self.baudrate}'

    def open(self) -> None:
        """Open the bus (or the replay log); raise TransportError if it cannot."""
        import serial

        self.close()
        try:
            self._serial = serial.serial_for_url(
                self.port, baudrate=self.baudrate, timeout=0.1, write_timeout=1.0, exclusive=True
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            self._serial = None
            raise TransportError(f'cannot open serial port {self.port}: {exc}') from exc

    def close(self) -> None:
        """Shut the bus down; never raises."""
        ser, self._serial = self._serial, None
        if ser is not None:
            with contextlib.suppress(Exception):  # closing a dead port must never raise
                ser.close()

    def read(self, timeout: float) -> bytes:
        """Return the next chunk, paced to ``bytes_per_second`` [B/s] if set (b'' at the end)."""
        import serial

        ser = self._serial
        if ser is None:
            raise TransportError(f'serial port {self.port} is not open')
        failures = (serial.SerialException, OSError, TypeError, AttributeError)
        try:
            ser.timeout = timeout
            first = ser.read(1)
        except failures as exc:
            # TypeError/AttributeError: pyserial internals after a concurrent close.
            raise TransportError(f'serial port {self.port} failed: {exc}') from exc
        if not first:
            return b''
        try:
            # non-blocking: one os.read of what is buffered.  A blocking read(n) loops and,
            # when the device fails mid-loop (unplug), raises and drops the bytes it had
            # already taken from the kernel; with timeout 0 nothing received is ever dropped.
            ser.timeout = 0
            waiting = ser.in_waiting
            rest = ser.read(min(waiting, self.max_read)) if waiting else b''
        except failures:
            rest = b''  # keep the first byte; the next read reports the failure
        return bytes(first + rest)

    def write(self, data: bytes) -> None:
        """Keep ``data`` in ``written`` (a replay has no device to send to)."""
        import serial

        ser = self._serial
        if ser is None:
            raise TransportError(f'serial port {self.port} is not open')
        try:
            ser.write(data)
            ser.flush()
        except (serial.SerialException, OSError) as exc:
            raise TransportError(f'write to {self.port} failed: {exc}') from exc


class CanTransport:
    """A python-can bus of any interface (socketcan, slcan, virtual, pcan, ...).

    interface, channel, bitrate [bit/s] and extra keyword arguments go to ``can.Bus``.
    The special interface ``replay`` plays back a python-can log file (channel = path;
    .asc, .blf, .csv, .log, ...).
    """

    def __init__(
        self,
        interface: str,
        channel: str,
        bitrate: int | None = 500_000,
        can_filters: list[dict[str, int]] | None = None,
        **kwargs: object,
    ) -> None:
        if not interface:
            raise ConfigError('CAN interface must not be empty')
        if bitrate is not None and bitrate <= 0:
            raise ConfigError(f'CAN bitrate must be > 0 bit/s, got {bitrate}')
        self.interface = interface
        self.channel = channel
        self.bitrate = bitrate
        self.can_filters = can_filters
        # passed through to can.Bus, whose interface options are **kwargs: Any
        self.kwargs: dict[str, Any] = dict(kwargs)
        self._bus: can.BusABC | None = None
        self._replay: Iterator[can.Message] | None = None

    @property
    def is_open(self) -> bool:
        """Tell whether the serial port is open."""
        return self._bus is not None or self._replay is not None

    def describe(self) -> str:
        """Return ``interface:channel``."""
        return f'{self.interface}:{self.channel}'

    def open(self) -> None:
        """Open the bus (or the replay log); raise TransportError if it cannot."""
        import can

        self.close()
        try:
            if self.interface == 'replay':
                self._replay = iter(can.LogReader(self.channel))
                return
            kwargs = dict(self.kwargs)
            if self.bitrate is not None and self.interface not in ('virtual',):
                kwargs['bitrate'] = self.bitrate
            self._bus = can.Bus(
                interface=self.interface,
                channel=self.channel,
                can_filters=self.can_filters,
                **kwargs,
            )
        except (can.CanError, OSError, ValueError, ImportError) as exc:
            self._bus = None
            raise TransportError(
                f'cannot open CAN {self.interface} channel {self.channel!r}: {exc}'
            ) from exc

    def close(self) -> None:
        """Shut the bus down; never raises."""
        bus, self._bus = self._bus, None
        self._replay = None
        if bus is not None:
            with contextlib.suppress(Exception):  # shutting down a dead bus must never raise
                bus.shutdown()

    def recv(self, timeout: float) -> can.Message | None:
        """Return the next CAN message, or None after ``timeout`` [s] without one.

        Raises
        ------
        TransportError
            The bus or the replay log failed, or the transport is not open.
        """
        import can

        if self._replay is not None:
            try:
                return next(self._replay)
            except StopIteration:
                time.sleep(timeout)
                return None
            except (ValueError, OSError) as exc:
                raise TransportError(f'CAN replay {self.channel} failed: {exc}') from exc
        bus = self._bus
        if bus is None:
            raise TransportError(f'CAN {self.interface}:{self.channel} is not open')
        try:
            return bus.recv(timeout)
        except (can.CanError, OSError, ValueError, TypeError, AttributeError) as exc:
            raise TransportError(f'CAN {self.interface}:{self.channel} failed: {exc}') from exc
