"""The emulator's pty never hangs when the driver stops reading."""

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
