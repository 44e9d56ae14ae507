"""The stick detector (:func:`find_sticks`) and the motion type of a block.

The criterion is described in :mod:`tribo_estimation.core.sticks`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from tribo_estimation.core.model import RigParams
from tribo_estimation.core.observer import FrictionObserver
from tribo_estimation.core.signal import (
    chamber_speed,
    local_slope,
    longest_run,
    noise_level,
    running_max,
    runs,
    span_medians,
)
from tribo_estimation.errors import (
    InvalidDataError,
    InvalidParameterError,
    NonMonotonicTimeError,
    TooShortError,
)

from .bounds import _stick_bounds
from .lag import chamber_speed_integral, estimate_torsion_lag, torsion_lag_compensated
from .report import MIN_STICK, StickPhase, StickReport

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


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


#: Filter time constants the forward pass of :func:`slip_speed` runs before its state is
#: used to start the backward pass (start-up error reduced by e^-8 = 3e-4).
_SETTLE_TAU = 8.0


#: Window of the local slope of the stick residual (candidate stage) [samples].
_SLOPE_WIN = 9

#: Longest time the slope window spans [s]: below 4.5 kHz the window shrinks to it,
#: down to 5 samples (a stick of a few ms at 2 kHz is 5-10 samples long, which a
#: 9-sample slope of 4.5 ms smears away).
_SLOPE_TIME = 2e-3


def _slope_window(fs: float) -> int:
    """Return the odd window of the residual's local slope [samples] (5 to 9)."""
    n = math.floor(_SLOPE_TIME * fs)
    n -= 1 - n % 2  # odd, at most the time span
    return max(5, min(_SLOPE_WIN, n))


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

#: Longest candidate run given one stick line; longer runs are cut into pieces of
#: this length and their phases joined (:func:`_pieces`) [s].
_PIECE = 0.05


def stick_residual(
    rig: RigParams, torsion: np.ndarray, accel: np.ndarray, speed: np.ndarray
) -> np.ndarray:
    """Return the stick residual r = (I1+I2)*a + (K1+K2)*w + (C1+C2)*M_t/C1 [N m].

    r is linear in t while sticking at constant drive speed (see the package
    docstring of :mod:`tribo_estimation.core.sticks`). ``speed`` is
    the chamber speed w1 = w2 while sticking, or any signal equal to it up to a
    constant within each stick (:func:`chamber_speed_integral`).
    """
    return (
        (rig.I1 + rig.I2) * accel + (rig.K1 + rig.K2) * speed + (rig.C1 + rig.C2) * torsion / rig.C1
    )


