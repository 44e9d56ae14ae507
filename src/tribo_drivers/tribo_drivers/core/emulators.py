"""Device emulators for tests and benchmarks (no hardware needed).

* :class:`PtyPort` a pseudo-terminal pair (``os.openpty``) with a stable symlink path, so a
  driver can open "the device" by name; ``unplug()`` closes the pair (the driver's reads fail
  with EIO like a vanished USB adapter) and ``replug()`` creates a fresh pair behind the same
  path.
* :class:`DaqEmulator` streams DAQ frames in real time with injected faults (corrupted frames,
  dropped bytes, garbage bursts, unplug/replug) and records the ground truth: which sample
  indices went out intact, which were damaged, which were never sent.
* :class:`CounterEmulator` the radiation counter: answers ``$DWELL`` with ``$ACK`` and emits
  one ``$CNT`` line per dwell (optionally with wrong checksums and garbage lines).
* :class:`CanEmulator` sends the CAN sensor frames to any python-can bus (e.g. ``virtual``);
  :class:`SlcanPtyDevice` is a serial-line CAN adapter (slcan / Lawicel protocol) on a pty.
"""

from __future__ import annotations

import contextlib
import fcntl
import math
import os
import select
import struct
import tempfile
import termios
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from tribo_drivers.core import counter_protocol as cp
from tribo_drivers.core.can_protocol import ACCEL_ID, SPEED_ID, CanCodec
from tribo_drivers.core.daq_protocol import FRAME_SIZE, encode_frames
from tribo_drivers.errors import TransportError


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

    def pending_to_driver(self) -> int:
        """Bytes written by the emulator that the driver has not read yet."""
        with self.lock:
            if not self.plugged:
                return 0
            buf = fcntl.ioctl(self._slave, termios.TIOCINQ, b'\0\0\0\0')
            return int(struct.unpack('i', buf)[0])

    def drain(self, timeout: float = 2.0) -> bool:
        """Wait until the driver has read everything written so far (True if it did)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.pending_to_driver() == 0:
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


def default_daq_signal(
    index: npt.NDArray[np.int64],
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Raw counts that are a known function of the sample index (tests check the values)."""
    torque = (index * 7919) % 2_000_001 - 1_000_000
    accel = (index * 104_729) % 200_001 - 100_000
    speed = 150_000 + (index % 1000)
    return torque, accel, speed


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


@dataclass
class DaqTruth:
    """Ground truth of a DAQ emulation (unwrapped sample indices)."""

    intact: list[npt.NDArray[np.int64]] = field(default_factory=list)
    damaged: list[npt.NDArray[np.int64]] = field(default_factory=list)
    unsent: list[npt.NDArray[np.int64]] = field(default_factory=list)
    # intact frames sent shortly after the driver opened the port: its open may still flush
    # them (pyserial resets the input buffer last), so they may or may not arrive
    uncertain: list[npt.NDArray[np.int64]] = field(default_factory=list)
    garbage_bursts: int = 0
    garbage_bytes: int = 0
    unplugs: int = 0

    def intact_indices(self) -> npt.NDArray[np.int64]:
        """Return the sample indices of the frames sent intact."""
        return np.concatenate(self.intact) if self.intact else np.zeros(0, dtype=np.int64)

    def uncertain_indices(self) -> npt.NDArray[np.int64]:
        """Return the sample indices of frames that may or may not arrive (sent around a fault)."""
        return np.concatenate(self.uncertain) if self.uncertain else np.zeros(0, dtype=np.int64)

    def count(self, what: str) -> int:
        """Return the number of indices in the ground-truth list ``what`` (e.g. ``'intact'``)."""
        return int(sum(a.size for a in getattr(self, what)))


