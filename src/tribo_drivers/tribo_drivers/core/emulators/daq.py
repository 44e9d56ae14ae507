"""DAQ emulator: frames in real time with injected faults and recorded ground truth."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from tribo_drivers.core.daq_protocol import FRAME_SIZE, encode_frames

from .pty import PtyPort, _PtyEmulator


def default_daq_signal(
    index: npt.NDArray[np.int64],
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Raw counts that are a known function of the sample index (tests check the values)."""
    torque = (index * 7919) % 2_000_001 - 1_000_000
    accel = (index * 104_729) % 200_001 - 100_000
    speed = 150_000 + (index % 1000)
    return torque, accel, speed


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
