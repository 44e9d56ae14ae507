"""Sample timestamps from the device sample index, anchored to host receive times.

A sample with device index n was taken at ``t = offset + n / fs`` on the host clock.  Every
read gives one observation ``o = t_receive - n_last / fs`` where n_last is the index of the
newest sample in the read; ``o`` exceeds the true offset by the transport latency (USB
packetisation, scheduling: always >= 0, often several ms, heavy-tailed).  The estimator tracks
the *minimum*-latency observation: the estimate drops at once to any smaller observation and
otherwise rises slowly (``drift`` s per s, covering a device clock slower than nominal).  This
removes the USB jitter from the stamps; the remaining error is the minimum latency (a constant
lag) plus the drift allowance.  If the observations stay far above the estimate for
``step_timeout`` seconds (host clock stepped forward, device restarted) the estimate is reset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from tribo_drivers.errors import TimestampError


@dataclass
class SampleClock:
    """Minimum-latency clock-offset tracker for one device stream.

    sample_rate: nominal device sample rate [Hz] (the unit of the indices);
    drift: upward leak of the estimate [s/s], > the device clock's rate error;
    step_threshold: an observation this far above the estimate [s] is suspicious;
    step_timeout: suspicious for this long [s] -> re-anchor on the observations.
    """

    sample_rate: float
    drift: float = 200e-6
    step_threshold: float = 0.25
    step_timeout: float = 2.0
    _offset: float | None = None
    _last_host: float = 0.0
    _suspect_since: float | None = None

    def __post_init__(self) -> None:
        """Refuse a sample rate [Hz], drift, step threshold [s] or step timeout [s] out of range."""
        if not (math.isfinite(self.sample_rate) and self.sample_rate > 0):
            raise TimestampError(f'sample_rate must be positive and finite, got {self.sample_rate}')
        if not (self.drift >= 0 and self.step_threshold > 0 and self.step_timeout > 0):
            raise TimestampError('drift must be >= 0, step_threshold and step_timeout > 0')

    @property
    def offset(self) -> float | None:
        """Current offset estimate [s]: host time of device index 0."""
        return self._offset

    def reset(self) -> None:
        """Forget the clock offset (the next observation starts a new fit)."""
        self._offset = None
        self._suspect_since = None

    def observe(self, host_time: float, last_index: int) -> None:
        """Feed a read received at ``host_time`` [s] whose newest sample has ``last_index``."""
        if not math.isfinite(host_time):
            raise TimestampError(f'host time must be finite, got {host_time}')
        obs = host_time - last_index / self.sample_rate
        if self._offset is None:
            self._offset = obs
            self._last_host = host_time
            return
        dt = max(host_time - self._last_host, 0.0)
        self._last_host = host_time
        leaked = self._offset + self.drift * dt
        if obs <= leaked:
            self._offset = obs
            self._suspect_since = None
            return
        self._offset = leaked
        if obs - leaked > self.step_threshold:
            if self._suspect_since is None:
                self._suspect_since = host_time
            elif host_time - self._suspect_since >= self.step_timeout:
                self._offset = obs
                self._suspect_since = None
        else:
            self._suspect_since = None

    def time_of(self, index: int) -> float:
        """Host time [s] of the sample with device index ``index``."""
        if self._offset is None:
            raise TimestampError('no observation yet: call observe() before time_of()')
        return self._offset + index / self.sample_rate
