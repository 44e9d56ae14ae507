"""Residual statistics of the discrepancy workflow: where the gap concentrates.

Pure array functions (no model, no I/O) so they can be tested on synthetic
arrays. Units: time in s, residuals in the unit of their channel (the torsion
moment residual in N m), slip speed in rad/s, angles in rad, frequencies in Hz.

The motion phases follow the paper's friction model (Equ. 3-8, hysteresis rule
of section 2.5): *stick* (slip speed v = 0), *slip accelerating* (|v| before
its maximum within the sliding phase) and *slip decelerating* (after it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import signal

from tribo_estimation.core.signal import noise_level, runs
from tribo_estimation.errors import InvalidDataError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

#: Phase codes returned by :func:`phase_labels`.
STICK = 0
SLIP_ACCEL = 1
SLIP_DECEL = 2
PHASE_NAMES: tuple[str, str, str] = ('stick', 'slip_accelerating', 'slip_decelerating')


def phase_labels(slip_speed: FloatArray, stick: BoolArray) -> IntArray:
    """Label every sample stick (0), slip accelerating (1) or slip decelerating (2).

    Within one sliding phase (a run of ``stick == False``) the samples up to and
    including the maximum of |v| are 'accelerating', the rest 'decelerating'
    (the paper's hysteresis rule, section 2.5). ``slip_speed`` in rad/s.
    """
    v = np.abs(np.asarray(slip_speed, dtype=np.float64))
    st = np.asarray(stick, dtype=bool)
    if v.shape != st.shape:
        raise InvalidDataError(f'slip_speed {v.shape} and stick {st.shape} differ in shape')
    labels = np.zeros(v.size, dtype=np.int64)
    starts, stops = runs(~st)
    for a, b in zip(starts, stops, strict=True):
        k = a + int(np.argmax(v[a:b]))
        labels[a : k + 1] = SLIP_ACCEL
        labels[k + 1 : b] = SLIP_DECEL
    return labels


def preceding_stick_duration(stick: BoolArray, fs: float) -> FloatArray:
    """Duration (s) of the stick phase preceding each sample's sliding phase.

    NaN during sticking and in a sliding phase not preceded by a complete stick
    phase (start of the record). ``fs`` in Hz.
    """
    st = np.asarray(stick, dtype=bool)
    out = np.full(st.size, np.nan)
    s_starts, s_stops = runs(st)
    slip_starts, slip_stops = runs(~st)
    for a, b in zip(slip_starts, slip_stops, strict=True):
        j = np.searchsorted(s_stops, a, side='right') - 1
        if j >= 0 and s_stops[j] == a and s_starts[j] > 0:
            out[a:b] = (s_stops[j] - s_starts[j]) / fs
    return out


def stick_durations(stick: BoolArray, fs: float) -> FloatArray:
    """Durations (s) of the complete stick phases (not touching the record ends)."""
    st = np.asarray(stick, dtype=bool)
    a, b = runs(st)
    keep = (a > 0) & (b < st.size)
    return ((b[keep] - a[keep]) / fs).astype(np.float64)


def time_since_breakaway(stick: BoolArray, fs: float) -> FloatArray:
    """Signed time (s) to the nearest breakaway (end of a stick phase).

    Negative before the breakaway, positive after; NaN if the record has none.
    """
    st = np.asarray(stick, dtype=bool)
    _, stops = runs(st)
    breaks = stops[(stops > 0) & (stops < st.size)]
    if breaks.size == 0:
        return np.full(st.size, np.nan)
    idx = np.arange(st.size)
    pos = np.searchsorted(breaks, idx)
    before = breaks[np.clip(pos - 1, 0, breaks.size - 1)]
    after = breaks[np.clip(pos, 0, breaks.size - 1)]
    d_before = idx - before
    d_after = idx - after
    use_before = np.abs(d_before) <= np.abs(d_after)
    return np.where(use_before, d_before, d_after).astype(np.float64) / fs


def noise_floor(residual: FloatArray) -> float:
    """Robust white-noise level (same unit as ``residual``) from second differences.

    For white noise of standard deviation s the second difference has standard
    deviation s*sqrt(6); the median absolute deviation makes the estimate
    insensitive to the few sharp features (breakaways) of a model mismatch.
    """
    r = np.asarray(residual, dtype=np.float64)
    if r.size < 8:
        return float(np.std(r))
    return noise_level(r)


def rms(x: FloatArray) -> float:
    """Root mean square of the finite values of ``x`` (NaN if none)."""
    a = np.asarray(x, dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(np.sqrt(np.mean(a * a))) if a.size else float('nan')


@dataclass(frozen=True)
class BinnedResidual:
    """Residual statistics in bins of a localising variable.

    ``centres`` in the variable's ``unit``; ``mean`` and ``rms`` in the unit of
    the residual; ``count`` samples per bin.
    """

    variable: str
    unit: str
    centres: tuple[float, ...]
    mean: tuple[float, ...]
    rms: tuple[float, ...]
    count: tuple[int, ...]

    def as_dict(self) -> dict[str, object]:
        """JSON-ready form."""
        return {
            'variable': self.variable,
            'unit': self.unit,
            'centres': list(self.centres),
            'mean': list(self.mean),
            'rms': list(self.rms),
            'count': list(self.count),
        }


def binned(
    variable: FloatArray,
    residual: FloatArray,
    *,
    name: str,
    unit: str,
    bins: int | FloatArray = 12,
    min_count: int = 20,
) -> BinnedResidual:
    """Mean and rms of ``residual`` in bins of ``variable`` (NaN samples skipped).

    ``bins`` is a number of equal-population bins or explicit edges. Bins with
    fewer than ``min_count`` samples are dropped.
    """
    x = np.asarray(variable, dtype=np.float64)
    r = np.asarray(residual, dtype=np.float64)
    ok = np.isfinite(x) & np.isfinite(r)
    x, r = x[ok], r[ok]
    if x.size == 0:
        return BinnedResidual(name, unit, (), (), (), ())
    if isinstance(bins, int):
        edges = np.unique(np.quantile(x, np.linspace(0.0, 1.0, bins + 1)))
    else:
        edges = np.asarray(bins, dtype=np.float64)
    if edges.size < 2:
        edges = np.array([x.min(), x.max() + 1e-12])
    k = np.clip(np.searchsorted(edges, x, side='right') - 1, 0, edges.size - 2)
    centres, means, rmss, counts = [], [], [], []
    for i in range(edges.size - 1):
        sel = r[k == i]
        if sel.size < min_count:
            continue
        centres.append(float(0.5 * (edges[i] + edges[i + 1])))
        means.append(float(np.mean(sel)))
        rmss.append(float(np.sqrt(np.mean(sel * sel))))
        counts.append(int(sel.size))
    return BinnedResidual(name, unit, tuple(centres), tuple(means), tuple(rmss), tuple(counts))


@dataclass(frozen=True)
class SpectralLine:
    """A sinusoidal component of a residual: frequency (Hz), amplitude and phase.

    ``amplitude`` is the sinusoid's amplitude in the residual's unit (the rms of
    the line is amplitude/sqrt(2)); ``prominence`` the ratio of the line's power
    spectral density to the local spectral floor (-).
    """

    frequency: float
    amplitude: float
    phase: float
    prominence: float


def fit_sinusoid(
    time: FloatArray, x: FloatArray, frequency: float, *, span: float = 0.0, steps: int = 41
) -> tuple[float, float, float]:
    """Least-squares sinusoid ``A*sin(2*pi*f*t + p)`` plus a constant fitted to ``x``.

    The frequency is refined on a grid ``frequency +- span`` (Hz). Returns
    ``(f, A, p)`` with A >= 0 (unit of x) and p in rad.
    """
    t = np.asarray(time, dtype=np.float64)
    y = np.asarray(x, dtype=np.float64)
    freqs = [frequency] if span <= 0 else np.linspace(frequency - span, frequency + span, steps)
    best = (frequency, 0.0, 0.0)
    best_ss = math.inf
    n = float(t.size)
    sum_y = float(np.sum(y))
    # exp(i*2*pi*f*t) over the equally spaced grid by one complex product per step
    step = float(freqs[1] - freqs[0]) if len(freqs) > 1 else 0.0
    turn = np.exp(2j * math.pi * step * t)
    z = np.exp(2j * math.pi * float(freqs[0]) * t)
    for i, f in enumerate(freqs):
        if i:
            z *= turn
        if f <= 0:
            continue
        s, c = z.imag, z.real
        ss_, cc_, sc_ = float(s @ s), float(c @ c), float(s @ c)
        s1, c1 = float(np.sum(s)), float(np.sum(c))
        G = np.array([[ss_, sc_, s1], [sc_, cc_, c1], [s1, c1, n]])
        b = np.array([float(s @ y), float(c @ y), sum_y])
        try:
            a, bc, m = np.linalg.solve(G, b)
        except np.linalg.LinAlgError:
            continue
        # residual sum of squares of the least-squares fit: y'y - coef'X'y (the
        # constant y'y is left out: only the ordering over the grid matters)
        ss = -float(a * b[0] + bc * b[1] + m * b[2])
        if ss < best_ss:
            best_ss = ss
            best = (float(f), float(math.hypot(a, bc)), float(math.atan2(bc, a)))
    return best


#: Margin of the line search's prefilter over the local median's grid estimate [-],
#: and the grid's relative step [-] (windows of +-10 % at neighbouring grid points
#: share 95 % of their bins).
_PREFILTER_MARGIN = 4.0
_GRID_STEP = 0.025


def spectral_lines(
    time: FloatArray,
    residual: FloatArray,
    fs: float,
    *,
    max_lines: int = 5,
    min_prominence: float = 30.0,
    min_amplitude: float = 0.0,
    fmin: float = 0.5,
    fmax: float | None = None,
) -> list[SpectralLine]:
    """Narrow lines in the residual spectrum (Welch PSD), strongest first.

    A line is a local PSD maximum at least ``min_prominence`` times the median
    PSD in a +-10 % frequency neighbourhood (a broadband bump of a stick-slip
    misfit is not a line); its frequency and amplitude are then refined by a
    least-squares sinusoid fit (:func:`fit_sinusoid`). ``fs`` in Hz.
    """
    r = np.asarray(residual, dtype=np.float64)
    n = r.size
    if n < 256:
        return []
    # one Hann-windowed periodogram of the whole record: the finest frequency
    # resolution (lines are narrow); a white-noise bin exceeds 30 x the local
    # median with probability ~exp(-30*ln2) ~ 1e-9
    f, p = signal.periodogram(r - np.mean(r), fs=fs, window='hann', detrend='linear')
    df = f[1] - f[0]
    fmax = fs / 2.0 if fmax is None else fmax
    peaks, _ = signal.find_peaks(p)
    peaks = peaks[(f[peaks] >= max(fmin, 2 * df)) & (f[peaks] <= fmax)]

    def floor_at(fk: float) -> float:
        half = max(0.1 * fk, 8 * df)
        lo = int(np.searchsorted(f, fk - half, side='left'))
        hi = int(np.searchsorted(f, fk + half, side='right'))
        return float(np.median(p[lo:hi]))

    cands: list[tuple[float, float]] = []
    if peaks.size:
        # prefilter: the local median on a log grid, with a margin; the exact test
        # follows for the peaks it keeps
        fp = f[peaks]
        grid = np.geomspace(fp[0], fp[-1], max(2, int(np.log(fp[-1] / fp[0]) / _GRID_STEP) + 2))
        approx = np.interp(fp, grid, [floor_at(float(g)) for g in grid])
        for k in peaks[p[peaks] * _PREFILTER_MARGIN >= min_prominence * approx]:
            fk = float(f[k])
            floor = floor_at(fk)
            prom = float(p[k] / floor) if floor > 0 else float('inf')
            if prom >= min_prominence:
                cands.append((float(p[k]), fk))
    cands.sort(reverse=True)
    lines: list[SpectralLine] = []
    for _, fk in cands[: 3 * max_lines]:
        if any(abs(fk - ln.frequency) < 2 * df for ln in lines):
            continue
        fr, amp, ph = fit_sinusoid(time, r, fk, span=df, steps=41)
        half = max(0.1 * fk, 8 * df)
        sel = (f >= fk - half) & (f <= fk + half)
        prom = float(np.max(p[sel]) / np.median(p[sel]))
        if amp >= min_amplitude:
            lines.append(SpectralLine(fr, amp, ph, prom))
        if len(lines) >= max_lines:
            break
    return lines


@dataclass(frozen=True)
class Trend:
    """Fit the linear trend of a residual with time.

    Returns the slope (unit/s), the change over the record (unit) and its t
    statistic computed on block means (robust to the residual's autocorrelation).
    """

    slope: float
    change: float
    t_stat: float


def trend(time: FloatArray, residual: FloatArray, *, blocks: int = 20) -> Trend:
    """Fit ``mean(residual) = a + slope*t`` on ``blocks`` equal time blocks."""
    t = np.asarray(time, dtype=np.float64)
    r = np.asarray(residual, dtype=np.float64)
    nb = int(min(blocks, max(3, t.size // 50)))
    idx = np.array_split(np.arange(t.size), nb)
    tm = np.array([t[i].mean() for i in idx])
    rm = np.array([r[i].mean() for i in idx])
    A = np.column_stack([np.ones_like(tm), tm - tm.mean()])
    coef, *_ = np.linalg.lstsq(A, rm, rcond=None)
    res = rm - A @ coef
    dof = max(nb - 2, 1)
    s2 = float(res @ res) / dof
    sxx = float(np.sum((tm - tm.mean()) ** 2))
    se = math.sqrt(s2 / sxx) if sxx > 0 and s2 > 0 else 0.0
    slope = float(coef[1])
    t_stat = slope / se if se > 0 else (math.inf if slope != 0 else 0.0)
    return Trend(slope, slope * float(t[-1] - t[0]), float(t_stat))


def phase_rms(residual: FloatArray, labels: IntArray) -> dict[str, float]:
    """Rms of the residual in each motion phase (NaN for an absent phase)."""
    r = np.asarray(residual, dtype=np.float64)
    return {name: rms(r[labels == code]) for code, name in enumerate(PHASE_NAMES)}


@dataclass(frozen=True)
class AngleDependence:
    """First- and second-harmonic dependence of the residual on an angle (rad).

    ``amplitude`` (residual unit) is the larger of the two harmonic amplitudes;
    ``order`` which harmonic (1 or 2); ``phase`` (rad).
    """

    amplitude: float
    order: int
    phase: float


def angle_dependence(angle: FloatArray, residual: FloatArray) -> AngleDependence:
    """Least-squares ``a*cos(n*angle) + b*sin(n*angle)`` for n = 1, 2 (plus mean)."""
    th = np.asarray(angle, dtype=np.float64)
    r = np.asarray(residual, dtype=np.float64)
    best = AngleDependence(0.0, 1, 0.0)
    for order in (1, 2):
        A = np.column_stack([np.ones_like(th), np.cos(order * th), np.sin(order * th)])
        coef, *_ = np.linalg.lstsq(A, r, rcond=None)
        amp = float(math.hypot(coef[1], coef[2]))
        if amp > best.amplitude:
            best = AngleDependence(amp, order, float(math.atan2(coef[2], coef[1])))
    return best