def drive_speed_level(speed: np.ndarray, fs: float, window: float = _DRIVE_WIN) -> np.ndarray:
    """Return the drive-speed level w0 [rad/s] per sample.

    Centred moving mean of the shaft speed over ``window`` [s] (edges: the window
    shrinks). Over whole stick-slip
    periods the shaft's mean speed is the drive's; a first-order sensor lag
    leaves the mean of a constant speed unchanged (it delays ramps by its time
    constant).
    """
    n = speed.size
    h = max(1, min(n // 2, round(0.5 * window * fs)))
    c = np.concatenate(([0.0], np.cumsum(speed)))
    i = np.arange(n)
    lo = np.maximum(0, i - h)
    hi = np.minimum(n, i + h + 1)
    return np.asarray((c[hi] - c[lo]) / (hi - lo))


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
    speed channel's lag and of a torsion gain error).
    """
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt
    w = chamber_speed_integral(ac, dt)
    if torsion_lag > 0.0:
        mt = torsion_lag_compensated(mt, w, dt, torsion_lag, rig.C1)
    r = stick_residual(rig, mt, ac, w)
    win = _slope_window(fs)
    slope = local_slope(r, dt, win)
    sig = noise_level(r, order=3)
    if not sig > 0.0:  # constant residual, or fewer than 8 samples
        sig = 1e-9 * (float(np.max(np.abs(r))) + 1.0)
    k = np.arange(-(win // 2), win // 2 + 1, dtype=float)
    sig_v = sig / (rig.C2 * dt * math.sqrt(float(np.sum(k * k))))
    thr = speed_threshold if speed_threshold is not None else max(_V_MIN, 6.0 * sig_v)
    w0 = drive_speed_level(w2, fs)
    half = max(1, round(0.5 * _DRIVE_WIN * fs))  # the level's half window [samples]
    # chamber speed w1 from torsion and acceleration only (complementary filter)
    w1 = -slip_speed(rig, mt, ac, np.zeros_like(w2), fs)
    w2_slope = local_slope(w2, dt, win)

    def passes(w0: FloatArray) -> tuple[list[StickPhase], FloatArray]:
        phases: list[StickPhase] = []
        cuts = np.zeros(0, np.int64)
        w0_channel = w0
        for _pass in range(2):
            # slip speed from the residual's slope: r' = C2*(w0 - v) - I2*v'' - K2*v' + K2*w0'
            v = w0 - slope / rig.C2
            c_lo, c_stop, cuts = _pieces(*runs(np.abs(v) < thr), max(8, round(_PIECE * fs)))
            c_hi = c_stop - 1  # last index of each run (inclusive)
            starts = np.empty(c_lo.size)
            ends = np.empty(c_lo.size)
            slopes = np.empty(c_lo.size)
            m = _stick_bounds(t, r, c_lo, c_hi, sig, n_sigma * sig, dt, starts, ends, slopes)
            # plausibility: r can stay parallel to a stick line for a few ms around a high
            # slip-speed peak (v ~ -(I2*v'' + K2*v')/C2); there the chamber has sprung far
            # back from the drive speed, unlike in a stick where w1 = w2 stays near w0
            u = np.abs(w0 - w1)
            h = max(1, round(_U_WIN * fs))
            u_loc = running_max(u, 2 * h + 1)
            kept: list[tuple[float, float, float, int, int]] = []
            for a, b, sl in zip(
                starts[:m].tolist(), ends[:m].tolist(), slopes[:m].tolist(), strict=True
            ):
                if b <= a:
                    continue
                i0 = int(np.searchsorted(t, a))
                i1 = max(i0 + 1, int(np.searchsorted(t, b)))
                line = sl / rig.C2
                if abs(line) < thr:
                    # a stick at (near) rest: its flat line also fits steady sliding
                    # beside it (a still chamber); it lasts only while the drive's level
                    # agrees with the line's speed (the level, a centred mean, departs
                    # half its window before the drive does)
                    lvl = w0_channel[i0:i1]
                    agree = np.abs(lvl - line) < np.maximum(thr, 0.5 * np.abs(lvl))
                    rest_lo, rest_hi = longest_run(agree)
                    if rest_hi - rest_lo < 2:
                        continue
                    lo = i0 + rest_lo - (half if rest_lo > 0 else 0)
                    hi = i0 + rest_hi + (half if rest_hi < i1 - i0 else 0)
                    i0, i1 = max(i0, lo), min(i1, hi)
                    a, b = max(a, float(t[i0]) - 0.5 * dt), min(b, float(t[i1 - 1]) + 0.5 * dt)
                kept.append((a, b, sl, i0, i1))
            if kept:
                i0s = np.asarray([k[3] for k in kept], dtype=np.int64)
                u_med = span_medians(u, i0s, [k[4] for k in kept])
                near = ~(u_med > np.maximum(_U_MIN, _U_FRAC * u_loc[i0s]))
                kept = [k for k, ok in zip(kept, near.tolist(), strict=True) if ok]
            mismatch = speed_mismatch(w2, w2_slope, w1, [(k[3], k[4]) for k in kept])
            phases = [
                StickPhase(float(a), float(b), sl / rig.C2 if i1 - i0 >= 6 else math.nan)
                for (a, b, sl, i0, i1), dw in zip(kept, mismatch, strict=True)
                if abs(dw) <= _W_MISMATCH
            ]
            lines = [ph for ph in phases if math.isfinite(ph.drive_speed)]
            if len(lines) < 2:
                break
            # between the lines their speeds are the drive's (exact through ramps and
            # steps); before the first and after the last the channel's level carries
            # the drive, corrected by the nearest line (its offset, gain and lag error):
            # a drive that speeds up after the last stick slides
            mids = np.asarray([0.5 * (ph.start + ph.end) for ph in lines])
            speeds = np.asarray([ph.drive_speed for ph in lines])
            w0_lines = np.interp(t, mids, speeds)
            for k in (0, -1):
                out = t < mids[0] if k == 0 else t > mids[-1]
                i = int(np.searchsorted(t, mids[k]).clip(0, t.size - 1))
                w0_lines[out] = w0_channel[out] + (speeds[k] - w0_channel[i])
            w0 = w0_lines
        # the pieces of a cut run are one stick (after the lines have given w0: each
        # piece's line speed is the drive's at its middle)
        return _merged(phases, 2.0 * dt, t[cuts]), w0

    phases, w0_used = passes(w0)
    if len(phases) < 2:
        # no stick-slip at the speed channel's level: a speed-channel offset beyond the
        # threshold hides every stick; the stick lines themselves show the drive speed.
        # Each clear level is tried, the one with the most sticks kept. A level near 0
        # is no drive (a still chamber in steady sliding also gives a flat residual), and
        # in the sticks of a true level the chamber moves with the drive (w1 = M_t'/C1,
        # Equ. 4, from the torsion alone, near the level): a slow-slip bump of the
        # histogram gives phases where it does not
        level = float(np.mean(w0))
        w1_torsion = chamber_speed(mt, fs, rig.C1)
        for c in _stick_line_offsets(slope / rig.C2 - w0, thr):
            if abs(level + c) < 2.0 * thr:
                continue
            shifted, w0_shifted = passes(w0 + c)
            # per phase, too: where the shifted level is near 0 but the channel's is not,
            # the flat residual is a still chamber in steady sliding, not a stopped drive
            shifted = [ph for ph in shifted if not _stopped_by_offset(t, ph, w0, w0_shifted, thr)]
            if len(shifted) < max(2, len(phases) + 1):
                continue
            dev = []
            for ph in shifted:
                i0 = int(np.searchsorted(t, ph.start))
                i1 = max(i0 + 1, int(np.searchsorted(t, ph.end)))
                dev.append(float(np.median(w1_torsion[i0:i1] - w0_shifted[i0:i1])))
            if float(np.median(np.abs(dev))) < max(_U_MIN, 0.5 * abs(level + c)):
                phases, w0_used = shifted, w0_shifted
    return phases, float(np.mean(w0_used))


def _pieces(lo: IntArray, stop: IntArray, most: int) -> tuple[IntArray, IntArray, IntArray]:
    """Split candidate runs longer than ``most`` samples into consecutive pieces.

    A long stick (at rest before a start-up, through a stop) is a line of the
    residual only up to the torsion channel's slow (coloured) noise and drift, which
    over a second leave the white-noise band; each piece gets its own line, and the
    pieces of one stick are joined again (:func:`_merged`). Returns the pieces'
    first and stop samples and the samples where a run was cut.
    """
    a: list[int] = []
    b: list[int] = []
    cuts: list[int] = []
    for i, j in zip(lo.tolist(), stop.tolist(), strict=True):
        while j - i > most:
            a.append(i)
            b.append(i + most)
            i += most
            cuts.append(i)
        a.append(i)
        b.append(j)
    return np.asarray(a, np.int64), np.asarray(b, np.int64), np.asarray(cuts, np.int64)


def _merged(phases: list[StickPhase], gap: float, cuts: FloatArray) -> list[StickPhase]:
    """Join the phases of the pieces of one cut candidate run (:func:`_pieces`).

    Two phases are one stick when they overlap or lie within ``gap`` [s] of each
    other across a cut (time [s] in ``cuts``); phases that merely touch elsewhere
    stay apart (a false stick at the slow end of a slip beside a true one). The
    joined phase's drive speed is the duration-weighted mean of its pieces'.
    """
    if cuts.size == 0:
        return phases
    out: list[StickPhase] = []
    for ph in sorted(phases, key=lambda p: p.start):
        across = out and bool(np.any((cuts > out[-1].start) & (cuts < ph.end)))
        if out and across and ph.start <= out[-1].end + gap:
            prev = out[-1]
            parts = [
                (q.drive_speed, q.duration) for q in (prev, ph) if math.isfinite(q.drive_speed)
            ]
            weight = sum(d for _, d in parts)
            speed = sum(w * d for w, d in parts) / weight if weight > 0.0 else math.nan
            out[-1] = StickPhase(prev.start, max(prev.end, ph.end), speed)
        else:
            out.append(ph)
    return out


def _stopped_by_offset(
    t: FloatArray, ph: StickPhase, w0: FloatArray, w0_shifted: FloatArray, thr: float
) -> bool:
    """Return whether a shifted level puts a moving drive at rest over a phase.

    A stick line of slope ~0 (Equ. 6 with w0 ~ 0) is also what steady sliding with a
    still chamber gives; it is a stick at rest only where the speed channel's own level
    is at rest too (within ``2*thr`` [rad/s]).
    """
    i0 = int(np.searchsorted(t, ph.start))
    i1 = max(i0 + 1, int(np.searchsorted(t, ph.end)))
    shifted = abs(float(np.mean(w0_shifted[i0:i1])))
    channel = abs(float(np.mean(w0[i0:i1])))
    return shifted < 2.0 * thr <= channel


def _stick_line_offsets(d: FloatArray, thr: float, most: int = 3) -> list[float]:
    """Return the speed-channel offsets the stick lines may show, clearest first [rad/s].

    ``d = r'/C2 - w0`` per sample: in a stick the residual's slope is ``C2*w0`` (Equ.
    6), so ``d`` is minus the channel's offset there, the same in every stick: a sharp
    peak of its histogram; in a slip ``d`` spreads over the slip speeds, though a slow
    slip can make a broad bump too. Every peak (of up to ``most``) that holds 3 % of the
    samples within +-``thr``/4 and stands 4 times above the density 2-4 ``thr`` away
    is a candidate; the caller keeps the one that gives the most sticks.

    Parameters
    ----------
    d : FloatArray
        Stick-line speed minus the channel's drive level per sample [rad/s].
    thr : float
        Slip-speed threshold of the candidate stage [rad/s].
    most : int
        Largest number of candidates.

    Returns
    -------
    list of float
        ``median(d)`` over each peak [rad/s] (to add to the level).
    """
    x = d[np.isfinite(d)]
    width = 0.25 * thr
    lim = 50.0 * thr
    x = x[np.abs(x) < lim]
    if x.size < 100:
        return []
    hist, edges = np.histogram(x, bins=np.arange(-lim, lim + width, width))
    out: list[float] = []
    for k in np.argsort(hist)[::-1][: 4 * most].tolist():
        if len(out) >= most or hist[k] == 0:
            break
        centre = 0.5 * (edges[k] + edges[k + 1])
        if any(abs(centre - c) < thr for c in out):
            continue
        dist = np.abs(x - centre)
        peak = x[dist <= width]
        ring = np.count_nonzero((dist >= 2.0 * thr) & (dist < 4.0 * thr))
        # densities per unit speed: the peak's over 2*width, the ring's over 4*thr
        if peak.size >= 0.03 * d.size and peak.size / (2.0 * width) >= ring / thr:
            out.append(float(np.median(peak)))
    return out


#: Largest speed-channel lag :func:`speed_mismatch` considers [s].
_MAX_SPEED_LAG = 0.02

#: A phase whose median ``|w2 - w1|`` (speed channel, lag inverted, against the chamber
#: speed) exceeds this [rad/s] is a slip, not a stick (:func:`speed_mismatch`).
_W_MISMATCH = 0.5


def speed_mismatch(
    w2: FloatArray,
    w2_slope: FloatArray,
    w1: FloatArray,
    spans: list[tuple[int, int]],
    *,
    guard: int | None = None,
    sensor: tuple[float, float] | None = None,
) -> list[float]:
    """Return the median shaft-chamber speed difference of each phase [rad/s] (signed).

    While the discs stick the shaft moves with the chamber, ``w2 = w1`` (Equ. 1, 2,
    4). The speed channel ``y`` shows ``w2`` through a first-order lag ``tau`` and an
    offset ``c(t)``: ``y + tau*y' = w2 + c(t)``; ``w1`` [rad/s] comes from torsion
    (and acceleration) alone. The median of ``y + tau*y' - c(t) - w1`` over a phase's
    interior is ~0 in a stick and the slip speed in a phase in which the discs still
    slip (the slow end of a slip: several rad/s).

    With ``sensor = (tau, offset)`` the speed sensor is known (constant offset). Without
    it, ``tau`` (clipped to [0, 20 ms]) and an offset drifting linearly over the record
    are fitted by least squares to the interiors of the phases (twice: the second time
    without the phases the first fit puts beyond :data:`_W_MISMATCH`), so the sensor's
    lag and offset do not matter; a gain error ``e`` adds ``e*(w1 - mean w1)``, within
    0.1 rad/s for 10 % through a 12 -> 30 rpm step. A speed channel that disagrees with
    the chamber speed in more than half of the phases does not show the shaft speed (a
    wrong unit, a fault): the check is then skipped (all 0).

    Parameters
    ----------
    w2 : FloatArray
        Speed channel y [rad/s].
    w2_slope : FloatArray
        Its local slope y' [rad/s^2] (:func:`tribo_estimation.core.signal.local_slope`).
    w1 : FloatArray
        Chamber speed [rad/s].
    spans : list of tuple of int
        First and stop sample of each phase.
    guard : int, optional
        Samples left out at each end of a phase; a phase whose interior has fewer than 3
        samples gives 0. Default: ``min(5, length//4)``, interiors of 2 or more samples.
    sensor : tuple of float, optional
        Known ``(tau [s], offset [rad/s])`` of the speed sensor.

    Returns
    -------
    list of float
        ``median(y + tau*y' - c - w1)`` per phase [rad/s] (0 for a phase too short to
        tell; all 0 when the sensor is fitted and fewer than two phases of 4 samples
        can be used or more than half of them disagree).
    """
    inner = []
    for i0, i1 in spans:
        g = min(5, (i1 - i0) // 4) if guard is None else guard
        inner.append((i0 + g, i1 - g))
    shortest = 2 if guard is None else 3

    lo = np.asarray([a for a, _ in inner], dtype=np.int64)
    hi = np.asarray([b for _, b in inner], dtype=np.int64)
    short = hi - lo < shortest

    def medians(e: FloatArray) -> list[float]:
        return np.where(short, 0.0, span_medians(e, lo, hi)).tolist()  # type: ignore[no-any-return]

    if sensor is not None:
        tau, off = sensor
        return medians(w2 + tau * w2_slope - off - w1)
    use = [k for k, (a, b) in enumerate(inner) if b - a >= 4]
    out = [0.0] * len(spans)
    if len(use) < 2:
        return out
    s = np.linspace(-1.0, 1.0, w2.size)  # record time, scaled
    for _ in range(2):
        idx = np.concatenate([np.arange(*inner[k]) for k in use])
        x = np.stack([np.ones(idx.size), s[idx], -w2_slope[idx]], axis=1)
        coef = np.linalg.lstsq(x, w2[idx] - w1[idx], rcond=None)[0]
        tau = min(max(float(coef[2]), 0.0), _MAX_SPEED_LAG)
        out = medians(w2 + tau * w2_slope - coef[0] - coef[1] * s - w1)
        good = [k for k in use if abs(out[k]) <= _W_MISMATCH]
        if 2 * len(good) < len(use):
            return [0.0] * len(spans)
        if len(good) < 2 or good == use:
            break
        use = good
    return out


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
    """Find the stick phases of a record (the project's stick detector).

    The criterion is in the docstring of :mod:`tribo_estimation.core.sticks`.

    ``time`` [s], ``torsion`` M_t [N m], ``accel`` chamber acceleration [rad/s^2],
    ``speed`` shaft speed [rad/s] (its level over ~50 ms, and its lag-inverted value
    against the chamber speed inside each phase, the lag fitted: a sensor lag of the
    speed channel does not matter). Phases of at least ``min_duration``
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
        fs = 1.0 / float(np.median(np.diff(t)))
        return estimate_torsion_lag(mt, ac, fs, rig.C1, rig.fastest_mode_hz)
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
    torsion_lag: float | None = None,
) -> list[StickPhase]:
    """Return the stick phases of at least ``min_duration`` [s] in a record.

    Phases (start, end [s]) as :func:`find_sticks` finds them. A stick still running at the start
    (end) of the record starts (ends) at its first (last) sample. Cost: a few
    vector passes over the record plus compiled work per candidate (about 1 ms
    per 1 s block at 10 kHz).
    """
    t, mt, ac, w2 = _checked(time, torsion, accel, speed, min_duration, n_sigma)
    tau = _resolve_lag(t, mt, ac, rig, torsion_lag)
    phases, _ = _detect_all(t, mt, ac, w2, rig, speed_threshold, n_sigma, tau)
    return [p for p in phases if p.duration >= min_duration]


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
