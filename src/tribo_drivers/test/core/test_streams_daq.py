"""The DAQ stream (core/streams.py) on a dead device: back-off, no busy loop, interruptible."""

from __future__ import annotations

import threading
import time

from tribo_drivers.core.daq_protocol import DaqScaling
from tribo_drivers.core.reconnect import Backoff
from tribo_drivers.core.streams import DaqStream
from tribo_drivers.errors import TransportError


class DeadTransport:
    """A port that never opens (device absent)."""

    is_open = False

    def __init__(self) -> None:
        self.attempts = 0

    def open(self) -> None:
        self.attempts += 1
        raise TransportError('no such device /dev/ttyUSB9')

    def close(self) -> None:
        pass

    def read(self, timeout: float) -> bytes:
        raise TransportError('not open')

    def write(self, data: bytes) -> None:
        raise TransportError('not open')

    def describe(self) -> str:
        return 'dead'


def test_reconnect_backs_off_without_busy_loop() -> None:
    tr = DeadTransport()
    s = DaqStream(tr, DaqScaling(), backoff=Backoff(0.05, 2.0, 0.2))
    t_end = time.monotonic() + 1.0
    while time.monotonic() < t_end:
        assert s.poll(0.01) == []  # never raises
    # delays 0, .05, .1, .2, .2, ... -> about 6-7 attempts in 1 s; a busy loop would do
    # thousands.  Bound generous for a loaded machine, still far from busy looping.
    assert 3 <= tr.attempts <= 9
    assert s.counters.connected is False
    assert 'ttyUSB9' in s.counters.last_error


def test_stop_interrupts_backoff_wait() -> None:
    s = DaqStream(DeadTransport(), DaqScaling(), backoff=Backoff(5.0, 2.0, 5.0))
    s.poll(0.01)  # first attempt fails, next wait would be 5 s
    threading.Timer(0.1, s.stop).start()
    t0 = time.monotonic()
    s.poll(0.01)
    assert time.monotonic() - t0 < 2.0  # interrupted long before the 5 s back-off
