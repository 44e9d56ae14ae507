"""End-to-end fault scenario for the serial DAQ driver (used by the tests and bench_daq.py).

A :class:`~tribo_drivers.core.emulators.DaqEmulator` streams frames over a pseudo-terminal
with corrupted frames, garbage bursts and unplug/replug events; a
:class:`~tribo_drivers.core.streams.DaqStream` reads them like the node does.  The report
compares what was published against the emulator's ground truth.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from tribo_drivers.core.daq_protocol import DaqScaling
from tribo_drivers.core.emulators import DaqEmulator, PtyPort, default_daq_signal
from tribo_drivers.core.gaps import SampleBlock
from tribo_drivers.core.reconnect import Backoff
from tribo_drivers.core.streams import DaqStream
from tribo_drivers.core.transports import SerialTransport


@dataclass(frozen=True)
class FaultReport:
    """Accounting of one scenario (counts of samples unless noted)."""

    duration: float  # s
    sample_rate: float  # Hz
    sent_intact: int
    sent_uncertain: int  # intact, but sent while the driver's open could still flush them
    sent_damaged: int
    unsent: int
    delivered: int
    delivered_unique: int
    intact_missing: int  # intact frames never published
    recovered: int  # damaged frames published with their true content (a lost byte's twin)
    invented: int  # published indices that were never sent
    value_errors: int  # published values differing from the truth
    lost_counted: int  # samples in the gap counters
    span: int  # last - first published index + 1
    gaps: int
    crc_errors: int
    garbage_bursts: int
    unplugs: int
    reconnects: int
    disconnects: int
    blocks: int
    bridged_gaps: int  # blocks whose data would span a gap (must be 0)
    stamp_jitter_rms: float  # s, block stamps about a straight line in index

    @property
    def ok(self) -> bool:
        """Tell whether nothing intact was lost, invented or altered."""
        return (
            self.intact_missing == 0
            and self.invented == 0
            and self.value_errors == 0
            and self.delivered == self.delivered_unique
            and self.delivered + self.lost_counted == self.span
            and self.bridged_gaps == 0
        )

    def lines(self) -> list[str]:
        """Return the tally as ``name: value`` lines."""
        return [f'{k}: {v}' for k, v in self.__dict__.items()] + [f'ok: {self.ok}']


class _NotifyingSerialTransport(SerialTransport):
    """SerialTransport that tells the emulator's pty when its open has returned and what it read.

    The open flushes the input; frames sent from then on are counted as intact
    ground truth.  The byte count read lets the emulator's drain before an unplug wait
    until the driver really holds everything sent.
    """

    def __init__(self, port: PtyPort, baudrate: int) -> None:
        super().__init__(str(port.path), baudrate)
        self._pty = port
        port.require_open_notice = True

    def open(self) -> None:
        super().open()
        self._pty.notify_opened()

    def read(self, timeout: float) -> bytes:
        data = super().read(timeout)
        self._pty.note_driver_read(len(data))
        return data


def run_daq_fault_scenario(
    duration: float = 5.0,
    sample_rate: float = 10_000.0,
    corrupt_fraction: float = 0.01,
    drop_fraction: float = 0.0,
    garbage_bursts: int = 10,
    unplugs: int = 1,
    down_time: float = 0.3,
    seed: int = 1,
    start_index: int = (1 << 32) - 20_000,
) -> FaultReport:
    """Run the scenario in real time (``duration`` seconds) and return its accounting."""
    rng = np.random.default_rng(seed)
    scaling = DaqScaling(offset=(10.0, -5.0, 100.0), gain=(1e-5, 2e-3, 1e-4))
    emu = DaqEmulator(
        sample_rate,
        start_index=start_index,
        corrupt_fraction=corrupt_fraction,
        drop_fraction=drop_fraction,
        seed=seed,
    )
    stream = DaqStream(
        _NotifyingSerialTransport(emu.port, 2_000_000),
        scaling,
        sample_rate,
        backoff=Backoff(0.05, 2.0, 0.5),
    )
    blocks: list[SampleBlock] = []
    stop = threading.Event()

    def reader() -> None:
        while not stop.is_set():
            blocks.extend(stream.poll(0.02))

    events: list[tuple[float, str]] = [
        (float(t), 'garbage') for t in rng.uniform(0.1, duration - 0.2, garbage_bursts)
    ]
    events += [(duration * (k + 1) / (unplugs + 1), 'unplug') for k in range(unplugs)]
    events.sort()
    th = threading.Thread(target=reader, name='daq-reader', daemon=True)
    emu.start()
    th.start()
    t0 = time.monotonic()
    try:
        for t_ev, kind in events:
            time.sleep(max(0.0, t0 + t_ev - time.monotonic()))
            if kind == 'garbage':
                emu.inject_garbage(int(rng.integers(1, 200)), fake_syncs=int(rng.integers(0, 4)))
            else:
                emu.unplug(drain=True)
                time.sleep(down_time)
                emu.replug()
        time.sleep(max(0.0, t0 + duration - time.monotonic()))
        emu.stop()
        emu.port.drain(5.0)
        time.sleep(0.1)
    finally:
        stop.set()
        th.join(5.0)
        blocks.extend(stream.close())
        emu.close()
    return _account(emu, stream, blocks, scaling, duration, sample_rate)


def _account(
    emu: DaqEmulator,
    stream: DaqStream,
    blocks: list[SampleBlock],
    scaling: DaqScaling,
    duration: float,
    sample_rate: float,
) -> FaultReport:
    torque = [b for b in blocks if b.channel == 'torsion_moment']
    accel = [b for b in blocks if b.channel == 'angular_acceleration']
    speed = [b for b in blocks if b.channel == 'speed']
    if torque:
        idx = np.concatenate(
            [np.arange(b.first_index, b.next_index, dtype=np.int64) for b in torque]
        )
    else:
        idx = np.zeros(0, dtype=np.int64)
    intact = emu.truth.intact_indices()
    uncertain = emu.truth.uncertain_indices()
    damaged = (
        np.concatenate(emu.truth.damaged) if emu.truth.damaged else np.zeros(0, dtype=np.int64)
    )
    uniq = np.unique(idx)
    value_errors = 0
    if idx.size:
        t_raw, a_raw, s_raw = default_daq_signal(idx)
        for blist, raw, ch in ((torque, t_raw, 0), (accel, a_raw, 1), (speed, s_raw, 2)):
            got = np.concatenate([b.data for b in blist])
            want = (raw.astype(np.float64) - scaling.offset[ch]) * scaling.gain[ch]
            # tolerance: float64 rounding of (raw - offset) * gain only
            value_errors += int(np.count_nonzero(~np.isclose(got, want, rtol=1e-12, atol=0.0)))
    bridged = 0
    for b in torque:
        if b.data.size > stream.batcher.block_size:
            bridged += 1
    stamps = np.array([b.stamp for b in torque])
    firsts = np.array([b.first_index for b in torque], dtype=np.float64)
    jitter = float('nan')
    if stamps.size > 2:
        coef = np.polyfit(firsts - firsts[0], stamps - stamps[0], 1)
        resid = stamps - stamps[0] - np.polyval(coef, firsts - firsts[0])
        jitter = float(np.sqrt(np.mean(resid**2)))
    c = stream.counters
    span = int(idx.max() - idx.min() + 1) if idx.size else 0
    return FaultReport(
        duration=duration,
        sample_rate=sample_rate,
        sent_intact=int(intact.size),
        sent_uncertain=int(uncertain.size),
        sent_damaged=emu.truth.count('damaged'),
        unsent=emu.truth.count('unsent'),
        delivered=int(idx.size),
        delivered_unique=int(uniq.size),
        intact_missing=int(np.setdiff1d(intact, uniq).size),
        recovered=int(np.intersect1d(uniq, damaged).size),
        invented=int(np.setdiff1d(uniq, np.concatenate([intact, uncertain, damaged])).size),
        value_errors=value_errors,
        lost_counted=c.lost,
        span=span,
        gaps=c.gaps,
        crc_errors=c.crc_errors,
        garbage_bursts=emu.truth.garbage_bursts,
        unplugs=emu.truth.unplugs,
        reconnects=c.reconnects,
        disconnects=c.disconnects,
        blocks=len(torque),
        bridged_gaps=bridged,
        stamp_jitter_rms=jitter,
    )
