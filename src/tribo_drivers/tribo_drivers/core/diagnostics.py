"""A small equivalent of ROS ``diagnostic_updater`` producing plain dataclasses.

Each driver keeps a :class:`DriverCounters` record; :func:`driver_status` turns it, together
with the measured rate, into a :class:`DiagnosticStatus` (the node converts that into
``diagnostic_msgs/DiagnosticStatus``) at its ``diagnostic_period``.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field, fields
from enum import IntEnum

from tribo_drivers.errors import ConfigError


class Level(IntEnum):
    """diagnostic_msgs/DiagnosticStatus levels."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


@dataclass(frozen=True)
class DiagnosticStatus:
    """One status entry: level, name, message, hardware id and key/value pairs (strings)."""

    level: Level
    name: str
    message: str
    hardware_id: str
    values: tuple[tuple[str, str], ...] = ()

    def value(self, key: str) -> str:
        """Return the value of ``key`` (KeyError if the status has none)."""
        for k, v in self.values:
            if k == key:
                return v
        raise KeyError(key)


@dataclass
class DriverCounters:
    """Cumulative counters of one driver (monotonic over the node's life).

    frames: accepted frames/lines/CAN frames; samples: published samples;
    crc_errors: frames with a bad CRC / lines with a bad checksum; frame_errors: malformed
    lines or frames; gaps: gap events; lost: samples (or dwells) lost in gaps; duplicates,
    outliers, restarts: see :class:`tribo_drivers.core.gaps.IndexTracker`;
    discarded_bytes: bytes outside any accepted frame; reconnects: successful reopens;
    disconnects: times the device went away; blocks: published blocks/messages.
    """

    frames: int = 0
    samples: int = 0
    blocks: int = 0
    crc_errors: int = 0
    frame_errors: int = 0
    gaps: int = 0
    lost: int = 0
    duplicates: int = 0
    outliers: int = 0
    restarts: int = 0
    discarded_bytes: int = 0
    reconnects: int = 0
    disconnects: int = 0
    connected: bool = False
    last_error: str = ''

    def as_pairs(self) -> tuple[tuple[str, str], ...]:
        """Return the counters as (name, value text) pairs for a DiagnosticStatus."""
        return tuple((f.name, str(getattr(self, f.name))) for f in fields(self))

    def copy(self) -> DriverCounters:
        """Return an independent snapshot of the counters."""
        return DriverCounters(**{f.name: getattr(self, f.name) for f in fields(self)})


@dataclass
class RateMeter:
    """Event rate [1/s] over a sliding window of ``window`` seconds."""

    window: float = 2.0
    _events: deque[tuple[float, int]] = field(default_factory=deque)

    def __post_init__(self) -> None:
        """Refuse a rate window that is not > 0 s."""
        if not self.window > 0:
            raise ConfigError(f'rate window must be > 0 s, got {self.window}')

    def add(self, now: float, count: int = 1) -> None:
        """Count ``count`` events at host time ``now`` [s]."""
        self._events.append((now, count))
        self._trim(now)

    def _trim(self, now: float) -> None:
        while self._events and self._events[0][0] < now - self.window:
            self._events.popleft()

    def rate(self, now: float) -> float:
        """Return the event rate [1/s] over the window ending at ``now`` [s]."""
        self._trim(now)
        return sum(c for _, c in self._events) / self.window


def driver_status(
    name: str,
    hardware_id: str,
    counters: DriverCounters,
    rate: float,
    expected_rate: float,
    previous: DriverCounters | None = None,
    rate_tolerance: float = 0.1,
) -> DiagnosticStatus:
    """Status of one driver: ERROR when disconnected, WARN on low rate or new errors/gaps.

    rate, expected_rate: measured and nominal frame/sample rate [1/s]; previous: counters at
    the last update (new CRC errors or gaps since then give WARN).
    """
    problems: list[str] = []
    level = Level.OK
    if not counters.connected:
        level = Level.ERROR
        problems.append(
            'disconnected' + (f': {counters.last_error}' if counters.last_error else '')
        )
    else:
        if expected_rate > 0 and rate < (1.0 - rate_tolerance) * expected_rate:
            level = Level.WARN
            problems.append(f'rate {rate:.1f}/s below nominal {expected_rate:.1f}/s')
        if previous is not None:
            new_crc = counters.crc_errors - previous.crc_errors
            new_gaps = counters.gaps - previous.gaps
            new_lost = counters.lost - previous.lost
            if new_crc > 0:
                level = max(level, Level.WARN)
                problems.append(f'{new_crc} new checksum errors')
            if new_gaps > 0:
                level = max(level, Level.WARN)
                problems.append(f'{new_gaps} new gaps ({new_lost} lost)')
    message = '; '.join(problems) if problems else 'ok'
    values = (
        ('rate', f'{rate:.3f}'),
        ('expected_rate', f'{expected_rate:.3f}'),
        *counters.as_pairs(),
    )
    return DiagnosticStatus(Level(level), name, message, hardware_id, values)
