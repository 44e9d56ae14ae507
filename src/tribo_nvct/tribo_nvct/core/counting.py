"""Detector counts to released activity (paper 3.2, Equ. 8; physics notes section 2).

Per dwell [t_start, t_end] the counter reports ``counts`` registered during the
``live_time`` (real time minus dead time). For a non-paralysable counter the
dead-time corrected (true) rate is exactly ``counts / live_time``. Then

    I_DET = counts/live_time - B                 net count rate        [1/s]
    A_det = k_DET * I_DET                         activity seen, at t   [Bq]
    A_ref = A_det * c_decay                       decay-corrected to the profile's reference date

with B the background rate (configured, or measured before the test) and
``c_decay = lambda*T / (exp(-lambda*t0) - exp(-lambda*t1))`` the exact
dwell-average of exp(+lambda*t) (t counted from the reference date).
The Poisson variance of the counts (and of a measured background) is carried
through every step; k_DET's calibration uncertainty is kept separate
(systematic, common to all dwells).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tribo_nvct.errors import (
    LiveTimeError,
    NegativeCountsError,
    NonMonotonicTimeError,
    NvctConfigError,
)

FloatArray = NDArray[np.float64]

#: Tolerance when comparing live time with real time and dwell boundaries [s].
TIME_TOL = 1e-6


@dataclass(frozen=True)
class Dwell:
    """Counts of one detector dwell.

    t_start, t_end: test time [s]; counts: registered counts [-];
    live_time: counter live time [s] (<= t_end - t_start).
    """

    t_start: float
    t_end: float
    counts: int
    live_time: float

    def __post_init__(self) -> None:
        """Refuse non-finite times [s], an end before the start or a live time [s] out of range."""
        for name in ('t_start', 't_end', 'live_time'):
            v = getattr(self, name)
            if not isinstance(v, int | float) or not math.isfinite(v):
                raise NonMonotonicTimeError(f'dwell {name} is not a finite number: {v!r}')
        c = self.counts
        if isinstance(c, float):
            if not math.isfinite(c) or c != int(c):
                raise NegativeCountsError(f'counts must be a non-negative integer, got {c!r}')
            object.__setattr__(self, 'counts', int(c))
        elif not isinstance(c, int | np.integer):
            raise NegativeCountsError(f'counts must be a non-negative integer, got {c!r}')
        if self.counts < 0:
            raise NegativeCountsError(
                f'negative counts {self.counts} in dwell {self.t_start:g}-{self.t_end:g} s'
            )
        real = self.t_end - self.t_start
        if real <= 0.0:
            raise NonMonotonicTimeError(
                f'dwell end {self.t_end:g} s is not after its start {self.t_start:g} s'
            )
        if not self.live_time > 0.0:
            raise LiveTimeError(f'live time must be > 0 s, got {self.live_time:g} s')
        if self.live_time > real + TIME_TOL:
            raise LiveTimeError(
                f'live time {self.live_time:g} s exceeds the dwell {self.t_start:g}-'
                f'{self.t_end:g} s ({real:g} s)'
            )

    @property
    def t_mid(self) -> float:
        """Dwell centre [s]."""
        return 0.5 * (self.t_start + self.t_end)

    @property
    def real_time(self) -> float:
        """Dwell real time [s]."""
        return self.t_end - self.t_start


def check_sequence(previous: Dwell | None, dwell: Dwell) -> bool:
    """Check dwell order; return True if there is a gap before ``dwell``.

    Raises :class:`NonMonotonicTimeError` if the dwell starts before the previous end.
    """
    if previous is None:
        return False
    if dwell.t_start < previous.t_end - TIME_TOL:
        raise NonMonotonicTimeError(
            f'dwell starting at {dwell.t_start:g} s overlaps or precedes the previous dwell '
            f'ending at {previous.t_end:g} s'
        )
    return dwell.t_start > previous.t_end + max(1.0, 0.01 * previous.real_time)


@dataclass(frozen=True)
class Background:
    """Background count rate [1/s] and its standard error [1/s]."""

    rate: float
    se: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a negative or non-finite background rate [counts/s] or standard error."""
        if not (math.isfinite(self.rate) and self.rate >= 0.0):
            raise NvctConfigError(f'background rate must be >= 0 counts/s, got {self.rate!r}')
        if not (math.isfinite(self.se) and self.se >= 0.0):
            raise NvctConfigError(f'background standard error must be >= 0, got {self.se!r}')

    @classmethod
    def measured(cls, counts: int, live_time: float) -> Background:
        """Background measured before the test: ``counts`` over ``live_time`` [s] (Poisson)."""
        if counts < 0:
            raise NegativeCountsError(f'negative background counts {counts}')
        if not live_time > 0.0:
            raise LiveTimeError(f'background live time must be > 0 s, got {live_time!r}')
        return cls(counts / live_time, math.sqrt(max(counts, 1)) / live_time)


def decay_factor(t_start: float, t_end: float, lam: float, offset_s: float) -> float:
    """Dwell-averaged decay correction exp(+lambda*t) back to the reference date [-].

    t_start, t_end: test time [s]; lam: decay constant [1/s]; offset_s: time from the
    profile's reference date to the test start [s]. Counts in the dwell integrate
    A_ref*exp(-lambda*t); dividing by the integral's mean gives A_ref exactly.
    """
    t0 = offset_s + t_start
    T = t_end - t_start
    x = lam * T
    if x < 1e-12:
        return math.exp(lam * (t0 + 0.5 * T))
    return x * math.exp(lam * t0) / (-math.expm1(-x))


@dataclass(frozen=True)
class ActivityEstimate:
    """Activity released into the oil, decay-corrected to the reference date.

    activity: A [Bq]; se: statistical (Poisson) standard error [Bq];
    net_rate: background-subtracted, dead-time-corrected count rate [1/s].
    """

    activity: float
    se: float
    net_rate: float


def counts_to_activity(
    dwell: Dwell, background: Background, k_det: float, lam: float, offset_s: float
) -> ActivityEstimate:
    """Convert the counts of one dwell to decay-corrected activity (see module docstring).

    k_det: detector coefficient [Bq per count/s]; lam: decay constant [1/s];
    offset_s: reference date to test start [s].
    Poisson: Var(counts) = counts (at least 1, so zero counts still carry an error).
    """
    rate = dwell.counts / dwell.live_time
    rate_var = max(dwell.counts, 1) / dwell.live_time**2
    net = rate - background.rate
    net_se = math.sqrt(rate_var + background.se**2)
    c = decay_factor(dwell.t_start, dwell.t_end, lam, offset_s)
    return ActivityEstimate(k_det * net * c, k_det * net_se * c, net)


def currie_detection_limit_counts(background_counts: float) -> float:
    """Currie (1968) detection limit L_D = 2.71 + 4.65*sqrt(B) [counts] (alpha = beta = 5 %).

    B: expected background counts in the counting interval (well known background:
    paired-blank form 2.71 + 4.65 sqrt(B)).
    """
    if background_counts < 0.0:
        raise NvctConfigError(f'background counts must be >= 0, got {background_counts!r}')
    return 2.71 + 4.65 * math.sqrt(background_counts)


def currie_critical_level_counts(background_counts: float) -> float:
    """Currie decision threshold L_C = 2.33*sqrt(B) [counts] (alpha = 5 %)."""
    return 2.33 * math.sqrt(max(background_counts, 0.0))
