"""Output-error fit of the rig model (+ a candidate effect) to a measured record.

The record is cut into *segments*, each starting inside a measured stick phase
where the state is known from the measurements (the discs move together:
``w1 = w2`` = measured shaft speed, ``phi1`` = torsion moment / C1, the belt
deflection from the stuck system's moment balance, Equ. 6). Each segment is
simulated with the compiled kernel (:func:`tribo_estimation.core.kernel.integrate`,
Equ. 1-3, 6, 8 plus the :class:`~tribo_estimation.core.model.Extensions`) from
that re-initialised state, so long records do not drift. A record without
stick-slip starts its segments from the measured sliding state instead
(:meth:`Problem._sliding_states`). Segments are grouped
into time blocks, which the cross validation holds out.

The fitted values are a mapping ``name -> value`` of ``mu0``, ``mu_inf`` (Equ. 8,
-) and ``Extensions`` fields (their SI units, see
:class:`~tribo_estimation.core.model.Extensions`). The cost is the mean of the
squared, channel-weighted residuals (measured - simulated) of the torsion
moment (N m), the angular acceleration (rad/s^2) and the shaft speed (rad/s).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace

import numpy as np
import numpy.typing as npt

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.drive import (
    DriveEstimate,
    estimate_drive,
    refine_with_angles,
    tolerance,
)
from tribo_estimation.core.lsq import levenberg_marquardt
from tribo_estimation.core.measurement import apply_measurement_transforms, true_torsion_at_starts
from tribo_estimation.core.model import (
    DriveProfile,
    Extensions,
    FrictionLaw,
    RigParams,
    pack_params,
)
from tribo_estimation.core.shooting import (
    DriveKnots,
    lag_segments,
    local_cubic,
    shoot,
    sliding_states,
    stuck_states,
    window_mean,
)
from tribo_estimation.core.signal import CHAMBER_HALF, moving_average
from tribo_estimation.core.sticks import (
    MAX_TORSION_LAG,
    chamber_speed_integral,
    detect_sticks,
    drive_speed_level,
    estimate_torsion_lag,
    torsion_lag_compensated,
)
from tribo_estimation.errors import (
    EstimationError,
    InvalidDataError,
    InvalidParameterError,
    TooShortError,
)

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

#: Instrument model of the shaft-speed channel, fitted with the baseline:
#: first-order sensor lag [s] and zero offset [rad/s]. The simulated shaft speed
#: passes through them before it is compared; the state at segment starts does
#: not use the speed channel (the common speed comes from dM_t/dt), so the
#: other channels are insensitive to both.
SPEED_LAG = ParamSpec('speed_lag_tau', 's', 0.0, 0.02, 1e-3, 0.0)
SPEED_OFFSET = ParamSpec('speed_offset', 'rad/s', -1.0, 1.0, 0.01, 0.0)
INSTRUMENT: tuple[ParamSpec, ...] = (SPEED_LAG, SPEED_OFFSET)
INSTRUMENT_FIELDS: frozenset[str] = frozenset(p.name for p in INSTRUMENT)


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
    the time block each segment belongs to (unit of cross validation),
    ``run_start``/``run_stop`` the stick phase holding each start [samples]."""

    start: IntArray
    stop: IntArray
    stick_time: FloatArray
    block: IntArray
    run_start: IntArray | None = None
    run_stop: IntArray | None = None
    #: True: the record has no stick-slip; every segment starts while sliding
    sliding: bool = False

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