class DaqEmulator(_PtyEmulator):
    """Serial DAQ on a pty: 20-byte frames at ``sample_rate`` with injected faults.

    corrupt_fraction: fraction of frames with one byte flipped (caught by the CRC, or a
    broken sync); drop_fraction: fraction of frames missing one byte; garbage bursts are
    requested with :meth:`inject_garbage` (random bytes, some with fake sync words).
    ``start_index`` (u32 counter start, unwrapped) lets tests cross the 2**32 wrap.
    """

    THREAD_NAME = 'daq-emulator'

    def __init__(
        self,
        sample_rate: float = 10_000.0,
        *,
        start_index: int = 0,
        corrupt_fraction: float = 0.0,
        drop_fraction: float = 0.0,
        seed: int = 0,
        signal: Callable[
            [npt.NDArray[np.int64]],
            tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]],
        ] = default_daq_signal,
        chunk_period: float = 0.002,
        port: PtyPort | None = None,
    ) -> None:
        super().__init__()
        self.sample_rate = sample_rate
        self.port = port or PtyPort()
        self.next_index = start_index
        self.corrupt_fraction = corrupt_fraction
        self.drop_fraction = drop_fraction
        self.rng = np.random.default_rng(seed)
        self.signal = signal
        self.chunk_period = chunk_period
        self.truth = DaqTruth()
        self._garbage: list[bytes] = []
        self._lock = threading.RLock()
        self._paused = threading.Event()
        self._attached_at: float | None = None
        self.attach_grace = 0.05  # s after the driver configured the port (its flush)
        self.uncertain_window = 0.1  # s after that in which intact frames count as uncertain
        self._t0 = 0.0
        self._index0 = start_index

    def start(self) -> None:
        """Start streaming at the current time, from ``next_index``."""
        self._t0 = time.monotonic()
        self._index0 = self.next_index
        super().start()

    def inject_garbage(self, length: int, fake_syncs: int = 2) -> None:
        """Queue a burst of ``length`` random bytes (with some ``A5 5A`` fake syncs)."""
        burst = bytearray(self.rng.integers(0, 256, length, dtype=np.uint8).tobytes())
        for _ in range(min(fake_syncs, max(length - 1, 0))):
            p = int(self.rng.integers(0, length - 1))
            burst[p : p + 2] = b'\xa5\x5a'
        with self._lock:
            self._garbage.append(bytes(burst))

    def unplug(self, drain: bool = True) -> None:
        """Stop sending, optionally let the driver read what is in flight, then unplug.

        Samples falling due while unplugged are never sent (the device keeps counting).
        """
        with self._lock:
            self._paused.set()
        if drain:
            self.port.drain(timeout=10.0)
        self.port.unplug()
        self.truth.unplugs += 1

    def replug(self) -> None:
        """Plug the port in again and resume streaming."""
        self.port.plug()
        self._paused.clear()

    def _live(self) -> bool:
        if self._paused.is_set() or not self.port.plugged:
            self._attached_at = None
            return False
        if self._attached_at is None:
            if self.port.driver_attached():
                self._attached_at = time.monotonic()
            return False
        return time.monotonic() - self._attached_at >= self.attach_grace

    def _run(self) -> None:
        while not self._stop.is_set():
            due = self._index0 + int((time.monotonic() - self._t0) * self.sample_rate)
            if due > self.next_index:
                idx = np.arange(self.next_index, due, dtype=np.int64)
                self.next_index = due
                with self._lock:
                    if self._live():
                        self._send(idx)
                    else:
                        self.truth.unsent.append(idx)
            self._stop.wait(self.chunk_period)

    def _send(self, idx: npt.NDArray[np.int64]) -> None:
        n = idx.size
        u = self.rng.random(n)
        corrupt = u < self.corrupt_fraction
        drop = (u >= self.corrupt_fraction) & (u < self.corrupt_fraction + self.drop_fraction)
        t, a, s = self.signal(idx)
        raw = bytearray(encode_frames(idx, t, a, s))
        damaged = corrupt | drop
        for i in np.flatnonzero(corrupt).tolist():
            pos = i * FRAME_SIZE + int(self.rng.integers(0, FRAME_SIZE))
            raw[pos] ^= int(self.rng.integers(1, 256))
        # drop one byte per dropped frame (from the end so earlier offsets stay valid)
        for i in np.flatnonzero(drop).tolist()[::-1]:
            del raw[i * FRAME_SIZE + int(self.rng.integers(0, FRAME_SIZE))]
        with self._lock:
            garbage, self._garbage = self._garbage, []
        if garbage:
            # put the bursts between frames at random frame boundaries of this chunk
            out = bytearray()
            cuts = sorted(int(self.rng.integers(0, n + 1)) for _ in garbage)
            offsets = np.concatenate([[0], np.cumsum(np.where(drop, FRAME_SIZE - 1, FRAME_SIZE))])
            prev = 0
            for cut, burst in zip(cuts, garbage, strict=True):
                out += raw[offsets[prev] : offsets[cut]] + burst
                prev = cut
                self.truth.garbage_bursts += 1
                self.truth.garbage_bytes += len(burst)
            out += raw[offsets[prev] :]
            raw = out
        ok = self.port.write(bytes(raw), timeout=30.0)
        attached = self._attached_at if self._attached_at is not None else -math.inf
        if ok and time.monotonic() - attached < self.attach_grace + self.uncertain_window:
            self.truth.uncertain.append(idx[~damaged])
            self.truth.damaged.append(idx[damaged])
        elif ok:
            self.truth.intact.append(idx[~damaged])
            self.truth.damaged.append(idx[damaged])
        else:  # unplugged during the write: nothing of this chunk is trustworthy
            self.truth.damaged.append(idx)


