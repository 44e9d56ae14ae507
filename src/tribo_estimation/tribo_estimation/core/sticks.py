"""The project's one stick detector and motion-type classification (measured signals).

Signals: torsion moment ``M_t = C1*phi1`` [N m], chamber acceleration ``a`` [rad/s^2],
shaft speed ``w2`` [rad/s], uniformly sampled. The detector is insensitive to the
speed channel's dynamics (a tachometer lag of several ms): the speed channel only
sets the drive-speed level for the first pass.

Criterion. While the discs stick, chamber and shaft move as one body, so Equ. 1 +
Equ. 2 with ``w1 = w2 = w`` and the constant angle difference ``phi2 - phi1`` give
the *stick residual*

    r = (I1 + I2)*a + (K1 + K2)*w + (C1 + C2)*M_t/C1 = K2*w0 + C2*phi0(t) - C2*(phi2 - phi1)

which is a straight line in time with slope ``C2*w0`` (plus ``K2*w0'``). Here ``w``
is the integral of the measured acceleration (:func:`chamber_speed_integral`: the
chamber speed up to a constant, which only shifts each stick's line), never the
speed channel. In general ``r`` = stick line ``- C2*int(v) - I2*v' - K2*v`` with the
slip speed ``v = w2 - w1``.

1. Candidates: the slope of ``r`` over 9 samples gives the slip speed estimate
   ``v ~ w0 - r'/C2``; candidates are the runs with ``|v|`` below 0.4 rad/s (or six
   noise levels of the estimate). ``w0`` is, in a first pass, the shaft speed's
   50 ms moving mean (a lag does not change the mean of a constant speed), in a
   second pass the slopes of the stick lines found by the first (exact through
   start-up ramps and speed steps, free of any speed-channel lag and of a torsion
   gain error).
2. Boundaries: the line (a parabola on longer sticks when its curvature is
   significant) is fitted on the inside of each candidate and the stick grown or
   shrunk to the samples whose residual stays within ``n_sigma`` noise levels of it
   (one sample outside is noise, two in a row end the stick). Sliding friction
   differs from the stick moment, so ``r`` leaves the line by a jump at the stick
   start and by a fast-growing ramp after breakaway; the breakaway instant is found
   by fitting that ramp (hinge fit). Both ends come out to a fraction of a
   millisecond on 10 kHz data with realistic noise (see the tests).
3. Plausibility: around the peak of a fast slip, ``-(I2*v'' + K2*v')/C2`` can cancel
   ``v`` and keep ``r`` parallel to a stick line for a few ms; there the chamber has
   sprung far back from the drive (``|w0 - w1|`` large, with ``w1`` from the
   complementary filter of :mod:`.observer`, torsion and acceleration only), unlike in
   a stick. A phase whose median ``|w0 - w1|`` exceeds half the local maximum
   (+-40 ms; at least 1 rad/s) is dropped.

A first-order lag of the torsion amplifier (relative to the accelerometer) would
bend the stick lines; it is estimated from the record (:func:`estimate_torsion_lag`,
chamber kinematics ``M_t'' = C1*a``) or given, and compensated exactly
(:func:`torsion_lag_compensated`) before the residual is formed.

Phases of at least :data:`MIN_STICK` (1 ms, 10 samples at 10 kHz) are sticks,
shorter ones micro-sticks (:class:`StickReport`, counted apart). Cost: a few vector
passes over the record plus compiled work per candidate (a few ms per 1 s block).

Motion type per block: ``'stick-slip'`` (sticks of at least ``min_duration``),
``'slip-slip'`` (the torsion moment oscillates but slip never stops), ``'steady'``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.ndimage import maximum_filter1d

from tribo_estimation.core.model import RigParams
from tribo_estimation.core.observer import FrictionObserver
from tribo_estimation.core.signal import first_order_lag, noise_level, runs
from tribo_estimation.errors import (
    InvalidDataError,
    InvalidParameterError,
    NonMonotonicTimeError,
    TooShortError,
)

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


def slip_speed(
    rig: RigParams,
    torsion: np.ndarray,
    accel: np.ndarray,
    speed: np.ndarray,
    fs: float,
    corner_hz: float = 20.0,
) -> np.ndarray:
    """Slip speed estimate ``v = w2 - w1`` [rad/s] of a record without filter start-up.

    ``w1`` [rad/s] is the complementary filter of :class:`.observer.FrictionObserver`
    (Equ. 1 kinematics, corner ``corner_hz`` [Hz]). Its state at the first sample is
    unknown when a record (block) starts during sliding: started from the shaft speed
    the estimate would be off by the slip speed for several filter time constants
    (about 30 ms at 20 Hz), hiding the first sticks of the block. So the filter runs
    forwards from ``w2[0]`` until it has settled (:data:`_SETTLE_TAU` time constants)
    and the start of the record is then filtered *backwards* from that settled value.
    Time reversal keeps the filter's form (the acceleration is unchanged, the speed and
    the angle rate change sign), so the backward estimate has the forward one's noise
    and no start-up error; both agree where they meet.
    """
    n = torsion.shape[0]
    corner = min(corner_hz, 0.2 * fs)
    fwd = FrictionObserver(rig, fs, corner_hz=corner, initial_speed=float(speed[0]))
    w1 = fwd.chamber_speed(torsion, accel)
    k = min(n - 1, math.ceil(_SETTLE_TAU * fs / (2.0 * math.pi * corner)))
    if k > 0:
        back = FrictionObserver(rig, fs, corner_hz=corner, initial_speed=-float(w1[k]))
        w1[: k + 1] = -back.chamber_speed(torsion[k::-1], accel[k::-1])[::-1]
    return np.asarray(speed - w1)


#: Significance (standard errors) a stick parabola's curvature needs to be kept.
_CURVATURE_Z = 5.0

#: Filter time constants the forward pass of :func:`slip_speed` runs before its state is
#: used to start the backward pass (start-up error reduced by e^-8 = 3e-4).
_SETTLE_TAU = 8.0


#: Shortest stick phase counted as a stick [s] (10 samples at 10 kHz); shorter
#: detected phases are micro-sticks (counted apart).
MIN_STICK = 1e-3

#: Window of the local slope of the stick residual (candidate stage) [samples].
_SLOPE_WIN = 9

#: A phase whose median |w0 - w1| exceeds ``max(_U_MIN, _U_FRAC*max|w0 - w1|)`` [rad/s]
#: (maximum within +-``_U_WIN`` [s]) is a fast slip, not a stick (:func:`_detect_all`).
_U_MIN = 1.0
_U_FRAC = 0.5
_U_WIN = 0.04

#: Smallest slip-speed threshold of the candidate stage [rad/s] (covers the error of
#: the drive-speed level at ramp ends and steps).
_V_MIN = 0.4

#: Window of the drive-speed level taken from the speed channel [s].
_DRIVE_WIN = 0.05


def chamber_speed_integral(accel: np.ndarray, dt: float) -> np.ndarray:
    """Trapezoid integral of the chamber acceleration [rad/s] from 0 at the first
    sample: the chamber speed w1 up to a constant (and a slow drift from an
    accelerometer offset), free of any speed-channel dynamics."""
    w = np.empty_like(accel)
    w[0] = 0.0
    np.cumsum(0.5 * (accel[1:] + accel[:-1]) * dt, out=w[1:])
    return w


def stick_residual(
    rig: RigParams, torsion: np.ndarray, accel: np.ndarray, speed: np.ndarray
) -> np.ndarray:
    """Stick residual r = (I1+I2)*a + (K1+K2)*w + (C1+C2)*M_t/C1 [N m] (linear in t
    while sticking at constant drive speed; see the module docstring). ``speed`` is
    the chamber speed w1 = w2 while sticking, or any signal equal to it up to a
    constant within each stick (:func:`chamber_speed_integral`)."""
    return (
        (rig.I1 + rig.I2) * accel + (rig.K1 + rig.K2) * speed + (rig.C1 + rig.C2) * torsion / rig.C1
    )


#: Largest torsion-amplifier lag :func:`estimate_torsion_lag` considers [s], its grid
#: step [s] and the detrending window [s].
MAX_TORSION_LAG = 3e-3
_LAG_STEP = 1e-4
_LAG_WIN = 0.1


def estimate_torsion_lag(
    torsion: np.ndarray, accel: np.ndarray, fs: float, c1: float, max_lag: float = MAX_TORSION_LAG
) -> float:
    """First-order lag of the torsion channel relative to the accelerometer [s].

    Kinematics of the chamber (stick or slip): ``M_t = C1*phi1`` with
    ``phi1'' = a``, so the measured ``y = lag(M_t) = g*C1*(P - tau*lag(W))`` plus a
    slowly varying term, ``W``, ``P`` the single and double integrals of the
    acceleration and ``g`` a gain ratio. ``tau`` minimises the residual of that
    model over 0.1 s windows (each with its own ``g`` and quadratic trend, which
    absorb the integration constants, an accelerometer offset and gain errors);
    search on [0, ``max_lag``]: a 0.5 ms grid, halving steps down to 0.1 ms, then a
    parabola. A few ms per second of 10 kHz data; within about 2 % (+-20 us) of
    lags up to 2 ms at the noise of config/rig.yaml (the trapezoid integral of the
    acceleration's jumps at stick boundaries biases it slightly low). A lag of the
    accelerometer itself reads as a smaller (clipped at 0) torsion lag."""
    dt = 1.0 / fs
    w = chamber_speed_integral(accel, dt)
    phi = chamber_speed_integral(w, dt)
    n = torsion.size
    m = max(8, min(n, round(_LAG_WIN * fs)))
    k = n // m
    x0 = np.linspace(-1.0, 1.0, m)
    q, _ = np.linalg.qr(np.stack([np.ones(m), x0, x0 * x0], axis=1))

    def detrended(x: np.ndarray) -> np.ndarray:
        xx = x[: k * m].reshape(k, m)
        return np.asarray(xx - (xx @ q) @ q.T)

    y = detrended(torsion)
    syy = float(np.sum(y * y))

    def rss(tau: float) -> float:
        x = detrended(c1 * (phi - tau * first_order_lag(w, dt, tau)))
        sxx = np.sum(x * x, axis=1)
        sxy = np.sum(x * y, axis=1)
        ok = sxx > 0.0
        return syy - float(np.sum(sxy[ok] ** 2 / sxx[ok]))

    cache: dict[float, float] = {}

    def f(tau: float) -> float:
        tau = min(max(round(tau, 9), 0.0), max_lag)
        if tau not in cache:
            cache[tau] = rss(tau)
        return cache[tau]

    # coarse grid, then halving steps around the best point, then a parabola
    step = 5.0 * _LAG_STEP
    best = min(np.arange(0.0, max_lag + 0.5 * step, step).tolist(), key=f)
    while step > 1.01 * _LAG_STEP:
        step = max(_LAG_STEP, 0.5 * step)
        best = min((best - step, best, best + step), key=f)
    best = min(max(round(best, 9), 0.0), max_lag)
    a, b, c = f(best - _LAG_STEP), f(best), f(best + _LAG_STEP)
    den = a - 2.0 * b + c
    if 0.0 < best < max_lag and den > 0.0:
        return float(best + 0.5 * (a - c) / den * _LAG_STEP)
    return float(best)


def torsion_lag_compensated(
    torsion: np.ndarray, w: np.ndarray, dt: float, tau: float, c1: float
) -> np.ndarray:
    """Torsion moment [N m] before a first-order sensor lag of ``tau`` [s], up to a constant.

    With ``y = lag(M_t)``: ``M_t - y = tau*y' = tau*lag(M_t') = tau*C1*lag(w1)``
    (Equ. 1 kinematics, ``M_t' = C1*w1``), so ``M_t = y + tau*C1*lag(w)`` with ``w``
    the integrated acceleration (:func:`chamber_speed_integral`, the chamber speed
    up to a constant): exact, no differentiation of the noisy signal. The lag uses
    the first-order-hold discretisation (a zero-order hold's half-sample delay
    would move stick starts by ~0.5 ms at 10 rpm)."""
    return torsion + tau * c1 * first_order_lag(w, dt, tau)


def drive_speed_level(speed: np.ndarray, fs: float, window: float = _DRIVE_WIN) -> np.ndarray:
    """Drive-speed level w0 [rad/s] per sample: centred moving mean of the shaft
    speed over ``window`` [s] (edges: the window shrinks). Over whole stick-slip
    periods the shaft's mean speed is the drive's; a first-order sensor lag
    leaves the mean of a constant speed unchanged (it delays ramps by its time
    constant)."""
    n = speed.size
    h = max(1, min(n // 2, round(0.5 * window * fs)))
    c = np.concatenate(([0.0], np.cumsum(speed)))
    i = np.arange(n)
    lo = np.maximum(0, i - h)
    hi = np.minimum(n, i + h + 1)
    return np.asarray((c[hi] - c[lo]) / (hi - lo))


def local_slope(x: np.ndarray, dt: float, m: int = _SLOPE_WIN) -> np.ndarray:
    """Least-squares slope of ``x`` over a centred window of ``m`` (odd) samples
    [unit/s]; the ends use the first/last full window."""
    h = m // 2
    k = np.arange(-h, h + 1, dtype=float)
    kern = k / (np.sum(k * k) * dt)
    n = x.size
    if n < m:
        return np.full(n, float(np.polyfit(np.arange(n) * dt, x, 1)[0]))
    s = np.convolve(x, kern[::-1], mode='valid')
    return np.concatenate((np.full(h, s[0]), s, np.full(h, s[-1])))


@dataclass(frozen=True)
class StickReport:
    """Result of :func:`find_sticks` for one record or block.

    ``sticks``: phases of at least ``min_duration`` [s]; ``micro``: shorter detected
    phases (micro-sticks); ``motion``: ``'stick-slip'`` whenever ``sticks`` is not
    empty, else ``'slip-slip'`` or ``'steady'`` (:func:`classify_motion`);
    ``drive_speed``: mean drive-speed level [rad/s] used by the candidate stage;
    ``min_duration`` [s]; ``torsion_lag``: torsion-amplifier lag compensated [s]
    (given or estimated by :func:`estimate_torsion_lag`).
    """

    sticks: tuple[StickPhase, ...]
    micro: tuple[StickPhase, ...]
    motion: str
    drive_speed: float
    min_duration: float
    torsion_lag: float = 0.0

    @property
    def n_sticks(self) -> int:
        return len(self.sticks)

    @property
    def n_micro(self) -> int:
        return len(self.micro)

    def count_starting_after(self, t: float) -> int:
        """Sticks (>= min_duration) that start after ``t`` [s] (per-block counts:
        a stick running at a block start belongs to the block before)."""
        return sum(1 for p in self.sticks if p.start > t)


def _detect_all(
    t: np.ndarray,
    mt: np.ndarray,
    ac: np.ndarray,
    w2: np.ndarray,
    rig: RigParams,
    speed_threshold: float | None,
    n_sigma: float,
    torsion_lag: float = 0.0,
) -> tuple[list[StickPhase], float]:
    """Every detected phase (any duration) and the mean drive-speed level [rad/s].

    Two passes: the first takes the drive-speed level from the speed channel
    (:func:`drive_speed_level`); the second from the slopes of the stick lines the
    first pass found (slope = C2*w0: exact through ramps and steps, and free of the
    speed channel's lag and of a torsion gain error)."""
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt
    w = chamber_speed_integral(ac, dt)
    if torsion_lag > 0.0:
        mt = torsion_lag_compensated(mt, w, dt, torsion_lag, rig.C1)
    r = stick_residual(rig, mt, ac, w)
    slope = local_slope(r, dt)
    sig = noise_level(r, order=3)
    if not sig > 0.0:  # constant residual, or fewer than 8 samples
        sig = 1e-9 * (float(np.max(np.abs(r))) + 1.0)
    k = np.arange(-(_SLOPE_WIN // 2), _SLOPE_WIN // 2 + 1, dtype=float)
    sig_v = sig / (rig.C2 * dt * math.sqrt(float(np.sum(k * k))))
    thr = speed_threshold if speed_threshold is not None else max(_V_MIN, 6.0 * sig_v)
    w0 = drive_speed_level(w2, fs)
    phases: list[StickPhase] = []
    for _pass in range(2):
        # slip speed from the residual's slope: r' = C2*(w0 - v) - I2*v'' - K2*v' + K2*w0'
        v = w0 - slope / rig.C2
        c_lo, c_stop = runs(np.abs(v) < thr)
        c_hi = c_stop - 1  # last index of each run (inclusive)
        starts = np.empty(c_lo.size)
        ends = np.empty(c_lo.size)
        slopes = np.empty(c_lo.size)
        m = _stick_bounds(t, r, c_lo, c_hi, sig, n_sigma * sig, dt, starts, ends, slopes)
        # plausibility: r can stay parallel to a stick line for a few ms around a high
        # slip-speed peak (v ~ -(I2*v'' + K2*v')/C2); there the chamber has sprung far
        # back from the drive speed, unlike in a stick where w1 = w2 stays near w0
        u = np.abs(slip_speed(rig, mt, ac, w0, fs))
        h = max(1, round(_U_WIN * fs))
        u_loc = maximum_filter1d(u, 2 * h + 1, mode='nearest')
        phases = []
        mids: list[float] = []
        w_line: list[float] = []
        for a, b, sl in zip(
            starts[:m].tolist(), ends[:m].tolist(), slopes[:m].tolist(), strict=True
        ):
            if b <= a:
                continue
            i0 = int(np.searchsorted(t, a))
            i1 = max(i0 + 1, int(np.searchsorted(t, b)))
            if float(np.median(u[i0:i1])) > max(_U_MIN, _U_FRAC * float(u_loc[i0])):
                continue
            phases.append(StickPhase(float(a), float(b)))
            if i1 - i0 >= 6:
                mids.append(0.5 * (a + b))
                w_line.append(sl / rig.C2)
        if len(mids) < 2:
            break
        w0 = np.interp(t, np.asarray(mids), np.asarray(w_line))
    return phases, float(np.mean(w0))


def _checked(
    time: np.ndarray,
    torsion: np.ndarray,
    accel: np.ndarray,
    speed: np.ndarray,
    min_duration: float,
    n_sigma: float,
) -> list[np.ndarray]:
    arrs = _validate(
        ('time', time),
        ('torsion_moment', torsion),
        ('angular_acceleration', accel),
        ('speed', speed),
    )
    t = arrs[0]
    if t.size < 16:
        raise TooShortError(f'stick detection needs >= 16 samples, got {t.size}')
    dts = np.diff(t)
    if np.any(dts <= 0.0):
        i = int(np.flatnonzero(dts <= 0.0)[0]) + 1
        raise NonMonotonicTimeError(f'time does not increase at sample {i}')
    if not (min_duration >= 0.0 and n_sigma > 0.0):
        raise InvalidParameterError('min_duration must be >= 0 and n_sigma > 0')
    return arrs


def find_sticks(
    time: np.ndarray,
    torsion: np.ndarray,
    accel: np.ndarray,
    speed: np.ndarray,
    rig: RigParams,
    *,
    min_duration: float = MIN_STICK,
    speed_threshold: float | None = None,
    n_sigma: float = 4.0,
    torsion_lag: float | None = None,
) -> StickReport:
    """The project's stick detector (criterion in the module docstring).

    ``time`` [s], ``torsion`` M_t [N m], ``accel`` chamber acceleration [rad/s^2],
    ``speed`` shaft speed [rad/s] (only its level over ~50 ms is used, so a sensor
    lag of the speed channel does not matter). Phases of at least ``min_duration``
    [s] are sticks, shorter ones micro-sticks. ``speed_threshold`` [rad/s] of the
    candidate stage (default: 0.15 rad/s or 5 noise levels of the slip-speed
    estimate); ``n_sigma`` width of the residual band; ``torsion_lag`` [s] the
    first-order lag of the torsion amplifier relative to the accelerometer,
    compensated exactly (:func:`torsion_lag_compensated`; an uncompensated lag of
    1 ms loses most sticks); ``None`` (default) estimates it from the record
    (:func:`estimate_torsion_lag`), 0 switches the compensation off.
    """
    t, mt, ac, w2 = _checked(time, torsion, accel, speed, min_duration, n_sigma)
    tau = _resolve_lag(t, mt, ac, rig, torsion_lag)
    phases, w0 = _detect_all(t, mt, ac, w2, rig, speed_threshold, n_sigma, tau)
    sticks = tuple(p for p in phases if p.duration >= min_duration)
    micro = tuple(p for p in phases if p.duration < min_duration)
    motion = classify_motion(t, mt, ac, w2, rig, sticks=list(sticks), min_duration=min_duration)
    return StickReport(sticks, micro, motion, w0, min_duration, tau)


def _resolve_lag(
    t: np.ndarray, mt: np.ndarray, ac: np.ndarray, rig: RigParams, torsion_lag: float | None
) -> float:
    if torsion_lag is None:
        return estimate_torsion_lag(mt, ac, 1.0 / float(np.median(np.diff(t))), rig.C1)
    if not (math.isfinite(torsion_lag) and torsion_lag >= 0.0):
        raise InvalidParameterError(f'torsion_lag must be >= 0 s, got {torsion_lag!r}')
    return torsion_lag


def detect_sticks(
    time: np.ndarray,
    torsion: np.ndarray,
    accel: np.ndarray,
    speed: np.ndarray,
    rig: RigParams,
    *,
    min_duration: float = MIN_STICK,
    speed_threshold: float | None = None,
    n_sigma: float = 4.0,
    corner_hz: float = 20.0,
    torsion_lag: float | None = None,
) -> list[StickPhase]:
    """Stick phases (start, end [s]) of at least ``min_duration`` [s] in a record
    (:func:`find_sticks`; ``corner_hz`` is accepted for compatibility and unused).
    A stick still running at the start (end) of the record starts (ends) at its
    first (last) sample. Cost: a few vector passes over the record plus compiled
    work per candidate (about 1 ms per 1 s block at 10 kHz)."""
    del corner_hz
    t, mt, ac, w2 = _checked(time, torsion, accel, speed, min_duration, n_sigma)
    tau = _resolve_lag(t, mt, ac, rig, torsion_lag)
    phases, _ = _detect_all(t, mt, ac, w2, rig, speed_threshold, n_sigma, tau)
    return [p for p in phases if p.duration >= min_duration]


@njit(cache=True, nogil=True)
def _fit_poly(t: np.ndarray, r: np.ndarray, a0: int, a1: int, deg: int, poly: np.ndarray) -> float:
    """Least-squares polynomial (degree 1 or 2) through ``r[a0..a1]`` over ``t``.

    Stored as ``poly = [tc, h, c0, c1, c2]``: ``p(t) = c0 + c1*x + c2*x^2`` with the
    centred, scaled ``x = (t - tc)/h`` (well conditioned normal equations). Returns
    var(c2)/sigma^2 for white noise of std sigma on r (0 for a line)."""
    tc = 0.5 * (t[a0] + t[a1])
    h = 0.5 * (t[a1] - t[a0])
    if h <= 0.0:
        h = 1.0
    s0 = s1 = s2 = s3 = s4 = 0.0
    q0 = q1 = q2 = 0.0
    for i in range(a0, a1 + 1):
        x = (t[i] - tc) / h
        x2 = x * x
        y = r[i]
        s0 += 1.0
        s1 += x
        s2 += x2
        s3 += x2 * x
        s4 += x2 * x2
        q0 += y
        q1 += y * x
        q2 += y * x2
    poly[0] = tc
    poly[1] = h
    if deg == 1:
        det = s0 * s2 - s1 * s1
        poly[2] = (q0 * s2 - q1 * s1) / det
        poly[3] = (s0 * q1 - s1 * q0) / det
        poly[4] = 0.0
        return 0.0
    # 3x3 symmetric system [[s0 s1 s2] [s1 s2 s3] [s2 s3 s4]] c = q by Cramer's rule
    m00 = s2 * s4 - s3 * s3
    m01 = s1 * s4 - s3 * s2
    m02 = s1 * s3 - s2 * s2
    det = s0 * m00 - s1 * m01 + s2 * m02
    poly[2] = (q0 * m00 - s1 * (q1 * s4 - s3 * q2) + s2 * (q1 * s3 - s2 * q2)) / det
    poly[3] = (s0 * (q1 * s4 - s3 * q2) - q0 * m01 + s2 * (s1 * q2 - q1 * s2)) / det
    poly[4] = (s0 * (s2 * q2 - q1 * s3) - s1 * (s1 * q2 - q1 * s2) + q0 * m02) / det
    return (s0 * s2 - s1 * s1) / det


@njit(cache=True, nogil=True, inline='always')
def _poly_at(poly: np.ndarray, t: float) -> float:
    x = (t - poly[0]) / poly[1]
    return poly[2] + x * (poly[3] + x * poly[4])


@njit(cache=True, nogil=True, inline='always')
def _in_band(t: np.ndarray, r: np.ndarray, poly: np.ndarray, i: int, band: float) -> bool:
    return abs(r[i] - _poly_at(poly, t[i])) <= band


@njit(cache=True, nogil=True)
def _stick_bounds(
    t: np.ndarray,
    r: np.ndarray,
    c_lo: np.ndarray,
    c_hi: np.ndarray,
    sig: float,
    band: float,
    dt: float,
    starts: np.ndarray,
    ends: np.ndarray,
    slopes: np.ndarray,
) -> int:
    """Boundary stage of :func:`detect_sticks` for the candidate runs ``[c_lo, c_hi]``.

    Per candidate: fit the stick line (a parabola from 12 samples on when its
    curvature is significant against the noise level ``sig`` [N m] of ``r``) to its
    inside, grow/shrink it to the samples within ``band`` [N m] of the line (up to
    four refits), start half a sample before the first in-band sample, end by
    :func:`_breakaway`. Writes ``starts``/``ends`` [s] and the stick line's slope
    at its middle ``slopes`` [N m/s]; returns how many."""
    n = t.shape[0]
    poly = np.zeros(5)
    m = 0
    last_end = -1
    for k in range(c_lo.shape[0]):
        i0 = c_lo[k]
        i1 = c_hi[k]
        if i1 - i0 + 1 < 2 or i1 <= last_end:
            continue
        # first fit on the inside: the candidate run (from the windowed slope) falls
        # short of the stick start (the jump of r there spreads over the window) but
        # overshoots the breakaway by a few samples (v grows smoothly from 0); a short
        # run (a stick of about one window) is centred on its stick: widen it
        if i1 - i0 + 1 < 6:
            a0 = max(0, i0 - 2)
            a1 = min(n - 1, i1)
        else:
            a0 = i0 + 1
            a1 = i1 - min(3, max(0, i1 - i0 - 3))
        lo = a0
        hi = a1
        ok = True
        for _ in range(4):
            if a1 - a0 + 1 < 3:
                ok = False
                break
            # line at constant drive speed; a parabola absorbs a changing drive speed
            # (start-up ramp, ripple) on longer sticks, where its curvature stands out
            # of the noise (an insignificant curvature only bends the extrapolation
            # to the stick's ends)
            var_c2 = _fit_poly(t, r, a0, a1, 2, poly) if a1 - a0 + 1 >= 12 else -1.0
            if var_c2 < 0.0 or abs(poly[4]) < _CURVATURE_Z * sig * math.sqrt(var_c2):
                _fit_poly(t, r, a0, a1, 1, poly)
            # grow from an in-band sample near the middle; one sample out of the band
            # with its next neighbour back in is noise (a 4-sigma sample turns up
            # every few hundred samples), two in a row end the stick
            mid = (a0 + a1) // 2
            if not _in_band(t, r, poly, mid, band):
                if _in_band(t, r, poly, mid + 1, band):
                    mid += 1
                elif _in_band(t, r, poly, mid - 1, band):
                    mid -= 1
                else:
                    ok = False
                    break
            lo = mid
            while lo > 0 and (
                _in_band(t, r, poly, lo - 1, band)
                or (lo > 1 and _in_band(t, r, poly, lo - 2, band))
            ):
                lo -= 1
            hi = mid
            while hi < n - 1 and (
                _in_band(t, r, poly, hi + 1, band)
                or (hi < n - 2 and _in_band(t, r, poly, hi + 2, band))
            ):
                hi += 1
            if lo + 1 == a0 and hi - 1 == a1:
                break
            a0 = lo + 1
            a1 = hi - 1
        if not ok:
            continue
        starts[m] = t[lo] - 0.5 * dt if lo > 0 else t[0]
        ends[m] = _breakaway(t, r, poly, lo, hi, dt)
        slopes[m] = poly[3] / poly[1]
        last_end = hi
        m += 1
    return m


@njit(cache=True, nogil=True)
def _breakaway(
    t: np.ndarray, r: np.ndarray, poly: np.ndarray, lo: int, hi: int, dt: float
) -> float:
    """End of the stick [s]: hinge fit of the residual's departure from the stick line.

    After breakaway the residual leaves the line as a ramp ``c*(t - t_e)`` (friction
    falls behind the growing stick moment); t_e is found by least squares (41 trial
    instants from 4 samples before the last in-band sample ``hi`` to the first one
    outside) over the last in-band samples and the first few outside the band.
    """
    n = t.shape[0]
    if hi >= n - 1:
        return t[n - 1]
    j1 = min(n - 1, hi + 4)
    j0 = max(lo, hi - 12)
    m = j1 - j0 + 1
    d = np.empty(m)
    for j in range(m):
        d[j] = r[j0 + j] - _poly_at(poly, t[j0 + j])
    best_te = t[hi] + 0.5 * dt
    best_cost = np.inf
    ta = t[max(j0, hi - 4)]
    tb = t[hi + 1]
    step = (tb - ta) / 40.0
    for i in range(41):
        te = tb if i == 40 else ta + i * step
        xx = 0.0
        xd = 0.0
        for j in range(m):
            x = max(t[j0 + j] - te, 0.0)
            xx += x * x
            xd += x * d[j]
        if xx <= 0.0:
            continue
        c = xd / xx
        cost = 0.0
        for j in range(m):
            e = d[j] - c * max(t[j0 + j] - te, 0.0)
            cost += e * e
        if cost < best_cost:
            best_cost = cost
            best_te = te
    return best_te


def classify_motion(
    time: np.ndarray,
    torsion: np.ndarray,
    accel: np.ndarray,
    speed: np.ndarray,
    rig: RigParams,
    *,
    sticks: list[StickPhase] | None = None,
    min_duration: float = MIN_STICK,
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
    noise = noise_level(mt, order=3)
    noise = noise if noise > 0.0 else 0.0  # NaN below 8 samples
    if np.std(resid) > max(5.0 * noise, rel_oscillation * abs(float(np.mean(mt)))):
        return 'slip-slip'
    return 'steady'
