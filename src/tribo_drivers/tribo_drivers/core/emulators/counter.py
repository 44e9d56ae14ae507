"""Radiation-counter emulator: ``$DWELL``/``$ACK`` handshake and one ``$CNT`` line per dwell."""

from __future__ import annotations

import time

import numpy as np

from tribo_drivers.core import counter_protocol as cp

from .pty import PtyPort, _PtyEmulator


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