class CounterEmulator(_PtyEmulator):
    """Radiation counter on a pty: ``$DWELL`` -> ``$ACK``, one ``$CNT`` per dwell.

    dwell_ms: initial dwell [ms]; time_scale: test seconds per real second (accelerated
    tests); rate_cps: mean count rate [1/s] (Poisson); dead_fraction: live = dwell*(1-x);
    bad_checksum_every: every n-th CNT line gets a wrong checksum (0 = never);
    ignore_dwell_commands: this many DWELL commands are not answered (handshake retries).
    """

    THREAD_NAME = 'counter-emulator'

    def __init__(
        self,
        dwell_ms: int = 1000,
        *,
        time_scale: float = 1.0,
        rate_cps: float = 500.0,
        dead_fraction: float = 0.002,
        seed: int = 0,
        bad_checksum_every: int = 0,
        ignore_dwell_commands: int = 0,
        start_seq: int = 1,
        port: PtyPort | None = None,
    ) -> None:
        super().__init__()
        self.port = port or PtyPort()
        self.dwell_ms = dwell_ms
        self.time_scale = time_scale
        self.rate_cps = rate_cps
        self.dead_fraction = dead_fraction
        self.rng = np.random.default_rng(seed)
        self.bad_checksum_every = bad_checksum_every
        self.ignore_dwell_commands = ignore_dwell_commands
        self.seq = start_seq
        self.t_ms = 0
        self.sent: list[cp.CountRecord] = []
        self.bad: list[int] = []
        self.commands: list[bytes] = []
        self._rx = cp.LineSplitter()

    def _handle(self, line: bytes) -> None:
        self.commands.append(line)
        try:
            ms = cp.parse_dwell(line)
        except Exception:  # a bad command is ignored, like the real device does
            return
        if self.ignore_dwell_commands > 0:
            self.ignore_dwell_commands -= 1
            return
        self.dwell_ms = ms
        self.port.write(cp.format_ack_dwell(ms))

    def _run(self) -> None:
        next_emit = time.monotonic() + self.dwell_ms / 1000.0 / self.time_scale
        while not self._stop.is_set():
            wait = max(0.0, min(0.01, next_emit - time.monotonic()))
            data = self.port.read(wait)
            for line in self._rx.feed(data):
                self._handle(line)
            if time.monotonic() >= next_emit:
                self._emit()
                next_emit += self.dwell_ms / 1000.0 / self.time_scale

    def _emit(self) -> None:
        dwell = self.dwell_ms
        self.t_ms += dwell
        if not self.port.driver_attached():
            return
        live = round(dwell * (1.0 - self.dead_fraction))
        counts = int(self.rng.poisson(self.rate_cps * live / 1000.0))
        line = cp.format_cnt(self.seq, self.t_ms, dwell, counts, live)
        rec = cp.CountRecord(self.seq, self.t_ms / 1000.0, dwell / 1000.0, counts, live / 1000.0)
        if self.bad_checksum_every and self.seq % self.bad_checksum_every == 0:
            star = line.rfind(b'*')
            wrong = (int(line[star + 1 : star + 3], 16) ^ 0x5A) & 0xFF
            line = line[: star + 1] + f'{wrong:02X}'.encode() + b'\r\n'
            self.bad.append(self.seq)
        else:
            self.sent.append(rec)
        if self.port.driver_attached():
            self.port.write(line)
            self.seq += 1


