"""Output-error fit of the rig model (+ a candidate effect) to a measured record.

The record is cut into *segments*, each starting inside a measured stick phase
where the state is known from the measurements (the discs move together:
``w1 = w2`` = measured shaft speed, ``phi1`` = torsion moment / C1, the belt
deflection from the stuck system's moment balance, Equ. 6). Each segment is
simulated with the compiled kernel (:func:`tribo_estimation.core.kernel.integrate`,
Equ. 1-3, 6, 8 plus the :class:`~tribo_estimation.core.model.Extensions`) from
that re-initialised state, so long records do not drift. Segments are grouped
into time blocks, which the cross validation holds out.

The fitted values are a mapping ``name -> value`` of ``mu0``, ``mu_inf`` (Equ. 8,
-) and ``Extensions`` fields (their SI units, see
:class:`~tribo_estimation.core.model.Extensions`). The cost is the mean of the
squared, channel-weighted residuals (measured - simulated) of the torsion
moment (N m), the angular acceleration (rad/s^2) and the shaft speed (rad/s).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields, replace

import numpy as np
import numpy.typing as npt
from numba import njit
from scipy.signal import savgol_filter

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.model import (
    DriveProfile,
    Extensions,
    FrictionLaw,
    RigParams,
    pack_params,
)
from tribo_estimation.core.simulate import sensor_lag, sensor_offset
from tribo_estimation.errors import InvalidDataError, InvalidParameterError, TooShortError

from .candidates import ParamSpec
from .stats import FloatArray, IntArray

#: Compared channels: the torsion moment (N m), the chamber speed w1 (rad/s;
#: measured = the angular acceleration integrated from each segment start,
#: simulated = the state; a smooth function of the parameters, unlike the
#: sampled acceleration, which jumps at every breakaway) and the shaft speed (rad/s).
CHANNELS: tuple[str, str, str] = ('torsion_moment', 'chamber_speed', 'speed')
CHANNEL_UNITS: dict[str, str] = {
    'torsion_moment': 'N m',
    'chamber_speed': 'rad/s',
    'speed': 'rad/s',
}

#: Extensions fields that act on the measurement, not on the dynamics.
MEASUREMENT_FIELDS: frozenset[str] = frozenset(
    {'torque_offset', 'torque_offset_drift', 'torque_lag_tau'}
)
_EXT_FIELDS: frozenset[str] = frozenset(f.name for f in fields(Extensions))

#: Friction parameters of the baseline (Equ. 8), fitted in every model.
MU0 = ParamSpec('mu0', '-', 0.0, 2.0, 0.01, 0.1)
MU_INF = ParamSpec('mu_inf', '-', 0.0, 2.0, 0.01, 0.1)


@dataclass(frozen=True)
class Record:
    """A measured rig record on a uniform time base.

    ``time`` s, ``torsion_moment`` N m, ``angular_acceleration`` rad/s^2,
    ``speed`` (shaft, w2) rad/s.
    """

    time: FloatArray
    torsion_moment: FloatArray
    angular_acceleration: FloatArray
    speed: FloatArray

    def __post_init__(self) -> None:
        n = self.time.size
        for name in ('time', 'torsion_moment', 'angular_acceleration', 'speed'):
            a = getattr(self, name)
            if a.ndim != 1 or a.size != n:
                raise InvalidDataError(
                    f'record column {name!r} has shape {a.shape}, expected ({n},)'
                )
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                raise InvalidDataError(
                    f'record column {name!r} has a non-finite value at sample {int(bad[0])}'
                )
        if n < 100:
            raise TooShortError(f'record has {n} samples; the discrepancy fit needs >= 100')
        dt = np.diff(self.time)
        if np.any(dt <= 0):
            i = int(np.flatnonzero(dt <= 0)[0]) + 1
            raise InvalidDataError(f'record time is not strictly increasing at sample {i}')
        med = float(np.median(dt))
        if np.max(np.abs(dt - med)) > 0.01 * med:
            i = int(np.argmax(np.abs(dt - med))) + 1
            raise InvalidDataError(
                f'record is not uniformly sampled (step {dt[i - 1]:.3g} s at sample {i}, '
                f'median {med:.3g} s); resample it first'
            )

    @property
    def dt(self) -> float:
        """Sample interval [s]."""
        return float((self.time[-1] - self.time[0]) / (self.time.size - 1))

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        return 1.0 / self.dt

    def channel(self, name: str) -> FloatArray:
        """A measured column by name."""
        return np.asarray(getattr(self, name), dtype=np.float64)


@dataclass(frozen=True)
class Segments:
    """Simulation segments: ``start``/``stop`` sample indices (stop exclusive),
    ``stick_time`` the time already spent sticking at the start [s], ``block``
    the time block each segment belongs to (unit of cross validation)."""

    start: IntArray
    stop: IntArray
    stick_time: FloatArray
    block: IntArray

    @property
    def n(self) -> int:
        """Number of segments."""
        return int(self.start.size)

    @property
    def n_blocks(self) -> int:
        """Number of time blocks."""
        return int(self.block.max()) + 1 if self.block.size else 0

    def mask_blocks(self, blocks: Sequence[int] | npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        """Boolean segment mask of the segments in the given blocks."""
        return np.isin(self.block, np.asarray(blocks, dtype=np.int64))

    def sample_mask(
        self, n: int, seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.bool_]:
        """Boolean mask of the samples covered by the (selected) segments."""
        m = np.zeros(n, dtype=bool)
        sel = np.ones(self.n, dtype=bool) if seg_mask is None else seg_mask
        for a, b in zip(self.start[sel], self.stop[sel], strict=True):
            m[a:b] = True
        return m


def detect_stick_runs(
    record: Record,
    C1: float,
    *,
    speed_threshold: float | None = None,
    min_duration: float = 2e-3,
) -> tuple[IntArray, IntArray]:
    """Stick phases in measured data: runs where the chamber moves with the shaft.

    The torsion element gives the chamber speed, ``w1 = phi1' = (dM_t/dt)/C1``
    (M_t = C1*phi1, physics notes section 1); while the discs stick it equals
    the measured shaft speed w2. ``dM_t/dt`` is a 2 ms Savitzky-Golay derivative.
    A run counts if ``|w1 - w2|`` stays below ``speed_threshold`` (rad/s;
    default: 20 % of the median |w2|, at least 5 x the derivative's noise; the
    stuck system's ringing seen through a lagging torque amplifier makes the
    two estimates differ by ~10 % of w2 while sticking) for
    ``min_duration`` s. ``C1`` in N m/rad. Returns start and stop (exclusive)
    sample indices.
    """
    fs = record.fs
    half = max(2, round(1e-3 * fs))
    w1 = savgol_filter(record.torsion_moment, 2 * half + 1, 2, deriv=1, delta=record.dt) / C1
    w2 = savgol_filter(record.speed, 2 * half + 1, 2)
    diff = w1 - w2
    if speed_threshold is None:
        d2 = np.diff(record.torsion_moment, 2)
        noise = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)
        # std of a quadratic SG slope over 2*half+1 points ~ noise*sqrt(12/n^3)/dt
        n = 2 * half + 1
        slope_noise = noise * math.sqrt(12.0 / n**3) / record.dt / C1
        speed_threshold = max(0.2 * float(np.median(np.abs(record.speed))), 5.0 * slope_noise)
    low = np.abs(diff) < speed_threshold
    d = np.diff(np.concatenate(([0], low.astype(np.int8), [0])))
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    keep = (stops - starts) >= max(3, round(min_duration * fs))
    return starts[keep].astype(np.int64), stops[keep].astype(np.int64)


def refine_onsets(accel: FloatArray, starts: IntArray, *, search: int = 20) -> FloatArray:
    """Sub-sample stick onsets from the acceleration jump where the discs lock.

    When sliding ends the chamber acceleration jumps from its sliding value to
    that of the stuck system. Within ``search`` samples before/after each
    detected start, the jump is the largest first difference that stands out
    of its neighbours' trend, ``e[j] = d[j] - (d[j-1] + d[j+1])/2``; the onset
    is then half a sample before the first stuck sample. Starts without a
    clear jump (below 8 x the noise of e) stay as they are. Returns onsets in
    (fractional) samples.
    """
    a = np.asarray(accel, dtype=np.float64)
    d = np.diff(a)
    e = np.zeros_like(d)
    e[1:-1] = d[1:-1] - 0.5 * (d[:-2] + d[2:])
    noise = 1.4826 * float(np.median(np.abs(e - np.median(e))))
    out = starts.astype(np.float64).copy()
    for k, s in enumerate(starts):
        lo = max(1, int(s) - search)
        hi = min(e.size - 1, int(s) + search // 2)
        if hi <= lo:
            continue
        j = lo + int(np.argmax(np.abs(e[lo:hi])))
        if abs(e[j]) > 8.0 * noise:
            out[k] = j + 1 - 0.5
    return out


def make_segments(
    record: Record,
    C1: float,
    *,
    min_length: float = 0.03,
    block_time: float = 0.25,
    start_delay: float = 3e-3,
    runs: tuple[IntArray, IntArray] | None = None,
) -> Segments:
    """Cut the record into segments that start ``start_delay`` s into a stick phase.

    Each segment runs to the next segment start (at least ``min_length`` s
    later); segments are numbered into time blocks of about ``block_time`` s.
    Raises :class:`TooShortError` when the record has fewer than 3 stick
    phases (the workflow needs stick-slip; slip-slip records are not supported).
    """
    s_start, s_stop = runs if runs is not None else detect_stick_runs(record, C1)
    fs = record.fs
    delay = round(start_delay * fs)
    cand = [
        (int(a) + min(delay, (int(b) - int(a)) // 2)) for a, b in zip(s_start, s_stop, strict=True)
    ]
    if len(cand) < 3:
        raise TooShortError(
            f'found {len(cand)} stick phases in the record; the discrepancy workflow '
            'needs a stick-slip record with at least 3'
        )
    min_len = round(min_length * fs)
    starts = [cand[0]]
    for c in cand[1:]:
        if c - starts[-1] >= min_len:
            starts.append(c)
    stops = [*starts[1:], record.time.size]
    # the last segment only if it reaches the next stick phase... keep it if long enough
    if stops[-1] - starts[-1] < min_len:
        starts, stops = starts[:-1], stops[:-1]
    start_arr = np.asarray(starts, dtype=np.int64)
    stop_arr = np.asarray(stops, dtype=np.int64)
    onsets = refine_onsets(record.angular_acceleration, s_start)
    run_start_of = {
        int(a) + min(delay, (int(b) - int(a)) // 2): float(o)
        for a, b, o in zip(s_start, s_stop, onsets, strict=True)
    }
    stick_time = np.asarray(
        [max((s - run_start_of[int(s)]) / fs, 0.0) for s in start_arr], dtype=np.float64
    )
    t_rel = (start_arr - start_arr[0]) / fs
    n_blocks = max(2, round((stop_arr[-1] - start_arr[0]) / fs / block_time))
    block = np.minimum((t_rel / block_time).astype(np.int64), n_blocks - 1)
    # renumber so that block ids are 0..B-1 without gaps
    _, block = np.unique(block, return_inverse=True)
    return Segments(start_arr, stop_arr, stick_time, block.astype(np.int64))


@njit(cache=True)
def _run_segments(
    p: np.ndarray,
    states: np.ndarray,
    starts: np.ndarray,
    stops: np.ndarray,
    dt: float,
    n_sub: int,
    out: np.ndarray,
) -> int:
    """Integrate every segment from its state with the kernel; write into ``out``."""
    max_len = 0
    for k in range(starts.shape[0]):
        max_len = max(max_len, stops[k] - starts[k])
    buf = np.empty((kn.N_CH, max_len))
    n_ev = 0
    for k in range(starts.shape[0]):
        s = states[k].copy()
        n = stops[k] - starts[k]
        n_ev += kn.integrate(p, s, n, dt, n_sub, buf)
        for c in range(kn.N_CH):
            for i in range(n):
                out[c, starts[k] + i] = buf[c, i]
    return n_ev


@njit(cache=True)
def _stick_states(
    p: np.ndarray,
    t: np.ndarray,
    torque: np.ndarray,
    speed: np.ndarray,
    accel: np.ndarray,
    stick_time: np.ndarray,
) -> np.ndarray:
    """Kernel states (``kernel.S_*``) of stuck discs from measured quantities.

    ``torque`` is the true torsion moment C1*phi1 [N m]; the belt deflection
    phi2 - phi0 follows from the stuck system's moment balance
    ``(I1 + I2)*w' = Q1 + Q2`` using the kernel's own Q1, Q2 (Q2 is affine in phi2).
    """
    n = t.shape[0]
    states = np.zeros((n, kn.NS))
    for k in range(n):
        phi1 = torque[k] / p[kn.P_C1]
        w = speed[k]
        q1 = kn.chamber_moment(p, phi1, w)
        phi0 = kn.drive_angle(p, t[k])
        qa = kn.shaft_moment(p, t[k], phi0, w)
        qb = kn.shaft_moment(p, t[k], phi0 + 1e-3, w)
        slope = (qb - qa) / 1e-3
        target = (p[kn.P_I1] + p[kn.P_I2]) * accel[k] - q1
        phi2 = phi0 + (target - qa) / slope
        states[k, kn.S_T] = t[k]
        states[k, kn.S_PHI1] = phi1
        states[k, kn.S_W1] = w
        states[k, kn.S_PHI2] = phi2
        states[k, kn.S_W2] = w
        states[k, kn.S_LAG] = p[kn.P_MU0]
        states[k, kn.S_STUCK] = 1.0
        states[k, kn.S_DIR] = 1.0
        states[k, kn.S_TSTICK] = stick_time[k]
    return states


def _local_fit(y: FloatArray, idx: IntArray, half: int, dt: float) -> tuple[FloatArray, FloatArray]:
    """Value and slope at i of a least-squares parabola through y[i-half : i+half+1]."""
    n = y.size
    vals = np.empty(idx.size)
    slopes = np.empty(idx.size)
    for j, i in enumerate(idx):
        a = max(0, int(i) - half)
        b = min(n, int(i) + half + 1)
        x = (np.arange(a, b) - int(i)) * dt
        if b - a < 3:
            vals[j], slopes[j] = y[int(i)], 0.0
            continue
        c = np.polyfit(x, y[a:b], 2)
        vals[j], slopes[j] = c[2], c[1]
    return vals, slopes


@dataclass(frozen=True)
class SimulatedRecord:
    """Model output on the record's time base (NaN outside the segments).

    Channels as :class:`Record` (the torsion moment after the measurement-side
    extensions) plus ``friction_moment`` N m, ``slip_speed`` rad/s, ``stick``
    (1.0 while sticking) and ``chamber_speed`` rad/s; ``covered`` marks the
    samples inside the simulated segments.
    """

    torsion_moment: FloatArray
    angular_acceleration: FloatArray
    speed: FloatArray
    friction_moment: FloatArray
    slip_speed: FloatArray
    stick: FloatArray
    chamber_speed: FloatArray
    covered: npt.NDArray[np.bool_]

    def channel(self, name: str) -> FloatArray:
        """A simulated channel by name."""
        return np.asarray(getattr(self, name), dtype=np.float64)


@dataclass(frozen=True)
class FitOutcome:
    """Result of :meth:`Problem.fit`: fitted values (all free and fixed names),
    mean weighted squared residual ``cost`` (-) over the fitted segments, the
    number of function evaluations and whether the optimiser converged."""

    values: dict[str, float]
    cost: float
    nfev: int
    converged: bool


class Problem:
    """A record, its segments, the known rig and drive: simulate and fit models.

    ``rig`` (Tab. 1 values, F_N, R), ``k`` (Equ. 8, s/rad) and ``drive``
    (nominal speed, ramp) are known; ``mu0``, ``mu_inf`` and extension fields
    are the model values passed to :meth:`simulate` / :meth:`fit`.
    """

    def __init__(
        self,
        record: Record,
        rig: RigParams,
        drive: DriveProfile,
        *,
        k: float = 2.0,
        segments: Segments | None = None,
        weights: Mapping[str, float] | None = None,
    ) -> None:
        self.record = record
        self.rig = rig
        self.drive = drive
        self.k = float(k)
        self.segments = segments if segments is not None else make_segments(record, rig.C1)
        self.n_evals = 0
        i = self.segments.start
        half = max(2, round(1e-3 * record.fs))
        self._t0 = record.time[i].astype(np.float64)
        self._m_val, self._m_slope = _local_fit(record.torsion_moment, i, half, record.dt)
        self._a0, _ = _local_fit(record.angular_acceleration, i, half, record.dt)
        self._w0, _ = _local_fit(record.speed, i, half, record.dt)
        # measured chamber speed: w1 = w(start) + integral of w1' (trapezoid) per segment
        seg = self.segments
        w1 = np.full(record.time.size, np.nan)
        acc = record.angular_acceleration
        for k, (a, b) in enumerate(zip(seg.start, seg.stop, strict=True)):
            inc = 0.5 * (acc[a + 1 : b] + acc[a : b - 1]) * record.dt
            w1[a] = self._w0[k]
            w1[a + 1 : b] = self._w0[k] + np.cumsum(inc)
        self._meas: dict[str, FloatArray] = {
            'torsion_moment': record.torsion_moment,
            'chamber_speed': w1,
            'speed': record.speed,
        }
        self.weights: dict[str, float] = dict(weights) if weights else self.signal_weights()

    # ------------------------------------------------------------------ weights
    def signal_weights(self) -> dict[str, float]:
        """Channel weights 1/std(measured channel) (a start before any fit)."""
        out = {}
        for c in CHANNELS:
            m = self._meas[c] if hasattr(self, '_meas') else self.record.channel(c)
            s = float(np.nanstd(m))
            out[c] = 1.0 / s if s > 0 else 0.0
        return out

    def set_residual_weights(self, sim: SimulatedRecord, floor: Mapping[str, float]) -> None:
        """Weights 1/rms(residual) per channel (each channel then contributes
        equally to the cost of that model), never above 1/floor[c]."""
        cov = sim.covered
        for c in CHANNELS:
            r = self._meas[c][cov] - sim.channel(c)[cov]
            s = max(float(np.sqrt(np.mean(r * r))), floor.get(c, 0.0))
            self.weights[c] = 1.0 / s if s > 0 else 0.0

    # --------------------------------------------------------------- simulation
    def model_objects(self, values: Mapping[str, float]) -> tuple[FrictionLaw, Extensions]:
        """FrictionLaw and Extensions of a value mapping (unknown names rejected)."""
        ext_vals = {k: float(v) for k, v in values.items() if k not in ('mu0', 'mu_inf')}
        unknown = set(ext_vals) - _EXT_FIELDS
        if unknown:
            raise InvalidParameterError(f'unknown model parameter(s) {sorted(unknown)}')
        fr = FrictionLaw(
            max(float(values.get('mu0', MU0.initial)), 0.0),
            max(float(values.get('mu_inf', MU_INF.initial)), 0.0),
            self.k,
        )
        return fr, replace(Extensions(), **ext_vals)

    def simulate(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> SimulatedRecord:
        """Simulate the (selected) segments with the model ``values``."""
        fr, ext = self.model_objects(values)
        p = pack_params(self.rig, fr, self.drive, ext)
        rec = self.record
        seg = self.segments
        sel = np.ones(seg.n, dtype=bool) if seg_mask is None else seg_mask
        # measured torsion at the segment starts -> true C1*phi1 (invert the
        # measurement-side extensions: offset, then first-order lag)
        t0 = self._t0[sel]
        m_lagged = self._m_val[sel] - ext.torque_offset - ext.torque_offset_drift * t0
        # the sensor lag is the discrete filter y[n] = a*y[n-1] + (1 - a)*x[n] of
        # simulate.simulate, a = exp(-dt/tau): on a ramp of slope S it lags by
        # S*dt*a/(1 - a) (-> S*tau for dt << tau)
        lag_eff = 0.0
        if ext.torque_lag_tau > 0.0:
            a_l = math.exp(-rec.dt / ext.torque_lag_tau)
            lag_eff = rec.dt * a_l / (1.0 - a_l)
        m_true = m_lagged + lag_eff * (self._m_slope[sel] - ext.torque_offset_drift)
        states = _stick_states(p, t0, m_true, self._w0[sel], self._a0[sel], seg.stick_time[sel])
        n = rec.time.size
        out = np.full((kn.N_CH, n), np.nan)
        n_sub = kn.substeps_for(p, rec.dt)
        _run_segments(p, states, seg.start[sel], seg.stop[sel], rec.dt, n_sub, out)
        self.n_evals += 1
        torsion = out[kn.OUT_TORSION].copy()
        if ext.torque_lag_tau > 0.0:
            # the sensor model of simulate.simulate, per segment
            a = math.exp(-rec.dt / ext.torque_lag_tau)
            for k, (i0, i1) in enumerate(zip(seg.start[sel], seg.stop[sel], strict=True)):
                # state chosen so that the first output equals the measured (lagged)
                # value: y0 = a*y_prev + (1 - a)*x0
                y_prev = (m_lagged[k] - (1.0 - a) * torsion[i0]) / a
                torsion[i0:i1] = sensor_lag(torsion[i0:i1], rec.dt, ext.torque_lag_tau, y_prev)
        torsion = sensor_offset(torsion, rec.time, ext)
        covered = np.isfinite(out[kn.OUT_TORSION])
        return SimulatedRecord(
            torsion_moment=torsion,
            angular_acceleration=out[kn.OUT_ACCEL],
            speed=out[kn.OUT_SPEED],
            friction_moment=out[kn.OUT_FRICTION],
            slip_speed=out[kn.OUT_SLIP],
            stick=out[kn.OUT_STICK],
            chamber_speed=out[kn.OUT_W1],
            covered=covered,
        )

    def measured(self, name: str) -> FloatArray:
        """A compared measured channel (:data:`CHANNELS`; chamber speed NaN off-segment)."""
        return self._meas[name]

    def residual_vector(self, sim: SimulatedRecord) -> FloatArray:
        """Weighted residuals of all channels over the covered samples (-)."""
        cov = sim.covered
        parts = []
        for c in CHANNELS:
            w = self.weights.get(c, 0.0)
            if w > 0:
                r = self._meas[c][cov] - sim.channel(c)[cov]
                parts.append(w * r)
        v = np.concatenate(parts)
        # a diverged simulation (NaN) is a very bad fit, not a crash of the optimiser
        return np.where(np.isfinite(v), v, 1e3)

    def cost(self, sim: SimulatedRecord) -> float:
        """Mean squared weighted residual per sample (-), summed over channels."""
        v = self.residual_vector(sim)
        n = int(np.count_nonzero(sim.covered))
        return float(np.sum(v * v)) / max(n, 1)

    def torque_rms(self, sim: SimulatedRecord) -> float:
        """Rms of the torsion-moment residual (measured - simulated) [N m]."""
        cov = sim.covered
        r = self.record.torsion_moment[cov] - sim.torsion_moment[cov]
        return float(np.sqrt(np.mean(r * r)))

    # --------------------------------------------------------------------- fit
    def fit(
        self,
        free: Sequence[ParamSpec],
        start: Mapping[str, float],
        *,
        fixed: Mapping[str, float] | None = None,
        seg_mask: npt.NDArray[np.bool_] | None = None,
        max_nfev: int = 60,
    ) -> FitOutcome:
        """Least-squares output-error fit of the ``free`` parameters.

        ``start`` gives their start values, ``fixed`` further model values held
        constant. Uses :func:`levenberg_marquardt` on value/scale coordinates
        (log for time constants); ``max_nfev`` counts every simulation.
        """
        fixed_vals = dict(fixed or {})
        names = [p.name for p in free]

        def to_x(vals: Mapping[str, float]) -> FloatArray:
            return np.asarray(
                [
                    math.log(min(max(float(vals[p.name]), p.lower), p.upper))
                    if p.log
                    else min(max(float(vals[p.name]), p.lower), p.upper) / p.scale
                    for p in free
                ]
            )

        def from_x(x: FloatArray) -> dict[str, float]:
            out = dict(fixed_vals)
            for p, xi in zip(free, x, strict=True):
                out[p.name] = math.exp(float(xi)) if p.log else float(xi) * p.scale
            return out

        lo = np.asarray([math.log(p.lower) if p.log else p.lower / p.scale for p in free])
        hi = np.asarray([math.log(p.upper) if p.log else p.upper / p.scale for p in free])
        x0 = np.clip(to_x(start), lo, hi)

        def fun(x: FloatArray) -> FloatArray:
            return self.residual_vector(self.simulate(from_x(x), seg_mask))

        if not names:
            sim = self.simulate(fixed_vals, seg_mask)
            return FitOutcome(dict(fixed_vals), self.cost(sim), 1, True)
        x, sq, nfev, conv = levenberg_marquardt(fun, x0, lo, hi, max_nfev=max_nfev)
        n = int(np.count_nonzero(self.segments.sample_mask(self.record.time.size, seg_mask)))
        return FitOutcome(from_x(x), sq / max(n, 1), nfev, conv)


@njit(cache=True)
def _normal_equations(J_rows: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """J^T J and J^T r from the Jacobian's columns stored as rows (p x m).

    Compiled loops instead of BLAS: on a busy shared machine multi-threaded
    BLAS on these tall, thin products spins far longer than it computes.
    """
    p, m = J_rows.shape
    A = np.zeros((p, p))
    g = np.zeros(p)
    for i in range(p):
        acc = 0.0
        for k in range(m):
            acc += J_rows[i, k] * r[k]
        g[i] = acc
        for j in range(i, p):
            acc = 0.0
            for k in range(m):
                acc += J_rows[i, k] * J_rows[j, k]
            A[i, j] = acc
            A[j, i] = acc
    return A, g


def levenberg_marquardt(
    fun: Callable[[FloatArray], FloatArray],
    x0: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    *,
    max_nfev: int = 60,
    rel_step: float = 1e-4,
    ftol: float = 1e-6,
) -> tuple[FloatArray, float, int, bool]:
    """Bounded Levenberg-Marquardt on ``sum(fun(x)**2)`` with forward differences.

    Steps are projected onto the bounds ``[lo, hi]``; every function call
    (Jacobian columns included) counts against ``max_nfev``. Returns
    ``(x, sum of squares, nfev, converged)``; converged means the relative
    decrease of the sum of squares fell below ``ftol``.
    """
    x = np.clip(np.asarray(x0, dtype=np.float64), lo, hi)
    r = fun(x)
    sq = float(np.sum(r * r))
    nfev = 1
    lam = 1e-3
    p = x.size
    while nfev + p + 1 <= max_nfev:
        cols: list[FloatArray] = []
        for j in range(p):
            h = rel_step * max(1.0, abs(x[j]))
            if x[j] + h > hi[j]:
                h = -h
            xs = x.copy()
            xs[j] += h
            cols.append((fun(xs) - r) / h)
            nfev += 1
        A, g = _normal_equations(np.ascontiguousarray(np.vstack(cols)), r)
        dA = np.diag(A).copy()
        dA[dA <= 0] = 1.0
        improved = False
        while nfev < max_nfev:
            try:
                d = np.linalg.solve(A + lam * np.diag(dA), -g)
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            xn = np.clip(x + d, lo, hi)
            if np.allclose(xn, x, rtol=0.0, atol=1e-12):
                break
            rn = fun(xn)
            nfev += 1
            sqn = float(np.sum(rn * rn))
            if sqn < sq:
                rel = (sq - sqn) / max(sq, 1e-300)
                x, r, sq = xn, rn, sqn
                lam = max(lam / 5.0, 1e-9)
                improved = True
                if rel < ftol:
                    return x, sq, nfev, True
                break
            lam *= 4.0
            if lam > 1e8:
                break
        if not improved:
            return x, sq, nfev, True
    return x, sq, nfev, False
