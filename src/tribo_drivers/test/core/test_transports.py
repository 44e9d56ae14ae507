"""SerialTransport (core/transports.py) keeps what it read when the device fails mid-read."""

from __future__ import annotations


class _FailingSerial:
    """pyserial stand-in: one byte arrives, then the device fails (an unplug mid-read)."""

    def __init__(self) -> None:
        self.timeout: float | None = None
        self.in_waiting = 40
        self.calls = 0

    def read(self, size: int) -> bytes:
        import serial

        self.calls += 1
        if self.calls == 1:
            return b'\xa5'
        raise serial.SerialException('read failed: [Errno 5] Input/output error')

    def close(self) -> None:
        pass


def test_serial_read_keeps_received_bytes_when_the_device_fails_mid_read() -> None:
    import pytest

    from tribo_drivers.core.transports import SerialTransport
    from tribo_drivers.errors import TransportError

    tr = SerialTransport('/dev/null-not-opened', 115200)
    tr._serial = _FailingSerial()
    # the byte already received is returned; the failure is reported by the next read
    assert tr.read(0.1) == b'\xa5'
    with pytest.raises(TransportError, match='Input/output error'):
        tr.read(0.1)