def stick_runs(
    record: Record, rig: RigParams, *, min_duration: float = 2e-3
) -> tuple[IntArray, IntArray, FloatArray]:
    """Stick phases of a record from the package's one stick detector
    (:func:`tribo_estimation.core.sticks.detect_sticks`): first and stop
    (exclusive) sample of each phase and its start time [s]."""
    try:
        phases = detect_sticks(
            record.time,
            record.torsion_moment,
            record.angular_acceleration,
            record.speed,
            rig,
            min_duration=min_duration,
        )
    except EstimationError:
        phases = []
    fs, t0, n = record.fs, float(record.time[0]), record.time.size
    a = np.array([min(n, max(0, math.ceil((p.start - t0) * fs - 1e-9))) for p in phases], np.int64)
    b = np.array([min(n, max(0, math.ceil((p.end - t0) * fs - 1e-9))) for p in phases], np.int64)
    onset = np.array([p.start for p in phases], dtype=np.float64)
    keep = b > a
    a, b, onset = a[keep], b[keep], onset[keep]
    # overlapping phases (if a detector reports any) are merged
    order = np.argsort(a, kind='stable')
    ma: list[int] = []
    mb: list[int] = []
    mo: list[float] = []
    for i in order.tolist():
        if ma and a[i] < mb[-1]:
            mb[-1] = max(mb[-1], int(b[i]))
            mo[-1] = min(mo[-1], float(onset[i]))
        else:
            ma.append(int(a[i]))
            mb.append(int(b[i]))
            mo.append(float(onset[i]))
    return np.array(ma, np.int64), np.array(mb, np.int64), np.array(mo, np.float64)


