"""Pseudo-terminal device port and the thread life cycle shared by the emulators."""

from __future__ import annotations

import contextlib
import fcntl
import os
import select
import struct
import tempfile
import termios
import threading
import time
import tty
from pathlib import Path


class PtyPort:
    """A pseudo-terminal pair reachable through a stable symlink ``path``.

    The emulator side uses ``master``; the driver opens ``path`` (-> the slave tty).
    """

    def __init__(self, path: str | Path | None = None) -> None:
        if path is None:
            self._tmp: tempfile.TemporaryDirectory[str] | None = tempfile.TemporaryDirectory(
                prefix='tribo_pty_'
            )
            path = Path(self._tmp.name) / 'dev'
        else:
            self._tmp = None
        self.path = Path(path)
        self.master = -1
        self._slave = -1
        self.lock = threading.RLock()
        #: set by :meth:`notify_opened`; when ``require_open_notice`` is True the port
        #: counts as attached only after it (the driver's open, input flush included,
        #: has returned), not already when the driver has configured the line
        self.require_open_notice = False
        self._open_noticed = False
        #: bytes written since the driver's open notice and bytes the driver reports as
        #: read (:meth:`note_driver_read`): ``drain`` compares them when the notice is on
        self._written = 0
        self._driver_read = 0
        self.plug()

    @property
    def plugged(self) -> bool:
        """Return whether the pty pair exists (the device is plugged in)."""
        return self.master >= 0

    def plug(self) -> None:
        """Create a fresh pty pair behind ``path`` (raw mode, no echo, no CR/LF mapping)."""
        with self.lock:
            if self.plugged:
                return
            master, slave = os.openpty()
            tty.setraw(slave)
            tty.setraw(master)
            attrs = termios.tcgetattr(slave)
            attrs[4] = attrs[5] = termios.B50  # sentinel: replaced when a driver configures it
            termios.tcsetattr(slave, termios.TCSANOW, attrs)
            # non-blocking master: a write never blocks while holding the lock (a driver
            # that stopped reading would otherwise hang write() and so unplug()/close())
            os.set_blocking(master, False)
            self.master, self._slave = master, slave
            self._open_noticed = False
            tmp = self.path.with_suffix('.tmp')
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            os.symlink(os.ttyname(slave), tmp)
            os.replace(tmp, self.path)

    def driver_attached(self) -> bool:
        """Tell whether a driver has opened and configured the port (its speed replaced B50).

        Data written before that would be flushed by the driver's open (pyserial discards the
        input buffer), so emulators wait for this before they count a frame as sent. The
        speed is set a moment before that flush; on a heavily loaded machine the moment
        can be long, so exact accounting (faultsim) uses :meth:`notify_opened` instead.
        """
        with self.lock:
            if not self.plugged:
                return False
            if self.require_open_notice:
                return self._open_noticed
            return bool(termios.tcgetattr(self._slave)[4] != termios.B50)

    def notify_opened(self) -> None:
        """Note that the driver's open has returned (called by a test transport, see faultsim)."""
        with self.lock:
            if self.plugged:
                self._open_noticed = True
                self._written = self._driver_read = 0

    def note_driver_read(self, n: int) -> None:
        """Count ``n`` bytes as read by the driver (called by a test transport, see faultsim)."""
        with self.lock:
            self._driver_read += n

    def pending_to_driver(self) -> int:
        """Bytes written by the emulator that the driver has not read yet."""
        with self.lock:
            if not self.plugged:
                return 0
            buf = fcntl.ioctl(self._slave, termios.TIOCINQ, b'\0\0\0\0')
            return int(struct.unpack('i', buf)[0])

    def _drained(self) -> bool:
        if self.pending_to_driver():
            return False
        if not self.require_open_notice:
            return True
        # the kernel moves written bytes to the slave's input queue asynchronously (the
        # tty flip buffer), so an empty queue right after a write does not mean the driver
        # has them: with read reports, compare byte counts instead
        with self.lock:
            return not self.plugged or self._driver_read >= self._written

    def drain(self, timeout: float = 2.0) -> bool:
        """Wait until the driver has read everything written so far (True if it did)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self._drained():
                return True
            time.sleep(0.002)
        return False

    def unplug(self) -> None:
        """Remove the device: close both ends and the symlink; pending bytes are lost."""
        with self.lock:
            if not self.plugged:
                return
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
            for fd in (self.master, self._slave):
                with contextlib.suppress(OSError):
                    os.close(fd)
            self.master = self._slave = -1

    def replug(self) -> None:
        """Unplug and plug again: a new pty behind the same path."""
        self.unplug()
        self.plug()

    def write(self, data: bytes, timeout: float = 1.0) -> bool:
        """Write all of ``data`` (False if unplugged or the driver does not read for too long)."""
        view = memoryview(data)
        end = time.monotonic() + timeout
        while view:
            with self.lock:
                if not self.plugged:
                    return False
                fd = self.master
                _, writable, _ = select.select([], [fd], [], 0.0)
                if writable:
                    try:
                        n = os.write(fd, view)
                    except BlockingIOError:
                        n = 0
                    except OSError:
                        return False
                    self._written += n
                    view = view[n:]
                    continue
            if time.monotonic() > end:
                return False
            time.sleep(0.001)
        return True

    def read(self, timeout: float) -> bytes:
        """Bytes the driver wrote to the device (b'' after ``timeout`` or when unplugged)."""
        with self.lock:
            fd = self.master
        if fd < 0:
            time.sleep(timeout)
            return b''
        try:
            ready, _, _ = select.select([fd], [], [], timeout)
            if ready:
                with self.lock:
                    if self.master != fd:
                        return b''
                    return os.read(fd, 4096)
        except (OSError, ValueError):
            return b''
        return b''

    def close(self) -> None:
        """Unplug and remove the temporary directory of the link."""
        self.unplug()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None


class _EmulatorThread:
    """Thread lifecycle shared by the device emulators.

    ``start`` runs ``_run`` in a daemon thread until ``stop``.
    """

    THREAD_NAME = 'emulator'

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _run(self) -> None:
        raise NotImplementedError

    def start(self) -> None:
        """Start streaming at the current time, from ``next_index``."""
        self._thread = threading.Thread(target=self._run, name=self.THREAD_NAME, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)


class _PtyEmulator(_EmulatorThread):
    """An emulator behind a pseudo-terminal (``port``); ``close`` also closes it."""

    port: PtyPort

    @property
    def path(self) -> str:
        """Device path the driver opens (the pty's slave side)."""
        return str(self.port.path)

    def close(self) -> None:
        """Unplug and remove the temporary directory of the link."""
        self.stop()
        self.port.close()