class SlcanPtyDevice(_PtyEmulator):
    """A serial-line CAN adapter (slcan/Lawicel) on a pty, bridging to a send queue.

    Handles the host commands ``O`` (open), ``C`` (close), ``Sn`` (bitrate), ``V``, ``F`` and
    empty lines (answered with CR); while open, :meth:`send` writes ``tIIILDD..`` lines.
    """

    THREAD_NAME = 'slcan-device'

    def __init__(self, port: PtyPort | None = None) -> None:
        super().__init__()
        self.port = port or PtyPort()
        self.is_open = False
        self.bitrate_code = ''
        self._buf = bytearray()

    def _run(self) -> None:
        while not self._stop.is_set():
            data = self.port.read(0.02)
            self._buf.extend(data)
            while b'\r' in self._buf:
                cmd, _, rest = bytes(self._buf).partition(b'\r')
                self._buf = bytearray(rest)
                self._command(cmd.decode('ascii', 'replace'))

    def _command(self, cmd: str) -> None:
        if cmd == 'O' or cmd == 'L':
            self.is_open = True
        elif cmd == 'C':
            self.is_open = False
        elif cmd.startswith('S') or cmd.startswith('s'):
            self.bitrate_code = cmd
        elif cmd == 'V':
            self.port.write(b'V1013\r')
            return
        self.port.write(b'\r')

    def send(self, frame_id: int, data: bytes) -> bool:
        """Send one CAN frame as an slcan line; return False if the port is closed."""
        if not self.is_open:
            return False
        return self.port.write(f't{frame_id:03X}{len(data)}{data.hex().upper()}\r'.encode())


def default_can_signal(frame_id: int, seq: int) -> dict[str, tuple[float, ...]]:
    """SI values that are a known function of the frame counter (exactly representable)."""
    if frame_id == ACCEL_ID:
        return {
            'angular_acceleration': tuple(0.25 * ((seq * 3 + k) % 4001 - 2000) for k in range(3))
        }
    if frame_id == SPEED_ID:
        return {'speed': (1e-4 * (150_000 + seq % 1000),)}
    return {
        'normal_force': (0.5 * (200 + seq % 50),),
        'oil_temperature': (273.15 + 0.01 * (4000 + seq % 100),),
    }


class CanEmulator(_EmulatorThread):
    """Sends the three sensor frame types at their rates through ``send(frame_id, data)``.

    rates: frame_id -> frames per second (default: the codec's, from the DBC); seq
    counters start at ``start_seq`` (u16 wrap).
    Ground truth: ``sent[frame_id]`` is the list of unwrapped frame counters sent.
    """

    THREAD_NAME = 'can-emulator'

    def __init__(
        self,
        codec: CanCodec,
        send: Callable[[int, bytes], object],
        rates: dict[int, float] | None = None,
        start_seq: int = 0,
        skip: set[tuple[int, int]] | None = None,
    ) -> None:
        super().__init__()
        self.codec = codec
        self.send = send
        self.rates = rates or {fid: spec.frame_rate for fid, spec in codec.specs.items()}
        self.next_seq = dict.fromkeys(self.rates, start_seq)
        self.sent: dict[int, list[int]] = {fid: [] for fid in self.rates}
        self.skip = skip or set()
        self._start_seq = start_seq

    def frame(self, frame_id: int, seq: int) -> bytes:
        """Return the encoded payload of frame ``frame_id`` with sequence number ``seq``."""
        return self.codec.encode(frame_id, seq, default_can_signal(frame_id, seq))

    def _run(self) -> None:
        t0 = time.monotonic()
        while not self._stop.is_set():
            elapsed = time.monotonic() - t0
            for fid, rate in self.rates.items():
                due = self._start_seq + math.floor(elapsed * rate)
                while self.next_seq[fid] < due:
                    seq = self.next_seq[fid]
                    self.next_seq[fid] += 1
                    if (fid, seq) in self.skip:
                        continue
                    try:
                        ok = self.send(fid, self.frame(fid, seq))
                    except TransportError:
                        ok = False
                    if ok is not False:
                        self.sent[fid].append(seq)
            self._stop.wait(0.002)
