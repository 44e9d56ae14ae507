"""Stick-phase detection and motion-type classification from measured rig signals.

Signals: torsion moment ``M_t = C1*phi1`` [N m], chamber acceleration ``a`` [rad/s^2],
shaft speed ``w2`` [rad/s], uniformly sampled.

Detection works in two stages:

1. Candidates: the slip speed estimate ``v = w2 - w1`` (``w1`` from the
   complementary filter of :mod:`.observer`) stays below a threshold.
2. Boundaries: while the discs stick, chamber and shaft move as one body, so
   Equ. 1 + Equ. 2 with ``w1 = w2 = w`` and the constant angle difference
   ``phi2 - phi1`` give the *stick residual*

       r = (I1 + I2)*a + (K1 + K2)*w2 + (C1 + C2)*M_t/C1 = K2*w0 + C2*phi0(t) - C2*(phi2 - phi1)

   which is a straight line in time for a constant drive speed (slope ``C2*w0``;
   a parabola is used on longer sticks to absorb a changing drive speed).
   The line is fitted on the inside of each candidate and the stick is grown or
   shrunk to the samples whose residual stays within ``n_sigma`` noise levels of
   the line. Sliding friction differs from the stick moment, so ``r`` leaves the
   line by a jump at the stick start and by a fast-growing ramp after breakaway;
   the breakaway instant is then found by fitting that ramp (hinge fit). Both ends
   come out to a fraction of a millisecond on 10 kHz data with realistic noise
   (see the tests).

Motion type per block: ``'stick-slip'`` (sticks found), ``'slip-slip'`` (the
torsion moment oscillates but slip never stops), ``'steady'``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tribo_estimation.core.model import RigParams
from tribo_estimation.core.observer import FrictionObserver
from tribo_estimation.errors import InvalidDataError, InvalidParameterError, TooShortError

MOTION_TYPES: tuple[str, ...] = ('stick-slip', 'slip-slip', 'steady')


@dataclass(frozen=True)
class StickPhase:
    """One stick phase: ``start``, ``end`` [s] and ``duration`` = end - start [s]."""

    start: float
    end: float

    @property
    def duration(self) -> float:
        return self.end - self.start


def _validate(*arrays: tuple[str, np.ndarray]) -> list[np.ndarray]:
    out = []
    n = None
    for name, x in arrays:
        a = np.asarray(x, dtype=float)
        if a.ndim != 1:
            raise InvalidDataError(f'{name} must be one-dimensional')
        if n is not None and a.size != n:
            raise InvalidDataError(f'{name} has {a.size} samples, expected {n}')
        n = a.size
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise InvalidDataError(f'{name}: non-finite value at sample {bad[0]}')
        out.append(a)
    return out


def stick_residual(
    rig: RigParams, torsion: np.ndarray, accel: np.ndarray, speed: np.ndarray
) -> np.ndarray:
    """Stick residual r = (I1+I2)*a + (K1+K2)*w + (C1+C2)*M_t/C1 [N m] (linear in t
    while sticking at constant drive speed; see the module docstring). ``speed`` is
    the measured shaft speed w2, equal to w1 = w while sticking."""
    return (
        (rig.I1 + rig.I2) * accel + (rig.K1 + rig.K2) * speed + (rig.C1 + rig.C2) * torsion / rig.C1
    )


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Inclusive (first, last) index pairs of the True runs of mask."""
    if mask.size == 0:
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def _noise_level(x: np.ndarray) -> float:
    """Robust white-noise std of x from its third difference (signal-free at 10 kHz)."""
    if x.size < 8:
        return 0.0
    d3 = np.diff(x, 3)
    return float(1.4826 * np.median(np.abs(d3 - np.median(d3))) / math.sqrt(20.0))


