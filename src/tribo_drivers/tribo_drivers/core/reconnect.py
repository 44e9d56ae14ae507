"""Exponential back-off for reconnecting to a device that disappeared.

After a failed open the next attempt waits ``initial * factor**k`` seconds (k = number of
failures since the last success), capped at ``maximum``; waits happen on a
:class:`threading.Event` so a shutdown interrupts them at once (no busy loop, no long hang).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from tribo_drivers.errors import ConfigError


@dataclass(frozen=True)
class Backoff:
    """Back-off schedule: initial delay [s], growth factor [-], maximum delay [s]."""

    initial: float = 0.1
    factor: float = 2.0
    maximum: float = 5.0

    def __post_init__(self) -> None:
        """Refuse a delay [s] that is not > 0 or a factor < 1."""
        if not (math.isfinite(self.initial) and self.initial > 0):
            raise ConfigError(f'back-off initial delay must be > 0 s, got {self.initial}')
        if not (math.isfinite(self.factor) and self.factor >= 1):
            raise ConfigError(f'back-off factor must be >= 1, got {self.factor}')
        if not (math.isfinite(self.maximum) and self.maximum >= self.initial):
            raise ConfigError(
                f'back-off maximum must be >= initial ({self.initial} s), got {self.maximum}'
            )

    def delay(self, failures: int) -> float:
        """Delay [s] before the next attempt after ``failures`` consecutive failures (>= 0)."""
        if failures <= 0:
            return 0.0
        exponent = min(failures - 1, 1000)
        return float(min(self.initial * self.factor**exponent, self.maximum))


@dataclass
class ReconnectState:
    """Book-keeping of the connection: failures in a row, reconnects, last error."""

    failures: int = 0
    connects: int = 0
    disconnects: int = 0
    last_error: str = ''

    @property
    def reconnects(self) -> int:
        """Successful opens after the first one [-]."""
        return max(self.connects - 1, 0)

    def failed(self, message: str) -> None:
        """Record a failed open with its message."""
        self.failures += 1
        self.last_error = message

    def connected(self) -> None:
        """Record a successful open (the back-off starts over)."""
        self.failures = 0
        self.connects += 1

    def lost(self, message: str) -> None:
        """Record the loss of an open device."""
        self.disconnects += 1
        self.last_error = message