def make_segments(
    record: Record,
    rig: RigParams,
    *,
    min_length: float = 0.03,
    block_time: float = 0.25,
    start_delay: float = 3e-3,
    runs: tuple[IntArray, IntArray, FloatArray] | None = None,
) -> Segments:
    """Cut the record into segments that start ``start_delay`` s into a stick phase.

    Each segment runs to the next segment start (at least ``min_length`` s
    later); segments are numbered into time blocks of about ``block_time`` s.
    ``runs`` (first, stop sample, start time [s] of each stick phase) default to
    :func:`stick_runs`. A record with fewer than 3 stick phases (slip-slip, steady
    sliding) gets sliding segments instead (:func:`_sliding_segments`).
    """
    s_start, s_stop, onset = runs if runs is not None else stick_runs(record, rig)
    fs = record.fs
    delay = round(start_delay * fs)
    cand = [
        (int(a) + min(delay, (int(b) - int(a)) // 2), k)
        for k, (a, b) in enumerate(zip(s_start, s_stop, strict=True))
    ]
    if len(cand) < 3:
        return _sliding_segments(record, block_time)
    min_len = round(min_length * fs)
    chosen = [cand[0]]
    for c in cand[1:]:
        if c[0] - chosen[-1][0] >= min_len:
            chosen.append(c)
    starts = [c[0] for c in chosen]
    stops = [*starts[1:], record.time.size]
    if stops[-1] - starts[-1] < min_len:
        chosen, starts, stops = chosen[:-1], starts[:-1], stops[:-1]
    start_arr = np.asarray(starts, dtype=np.int64)
    stop_arr = np.asarray(stops, dtype=np.int64)
    run_k = np.asarray([c[1] for c in chosen], dtype=np.int64)
    stick_time = np.maximum(record.time[start_arr] - onset[run_k], 0.0)
    t_rel = (start_arr - start_arr[0]) / fs
    n_blocks = max(2, round((stop_arr[-1] - start_arr[0]) / fs / block_time))
    block = np.minimum((t_rel / block_time).astype(np.int64), n_blocks - 1)
    # renumber so that block ids are 0..B-1 without gaps
    _, block = np.unique(block, return_inverse=True)
    return Segments(
        start_arr,
        stop_arr,
        stick_time.astype(np.float64),
        block.astype(np.int64),
        np.asarray(s_start, dtype=np.int64)[run_k],
        np.asarray(s_stop, dtype=np.int64)[run_k],
    )


#: Local-fit window at sliding segment starts [samples] (odd).
_SLIDE_WIN = 51


def _sliding_segments(record: Record, block_time: float) -> Segments:
    """Segments of a record without stick-slip (slip-slip, steady sliding): one per
    ``block_time`` [s], each starting from the measured sliding state (see
    :meth:`Problem.simulate`). Raises :class:`TooShortError` below two blocks."""
    fs = record.fs
    n = record.time.size
    length = max(round(block_time * fs), 100)
    edge = _SLIDE_WIN  # the local fits at a start need samples on both sides
    starts = np.arange(edge, n - length // 2, length, dtype=np.int64)
    if starts.size < 2:
        raise TooShortError(
            f'record of {n / fs:.3g} s without stick phases: the discrepancy workflow needs '
            f'at least {2 * block_time:.3g} s of sliding'
        )
    stops = np.append(starts[1:], n).astype(np.int64)
    return Segments(
        starts,
        stops,
        np.zeros(starts.size),
        np.arange(starts.size, dtype=np.int64),
        None,
        None,
        True,
    )


def speed_slope(speed: FloatArray, dt: float) -> FloatArray:
    """Slope y' [rad/s^2] of the speed channel (local cubic over 4*7+1 samples): with
    a first-order sensor lag tau the shaft speed is ``w = y + tau*y'``."""
    from scipy.signal import savgol_filter

    win = 4 * CHAMBER_HALF + 1
    if speed.size < win:
        return np.zeros(speed.size)
    return np.asarray(savgol_filter(speed, win, 3, deriv=1, delta=dt), dtype=np.float64)


#: Length of the record pieces the torsion lag is estimated on [s] (the spread of
#: the pieces' estimates gives its standard error) and the window of the local
#: mean that fixes the compensation's constant and drift [s].
_TQ_LAG_PIECE = 1.0
_TQ_LAG_MEAN_WIN = 0.005
#: Smallest torsion lag taken as real [s] (the block fit's threshold).
MIN_TORSION_LAG = 1e-4


@dataclass(frozen=True)
class TorsionLag:
    """Identified first-order lag of the torsion amplifier ``tau`` [s] with its
    standard error ``se`` [s] (spread of the estimates on ``n`` record pieces)
    and the lag compensated (``used`` [s], 0 = none)."""

    tau: float
    se: float
    n: int
    used: float

    def report(self) -> dict[str, float | int | str]:
        """The ``instrument`` entry of discrepancy.json."""
        return {'value': self.tau, 'se': self.se, 'unit': 's', 'used': self.used, 'pieces': self.n}


def identify_torsion_lag(record: Record, rig: RigParams, *, enabled: bool = True) -> TorsionLag:
    """The torsion amplifier's first-order lag from the record, friction-free.

    :func:`sticks.estimate_torsion_lag` (chamber kinematics ``M_t = C1*phi1``,
    ``phi1'' = a``, Equ. 1/4) on pieces of ~1 s; the median is the lag, the
    pieces' spread its standard error. Used (compensated) when at least
    :data:`MIN_TORSION_LAG`, beyond 3 standard errors and inside the estimator's
    range (an estimate at the range's end, 3 ms, is left to the workflow's
    ``torque_sensor_lag`` candidate); ``enabled=False`` estimates nothing."""
    if not enabled:
        return TorsionLag(math.nan, math.nan, 0, 0.0)
    fs = record.fs
    n = record.time.size
    # ~1 s pieces; at least 4 (of >= 0.2 s) on a shorter record for the spread
    m = max(1, int(n // round(_TQ_LAG_PIECE * fs)), min(4, int(n // round(0.2 * fs))))
    edges = np.linspace(0, n, m + 1).astype(int)
    est: list[float] = []
    for a, b in itertools.pairwise(edges.tolist()):
        try:
            tau = float(
                estimate_torsion_lag(
                    record.torsion_moment[a:b], record.angular_acceleration[a:b], fs, rig.C1
                )
            )
        except (ValueError, np.linalg.LinAlgError):
            continue
        if math.isfinite(tau):
            est.append(tau)
    if not est:
        return TorsionLag(math.nan, math.nan, 0, 0.0)
    arr = np.asarray(est)
    tau = float(np.median(arr))
    se = float(1.2533 * np.std(arr, ddof=1) / math.sqrt(arr.size)) if arr.size > 1 else math.nan
    ok = (
        tau >= MIN_TORSION_LAG
        and tau < 0.98 * MAX_TORSION_LAG
        and (not math.isfinite(se) or tau > 3.0 * se)
    )
    return TorsionLag(tau, se, arr.size, tau if ok else 0.0)


def torsion_compensated_record(record: Record, rig: RigParams, tau: float) -> Record:
    """The record with the torsion amplifier's first-order lag ``tau`` [s] taken
    out of its torsion moment (:func:`sticks.torsion_lag_compensated`, exact:
    ``M_t = y + tau*C1*lag(w1)``, Equ. 4). The integrated acceleration gives
    ``w1`` up to a constant and a drift (the trapezoid's error at the
    acceleration's jumps); the correction's local mean (5 ms: shorter than the
    stick and slip phases between the jumps) is therefore replaced by its true
    value, the local mean of ``tau*y'`` (a difference quotient of the measured
    ``y``: noise ~0.015 N m for a 1 ms lag at config/rig.yaml)."""
    if tau <= 0.0:
        return record
    fs = record.fs
    dt = record.dt
    y = record.torsion_moment
    w = chamber_speed_integral(record.angular_acceleration, dt)
    corr = torsion_lag_compensated(y, w, dt, tau, rig.C1) - y
    n = y.size
    h = max(1, min(n // 2, round(0.5 * _TQ_LAG_MEAN_WIN * fs)))
    i = np.arange(n)
    lo = np.maximum(0, i - h)
    hi = np.minimum(n - 1, i + h)
    mean_slope = (y[hi] - y[lo]) / ((hi - lo) * dt)  # local mean of y' [N m/s]
    corr = corr - drive_speed_level(corr, fs, _TQ_LAG_MEAN_WIN) + tau * mean_slope
    return replace(record, torsion_moment=np.asarray(y + corr, dtype=np.float64))


@dataclass(frozen=True)
class SpeedSensor:
    """Identified speed-sensor model: first-order lag ``tau`` [s] and zero offset
    ``offset`` [rad/s] with standard errors; ``n`` stick samples used."""

    tau: float
    tau_se: float
    offset: float
    offset_se: float
    n: int

    def values(self) -> dict[str, float]:
        """As model values (:data:`INSTRUMENT_FIELDS`); a value within 3 standard
        errors of zero is not used (0): the model is very sensitive to a wrong speed
        offset (it shifts the drive speed), so noise must not enter it."""

        def significant(v: float, se: float) -> float:
            return v if math.isfinite(se) and abs(v) > 3.0 * se else 0.0

        return {
            'speed_lag_tau': significant(self.tau, self.tau_se),
            'speed_offset': significant(self.offset, self.offset_se),
        }


def identify_speed_sensor(
    record: Record, rig: RigParams, runs: tuple[IntArray, IntArray] | None = None
) -> SpeedSensor:
    """Speed-sensor lag and offset from the stick phases, independent of friction.

    While the discs stick, the shaft speed equals the chamber speed
    ``w = (dM_t/dt)/C1`` (Equ. 4; from the torsion moment, which carries neither
    of the speed sensor's errors). A first-order sensor shows ``y`` with
    ``w = y + tau*y'`` (``y'`` from a local cubic through the speed channel), so
    ``y - w = offset - tau*y'``: a linear regression over the stick samples
    (10 samples from each end of a phase left out) gives both; standard errors
    are cluster-robust over the stick phases. ``tau`` is limited to [0, 20 ms].
    """
    from tribo_estimation.core.signal import chamber_speed

    if runs is None:
        a0, b0, _ = stick_runs(record, rig)
    else:
        a0, b0 = runs
    w = chamber_speed(record.torsion_moment, record.fs, rig.C1)
    # y' from the speed channel itself (during a stick it follows w' through the lag,
    # and before it the shaft's own acceleration)
    acc = speed_slope(record.speed, record.dt)
    guard = CHAMBER_HALF + 3
    idx_l: list[IntArray] = []
    cl_l: list[IntArray] = []
    for k, (a, b) in enumerate(zip(a0, b0, strict=True)):
        if b - a > 2 * guard + 2:
            ii = np.arange(int(a) + guard, int(b) - guard, dtype=np.int64)
            idx_l.append(ii)
            cl_l.append(np.full(ii.size, k, dtype=np.int64))
    if not idx_l:
        return SpeedSensor(0.0, math.nan, 0.0, math.nan, 0)
    idx = np.concatenate(idx_l)
    cl = np.concatenate(cl_l)
    d = record.speed[idx] - w[idx]
    X = np.column_stack((np.ones(idx.size), -acc[idx]))
    try:
        coef, *_ = np.linalg.lstsq(X, d, rcond=None)
        binv = np.linalg.inv(X.T @ X)
    except np.linalg.LinAlgError:
        return SpeedSensor(0.0, math.nan, 0.0, math.nan, int(idx.size))
    r = d - X @ coef
    _, g = np.unique(cl, return_inverse=True)
    G = int(g.max()) + 1
    scores = np.zeros((G, 2))
    np.add.at(scores, g, X * r[:, None])
    cov = binv @ (scores.T @ scores) @ binv * (G / max(G - 1, 1))
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    tau = min(max(float(coef[1]), 0.0), SPEED_LAG.upper)
    return SpeedSensor(tau, float(se[1]), float(coef[0]), float(se[0]), int(idx.size))


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
    se: dict[str, float] = field(default_factory=dict)


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
        #: drive speed measured from the record (the nominal speed only a check)
        self.drive_estimate: DriveEstimate = estimate_drive(
            record.time, record.speed, drive.nominal_speed
        )
        self.segments = segments if segments is not None else make_segments(record, rig)
        self.n_evals = 0
        seg = self.segments
        i = seg.start
        fs = record.fs
        self._t0 = record.time[i].astype(np.float64)
        self._drive_speed0 = self.drive_estimate
        # a record that begins at the drive's start (RIG.yaml ramp from t = 0, and the
        # measured speed there at rest within the profile tolerance): w0 = 0 at t0
        n_rest = max(1, round(0.01 * record.fs))  # the first 10 ms of the speed channel
        at_rest = abs(float(np.mean(record.speed[:n_rest]))) < tolerance(
            self.drive_estimate.level, 0.0
        )
        self._start_speed: float | None = (
            0.0 if drive.ramp_time > 0.0 and abs(float(record.time[0])) < 1e-6 and at_rest
            else None
        )  # fmt: skip
        sp = record.speed
        self._shaft_angle = np.concatenate(([0.0], np.cumsum(0.5 * (sp[1:] + sp[:-1]) * record.dt)))
        self._knots = DriveKnots.from_estimate(self.drive_estimate)
        # state at the segment starts: the torsion moment (local cubic) and the
        # acceleration; the common speed of the stuck discs from the speed channel
        # with its sensor model inverted (:meth:`_set_instrument`)
        self._m_val, slope = local_cubic(record.torsion_moment, i, seg.run_start, seg.run_stop)
        self._m_slope = np.where(np.isfinite(slope), slope * fs, 0.0)
        self._a0 = window_mean(record.angular_acceleration, i, 2, seg.run_start, seg.run_stop)
        self._speed_start = window_mean(record.speed, i, 5, seg.run_start, seg.run_stop)
        # stick samples (every 4th, away from the phase ends) and smoothed channels
        # for the drive angle (:meth:`_set_instrument`)
        width = 2 * CHAMBER_HALF + 1
        self._smooth_speed = moving_average(record.speed, width)
        self._speed_slope = speed_slope(record.speed, record.dt)
        self._smooth_accel = moving_average(record.angular_acceleration, width)
        self._smooth_torque = moving_average(record.torsion_moment, width)
        guard = CHAMBER_HALF + 1
        ra = seg.run_start if seg.run_start is not None else seg.start
        rb = seg.run_stop if seg.run_stop is not None else seg.start + 1
        idx = [
            np.arange(int(a) + guard, int(b) - guard, 4, dtype=np.int64)
            for a, b in zip(ra, rb, strict=True)
            if b - a > 2 * guard
        ]
        self._stick_samples = (
            np.unique(np.concatenate(idx)) if idx else np.asarray(seg.start, dtype=np.int64)
        )
        self._meas: dict[str, FloatArray] = {
            'torsion_moment': record.torsion_moment,
            'chamber_speed': np.full(record.time.size, np.nan),
            'speed': record.speed,
        }
        self._w_start = self._speed_start.copy()
        self._instrument: tuple[float, ...] = (math.nan,) * 7
        self._set_instrument(0.0, 0.0)
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
        ext_vals = {
            k: float(v)
            for k, v in values.items()
            if k not in ('mu0', 'mu_inf') and k not in INSTRUMENT_FIELDS
        }
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
        t0 = self._t0[sel]
        m_true = true_torsion_at_starts(ext, t0, self._m_val[sel], self._m_slope[sel], rec.dt)
        self._set_instrument(
            float(values.get('speed_lag_tau', 0.0)),
            float(values.get('speed_offset', 0.0)),
            (ext.ripple_amp, ext.ripple_freq, ext.ripple_phase),
            (ext.torque_offset, ext.torque_offset_drift),
        )
        dk = self._knots
        if seg.sliding:
            states = self._sliding_states(p, sel, m_true)
        else:
            states = stuck_states(
                p, t0, m_true, self._w_start[sel], self._a0[sel], seg.stick_time[sel], dk.time,
                dk.speed,
            )  # fmt: skip
        n = rec.time.size
        out = np.full((kn.N_CH, n), np.nan)
        n_sub = kn.substeps_for(p, rec.dt)
        shoot(p, states, seg.start[sel], seg.stop[sel], dk.time, dk.speed, rec.dt, n_sub, out)
        self.n_evals += 1
        speed = self._speed_sensor(out[kn.OUT_SPEED], values, sel)
        torsion, _ = apply_measurement_transforms(
            ext, rec.time, out[kn.OUT_TORSION].copy(), rec.dt,
            segments=(seg.start[sel], seg.stop[sel]), measured_first=self._m_val[sel],
        )  # fmt: skip
        covered = np.isfinite(out[kn.OUT_TORSION])
        return SimulatedRecord(
            torsion_moment=torsion,
            angular_acceleration=out[kn.OUT_ACCEL],
            speed=speed,
            friction_moment=out[kn.OUT_FRICTION],
            slip_speed=out[kn.OUT_SLIP],
            stick=out[kn.OUT_STICK],
            chamber_speed=out[kn.OUT_W1],
            covered=covered,
        )

    def _set_instrument(
        self,
        tau: float,
        offset: float,
        ripple: tuple[float, float, float] = (0.0, 0.0, 0.0),
        torque: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        """Invert the speed sensor (lag ``tau`` [s], offset [rad/s]) at the segment
        starts: while stuck the discs share one speed w with w' = the measured
        acceleration a, and a first-order sensor shows y with ``w = y + tau*y'``,
        ``y' = a`` (slowly varying a): ``w = y - offset + tau*a``. The measured
        chamber speed channel is ``w(start) + integral of a`` per segment."""
        key = (tau, offset, *ripple, *torque)
        if self._instrument == key:
            return
        same_sensor = self._instrument[:2] == (tau, offset)
        self._instrument = key
        if same_sensor:  # only the model's drive ripple or torque offset changed
            self._fit_drive(tau, offset, ripple, torque, place=False)
            return
        rec = self.record
        if tau > 0.0:
            self._w_start = self._stuck_speed_through_lag(tau) - offset
        else:
            self._w_start = self._speed_start - offset
        w1 = np.full(rec.time.size, np.nan)
        acc = rec.angular_acceleration
        for k, (a, b) in enumerate(zip(self.segments.start, self.segments.stop, strict=True)):
            inc = 0.5 * (acc[a + 1 : b] + acc[a : b - 1]) * rec.dt
            w1[a] = self._w_start[k]
            w1[a + 1 : b] = self._w_start[k] + np.cumsum(inc)
        self._meas['chamber_speed'] = w1
        self._fit_drive(tau, offset, ripple, torque)

    def _sliding_states(
        self, p: FloatArray, sel: npt.NDArray[np.bool_], m_true: FloatArray
    ) -> FloatArray:
        """Kernel states at sliding segment starts, all from the measured channels:
        ``phi1 = M_t/C1``, the chamber speed ``w1 = (dM_t/dt)/C1`` (Equ. 4), the shaft
        speed w2 (speed channel, sensor inverted) and its slope, and the friction
        moment from the chamber's balance ``M = I1*w1' - Q1`` (Equ. 1, the measured
        acceleration); the belt deflection then follows from the shaft's (Equ. 2)."""
        from scipy.signal import savgol_filter

        rig_c1 = float(p[kn.P_C1])
        rec = self.record
        i0 = self.segments.start[sel]
        # a sliding state's chamber speed sets the amplitude of the contact's lightly
        # damped oscillation for the whole segment: a local cubic over 5 ms (not
        # 1.5 ms) keeps its noise at ~4e-3 rad/s (config/rig.yaml noise)
        win = min(_SLIDE_WIN, rec.time.size - (1 - rec.time.size % 2))
        w1 = savgol_filter(rec.torsion_moment, win, 3, deriv=1, delta=rec.dt)[i0] / rig_c1
        a1 = window_mean(rec.angular_acceleration, i0, _SLIDE_WIN // 2)
        moment = np.empty(w1.size)
        for k in range(w1.size):
            q1 = kn.chamber_moment(p, float(m_true[k]) / rig_c1, float(w1[k]))
            moment[k] = float(p[kn.P_I1]) * float(a1[k]) - q1
        dk = self._knots
        w2_dot = self._speed_slope[self.segments.start[sel]]
        t0 = self._t0[sel]
        w2 = self._w_start[sel]
        return np.asarray(sliding_states(p, t0, m_true, w1, w2, w2_dot, moment, dk.time, dk.speed))

    def _stuck_speed_through_lag(self, tau: float) -> FloatArray:
        """Shaft speed [rad/s] at the segment starts behind a first-order speed sensor
        of lag ``tau`` [s] (offset not removed). Inverting ``w = y + tau*y'`` pointwise
        multiplies the speed noise by ``tau`` over the derivative's window (x10 at
        5 ms); instead the whole stick phase is used: while stuck, ``w = w_s + A(t)``
        with ``A`` the integrated measured acceleration, so the sensor shows
        ``y = w_s + lag(A) + d*exp(-(t - t_s)/tau)`` (the filter's memory of the slip
        before), a linear regression in ``w_s`` and ``d`` over the phase."""
        rec = self.record
        seg = self.segments
        dt = rec.dt
        acc = rec.angular_acceleration
        fallback = self._speed_start + tau * self._speed_slope[seg.start]
        if seg.run_start is None or seg.run_stop is None:
            return fallback
        out = fallback.copy()
        alpha = math.exp(-dt / tau)
        c_hold = (1.0 - alpha) * tau / dt
        for k, (i, ra, rb) in enumerate(zip(seg.start, seg.run_start, seg.run_stop, strict=True)):
            lo = int(ra) + CHAMBER_HALF
            hi = int(rb) - CHAMBER_HALF
            if hi - lo < 10 or not lo <= int(i) < hi:
                continue
            a = acc[lo:hi]
            big_a = np.concatenate(([0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)))
            lag_a = np.empty(big_a.size)
            zero = np.zeros(1, np.int64)
            lag_segments(big_a, zero, zero + big_a.size, np.zeros(1), alpha, lag_a, c_hold)
            z = rec.speed[lo:hi] - lag_a
            x = np.column_stack((np.ones(z.size), alpha ** np.arange(z.size)))
            try:
                coef, *_ = np.linalg.lstsq(x, z, rcond=None)
            except np.linalg.LinAlgError:
                continue
            out[k] = float(coef[0]) + float(big_a[int(i) - lo])
        return out

    def _fit_drive(
        self,
        tau: float,
        offset: float,
        ripple: tuple[float, float, float],
        torque: tuple[float, float],
        *,
        place: bool = True,
    ) -> None:
        """The drive profile from the drive angles at the stick samples, with the
        speed sensor inverted, the model's torque offset and drift [N m, N m/s] taken
        off the torsion moment and the model's drive-speed ripple (its angle) taken out.
        ``place``: search the profile's corner times (else keep the last ones)."""
        rec = self.record
        if self.segments.sliding:  # no stick samples: the smoothed shaft speed alone
            self.drive_estimate = self._drive_speed0
            self._knots = DriveKnots.from_estimate(self.drive_estimate)
            return
        # drive angle while stuck = shaft angle (integral of the speed channel, less
        # the offset; a lag shifts it by -tau*(y(t) - y(t_first))) - belt deflection
        # (Equ. 2 with the stuck balance); the drive profile is fitted to these angles
        rig = self.rig
        j = self._stick_samples
        y = self._smooth_speed[j]
        w = y - offset + tau * self._speed_slope[j]
        t = rec.time[j]
        q1 = -rig.K1 * w - (self._smooth_torque[j] - torque[0] - torque[1] * t)
        q2 = (rig.I1 + rig.I2) * self._smooth_accel[j] - q1
        phi2 = (
            self._shaft_angle[j]
            - offset * (t - rec.time[0])
            + tau * (y - float(self._smooth_speed[0]))
        )
        amp, freq, phase = ripple
        ripple_angle = np.zeros_like(t)
        if amp != 0.0 and freq > 0.0:  # the ripple's angle (kernel.drive_angle)
            om = 2.0 * math.pi * freq
            ripple_angle = amp / om * (math.cos(phase) - np.cos(om * t + phase))
        hints = np.array([0.0, self.drive.ramp_time]) if self.drive.ramp_time > 0 else None
        # the damping term K2*(w - w0) needs w0: the smoothed speed first, then once
        # more with the profile from the angles
        drive = self._drive_speed0 if place else self.drive_estimate
        for it in range(2):
            defl = -(q2 + rig.K2 * (w - drive.speed(t))) / rig.C2
            drive = refine_with_angles(
                drive, t, phi2 - defl - ripple_angle, hints, place=place and it == 0,
                start_speed=self._start_speed,
            )  # fmt: skip
        self.drive_estimate = drive
        self._knots = DriveKnots.from_estimate(self.drive_estimate)

    def _speed_sensor(
        self, w2: FloatArray, values: Mapping[str, float], sel: npt.NDArray[np.bool_]
    ) -> FloatArray:
        """The simulated shaft speed w2 [rad/s] as the speed sensor shows it: first-order
        lag ``speed_lag_tau`` [s] (its state at each segment start = the measured
        speed there, less the offset) and zero offset ``speed_offset`` [rad/s]."""
        tau = float(values.get('speed_lag_tau', 0.0))
        off = float(values.get('speed_offset', 0.0))
        if tau <= 0.0 and off == 0.0:
            return w2
        out = w2.copy()
        if tau > 0.0:
            seg = self.segments
            a = math.exp(-self.record.dt / tau)
            lag_segments(
                w2,
                seg.start[sel],
                seg.stop[sel],
                self._speed_start[sel] - off,
                a,
                out,
                (1.0 - a) * tau / self.record.dt,
            )
        return out + off

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
        names = [p.name for p in free]
        # values in ``start`` that are not free (e.g. the instrument model) stay fixed
        fixed_vals = {k: float(v) for k, v in start.items() if k not in names}
        fixed_vals.update(fixed or {})

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
        sol = levenberg_marquardt(
            fun, x0, lo, hi, max_nfev=max_nfev, max_iter=max_nfev, ftol=1e-6, lam0=1e-3
        )
        n = int(np.count_nonzero(self.segments.sample_mask(self.record.time.size, seg_mask)))
        # standard errors from the (last) Jacobian: s^2 (J^T J)^-1, in value units
        se: dict[str, float] = {}
        dof = max(1, sol.fun.size - len(names))
        try:
            cov = np.linalg.inv(sol.jac.T @ sol.jac) * (sol.cost / dof)
            sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        except np.linalg.LinAlgError:
            sd = np.full(len(names), math.nan)
        for p, xi, si in zip(free, sol.x, sd, strict=True):
            se[p.name] = float(math.exp(float(xi)) * si if p.log else si * p.scale)
        return FitOutcome(from_x(sol.x), sol.cost / max(n, 1), sol.nfev, sol.converged, se)
