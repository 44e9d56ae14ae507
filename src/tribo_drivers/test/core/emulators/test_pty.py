"""The emulator's pty (core/emulators/pty.py) never hangs when the driver stops reading."""

from __future__ import annotations

import threading
import time

from tribo_drivers.core.emulators import PtyPort


def test_write_to_a_port_nobody_reads_times_out_and_close_returns() -> None:
    port = PtyPort()
    try:
        # far more than a pty buffer holds (a few kB): the write cannot complete
        t0 = time.monotonic()
        assert port.write(b'\x55' * 1_000_000, timeout=0.3) is False
        assert time.monotonic() - t0 < 5.0  # timeout 0.3 s; generous for a loaded machine
        # a writer blocked in its retry loop must not keep close() waiting on the lock
        writer = threading.Thread(target=port.write, args=(b'\x55' * 1_000_000, 30.0))
        writer.start()
        time.sleep(0.1)
        closer = threading.Thread(target=port.close)
        closer.start()
        closer.join(5.0)
        assert not closer.is_alive()
        writer.join(5.0)  # the write sees the unplug and returns False
        assert not writer.is_alive()
    finally:
        port.close()


def test_drain_waits_for_the_driver_to_report_every_written_byte() -> None:
    port = PtyPort()
    try:
        port.require_open_notice = True
        port.notify_opened()
        assert port.write(b'\x01' * 100)
        # the queue may look empty while bytes sit in the kernel's flip buffer: with read
        # reports, drain needs the count, not the queue
        with open(port.path, 'rb', buffering=0) as slave:
            got = b''
            while len(got) < 100:
                got += slave.read(100 - len(got))
            assert port.drain(0.05) is False  # read but not reported yet
            port.note_driver_read(len(got))
            assert port.drain(0.5) is True
    finally:
        port.close()