def detect_sticks(
    time: np.ndarray,
    torsion: np.ndarray,
    accel: np.ndarray,
    speed: np.ndarray,
    rig: RigParams,
    *,
    min_duration: float = 2e-3,
    speed_threshold: float | None = None,
    n_sigma: float = 4.0,
    corner_hz: float = 20.0,
) -> list[StickPhase]:
    """Stick phases (start, end [s]) of at least ``min_duration`` [s] in a record.

    ``speed_threshold`` [rad/s] for the candidate stage (default: 0.15 rad/s or
    6 noise levels of the slip-speed estimate, whichever is larger); ``n_sigma``
    width of the residual band; ``corner_hz`` of the chamber-speed filter. A stick
    still running at the end of the record ends at the last sample.
    """
    t, mt, ac, w2 = _validate(
        ('time', time),
        ('torsion_moment', torsion),
        ('angular_acceleration', accel),
        ('speed', speed),
    )
    if t.size < 16:
        raise TooShortError(f'stick detection needs >= 16 samples, got {t.size}')
    dts = np.diff(t)
    if np.any(dts <= 0.0):
        from tribo_estimation.errors import NonMonotonicTimeError

        i = int(np.flatnonzero(dts <= 0.0)[0]) + 1
        raise NonMonotonicTimeError(f'time does not increase at sample {i}')
    if min_duration < 0.0 or n_sigma <= 0.0:
        raise InvalidParameterError('min_duration must be >= 0 and n_sigma > 0')
    dt = float(np.median(dts))
    fs = 1.0 / dt
    obs = FrictionObserver(rig, fs, corner_hz=min(corner_hz, 0.2 * fs), initial_speed=w2[0])
    w1 = obs.chamber_speed(mt, ac)
    v = w2 - w1
    r = stick_residual(rig, mt, ac, w2)
    thr = speed_threshold
    if thr is None:
        thr = max(0.15, 6.0 * _noise_level(v))
    cand = _runs(np.abs(v) < thr)
    sig = _noise_level(r)
    if sig <= 0.0:
        sig = 1e-9 * (float(np.max(np.abs(r))) + 1.0)
    band = n_sigma * sig
    phases: list[StickPhase] = []
    last_end = -1
    for i0, i1 in cand:
        if i1 - i0 + 1 < 5 or i1 <= last_end:
            continue
        a0, a1 = i0 + 2, i1 - 2
        lo, hi = a0, a1
        ok = True
        for _ in range(4):
            if a1 - a0 + 1 < 3:
                ok = False
                break
            tt = t[a0 : a1 + 1]
            # line at constant drive speed; a parabola absorbs a changing drive speed
            # (start-up ramp, ripple) on longer sticks
            deg = 2 if tt.size >= 12 else 1
            coef = np.polyfit(tt - tt[0], r[a0 : a1 + 1], deg)
            dev = np.abs(r - np.polyval(coef, t - tt[0]))
            mid = (a0 + a1) // 2
            if dev[mid] > band:
                ok = False
                break
            lo = mid
            while lo > 0 and dev[lo - 1] <= band:
                lo -= 1
            hi = mid
            while hi < t.size - 1 and dev[hi + 1] <= band:
                hi += 1
            if (lo + 1, hi - 1) == (a0, a1):
                break
            a0, a1 = lo + 1, hi - 1
        if not ok:
            continue
        start = t[lo] - 0.5 * dt if lo > 0 else t[0]
        end = _breakaway(t, r, coef, tt[0], lo, hi, band, dt)
        last_end = hi
        if end - start >= min_duration:
            phases.append(StickPhase(float(start), float(end)))
    return phases


def _breakaway(
    t: np.ndarray,
    r: np.ndarray,
    coef: np.ndarray,
    t_ref: float,
    lo: int,
    hi: int,
    band: float,
    dt: float,
) -> float:
    """End of the stick: hinge fit of the residual's departure from the stick line.

    After breakaway the residual leaves the line as a ramp ``c*(t - t_e)`` (friction
    falls behind the growing stick moment); t_e is found by least squares over the
    last in-band samples and the first few outside the band.
    """
    n = t.size
    if hi >= n - 1:
        return float(t[-1])
    j1 = min(n - 1, hi + 4)
    j0 = max(lo, hi - 12)
    tt = t[j0 : j1 + 1]
    d = r[j0 : j1 + 1] - np.polyval(coef, tt - t_ref)
    best_te, best_cost = t[hi] + 0.5 * dt, math.inf
    for te in np.linspace(t[max(j0, hi - 4)], t[hi + 1], 41):
        x = np.maximum(tt - te, 0.0)
        xx = float(np.dot(x, x))
        if xx <= 0.0:
            continue
        c = float(np.dot(x, d)) / xx
        cost = float(np.sum((d - c * x) ** 2))
        if cost < best_cost:
            best_cost, best_te = cost, float(te)
    return best_te


def classify_motion(
    time: np.ndarray,
    torsion: np.ndarray,
    accel: np.ndarray,
    speed: np.ndarray,
    rig: RigParams,
    *,
    sticks: list[StickPhase] | None = None,
    min_duration: float = 0.0,
    rel_oscillation: float = 0.005,
) -> str:
    """Motion type of one block: ``'stick-slip'``, ``'slip-slip'`` or ``'steady'``.

    Stick-slip when any stick phase (>= ``min_duration`` s) is found; otherwise
    slip-slip when the detrended torsion moment oscillates by more than five noise
    levels and ``rel_oscillation`` of its mean; else steady.
    """
    t, mt, ac, w2 = _validate(
        ('time', time),
        ('torsion_moment', torsion),
        ('angular_acceleration', accel),
        ('speed', speed),
    )
    if sticks is None:
        sticks = detect_sticks(t, mt, ac, w2, rig, min_duration=min_duration)
    if any(s.duration >= min_duration for s in sticks):
        return 'stick-slip'
    coef = np.polyfit(t - t[0], mt, 1)
    resid = mt - np.polyval(coef, t - t[0])
    noise = _noise_level(mt)
    if np.std(resid) > max(5.0 * noise, rel_oscillation * abs(float(np.mean(mt)))):
        return 'slip-slip'
    return 'steady'
