"""Instrument terms of the discrepancy fit, identified friction-free from the record.

The torsion amplifier's first-order lag (from the chamber kinematics, Equ. 1/4)
and the speed sensor's first-order lag and offset (from the stick phases, where
the shaft speed equals the chamber speed ``(dM_t/dt)/C1``, Equ. 4). Units: SI.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.stats import t as student_t

from tribo_estimation.core.drive import SMOOTH_TIME
from tribo_estimation.core.lsq import cluster_robust_se
from tribo_estimation.core.model import RigParams
from tribo_estimation.core.signal import (
    CHAMBER_HALF,
    chamber_speed,
    lag2_segments,
    lag_segments,
    local_slope,
    rig_half,
    running_integral,
    second_order_filter,
    second_order_lag,
)
from tribo_estimation.core.sticks import (
    MAX_TORSION_LAG,
    TORSION_LAG_SHAPES,
    chamber_speed_integral,
    drive_speed_level,
    fit_torsion_lag,
    kinematic_half,
    kinematic_pair,
    speed_mismatch,
    torsion_lag_compensated,
)

from ..stats import FloatArray, IntArray
from .records import SPEED_LAG, Record, Segments
from .segments import stick_runs


def speed_slope(speed: FloatArray, dt: float, rig: RigParams) -> FloatArray:
    """Return the slope y' of the speed channel (local cubic over 4*7+1 samples).

    With a first-order sensor lag tau the shaft speed is ``w = y + tau*y'``. The
    window is shortened to a quarter period of the rig's fastest mode
    (:func:`tribo_estimation.core.signal.rig_half`).

    Parameters
    ----------
    speed : FloatArray
        Measured speed channel y [rad/s].
    dt : float
        Sample interval [s].
    rig : RigParams
        Rig parameters (its fastest mode bounds the window).

    Returns
    -------
    FloatArray
        y' [rad/s^2] (zeros for a channel shorter than the window).
    """
    half = rig_half(2 * CHAMBER_HALF, 1.0 / dt, rig.fastest_mode_hz)
    return local_slope(speed, dt, 2 * half + 1, order=3)


def rig_chamber_speed(record: Record, rig: RigParams) -> FloatArray:
    """Return the chamber speed ``w1 = (dM_t/dt)/C1`` [rad/s] over a rig-bounded window.

    :func:`tribo_estimation.core.signal.chamber_speed` over ``2*CHAMBER_HALF + 1``
    samples, shortened to a quarter period of the rig's fastest mode
    (:func:`tribo_estimation.core.signal.rig_half`).

    Parameters
    ----------
    record : Record
        The measured record (torsion moment [N m]).
    rig : RigParams
        Rig parameters (C1; its fastest mode bounds the window).

    Returns
    -------
    FloatArray
        w1 [rad/s].
    """
    half = rig_half(CHAMBER_HALF, record.fs, rig.fastest_mode_hz)
    return chamber_speed(record.torsion_moment, record.fs, rig.C1, 2 * half + 1)


def stick_guard(record: Record, rig: RigParams) -> int:
    """Return the samples left out at each end of a stick phase by the sensor checks [-].

    ``CHAMBER_HALF + 3`` (the chamber speed's window stays inside the phase, with
    a margin), shortened like the windows (:func:`tribo_estimation.core.signal.rig_half`).

    Parameters
    ----------
    record : Record
        The measured record (its sample rate).
    rig : RigParams
        Rig parameters (its fastest mode).

    Returns
    -------
    int
        The guard [samples].
    """
    return rig_half(CHAMBER_HALF + 3, record.fs, rig.fastest_mode_hz, least=1)


#: Fewest stick phases that calibrate the speed channel (:func:`speed_error_at_sticks`).
_CALIBRATING_PHASES = 8


def speed_error_at_sticks(
    record: Record,
    rig: RigParams,
    runs: tuple[IntArray, IntArray] | None,
    tau: float = 0.0,
    slope: FloatArray | None = None,
) -> FloatArray:
    """Return the speed channel's slowly varying error seen at the stick phases [rad/s].

    While the discs stick the shaft speed is the chamber's, ``w = (dM_t/dt)/C1``
    (Equ. 4), which carries none of the speed sensor's errors, so the mean of
    ``y + tau*y' - w`` (a first-order lag ``tau`` inverted) over a phase's interior
    is the sensor's error there: its offset, the coloured part of its noise (a
    tachometer's drift), the white part's mean; less their mean, or a straight line in
    the phases' speed where it spreads as for the regression's gain (the sensor
    model's offset and gain, identified elsewhere). The errors are
    smoothed by a centred moving average over the phases within a half-width of time
    chosen by leave-one-out cross-validation with the one-standard-error rule (the
    widest window whose error is within one standard error of the least: from
    :data:`~tribo_estimation.core.drive.SMOOTH_TIME`, the drive profile's own
    resolution, doubling to the whole record; an error that does not vary, an
    offset or white noise, chooses the whole record, and nothing is left to
    correct), less their mean (the offset belongs to the sensor model), and
    interpolated linearly between the phases' centres (held beyond them). Integrated,
    the channel's coloured noise is a drift of the shaft angle that the drive angles
    of Equ. 2 (:meth:`.Problem._angle_drive`) would otherwise carry: at a slow drive
    a pink 0.008 rad/s is 2 % of the speed, and the belt makes it a moment of 1 N m
    per stick.

    Parameters
    ----------
    record : Record
        The record (torsion moment [N m], speed [rad/s]).
    rig : RigParams
        Rig parameters (C1, the fastest mode).
    runs : tuple of (IntArray, IntArray) or None
        First and stop sample of each stick phase (None: none).
    tau : float
        The speed sensor's first-order lag [s].
    slope : FloatArray, optional
        The speed channel's slope ``y'`` (default: :func:`speed_slope`) [rad/s^2].

    Returns
    -------
    FloatArray
        The error to take off the speed channel [rad/s] (zeros with fewer than
        :data:`_CALIBRATING_PHASES` phases).
    """
    n = record.time.size
    if runs is None:
        return np.zeros(n)
    guard = stick_guard(record, rig)
    w = rig_chamber_speed(record, rig)
    y = record.speed
    if tau > 0.0:
        y = y + tau * (speed_slope(y, record.dt, rig) if slope is None else slope)
    centres: list[float] = []
    errors: list[float] = []
    speeds: list[float] = []
    for a, b in zip(*runs, strict=True):
        if b - a > 2 * guard + 2:
            j = slice(int(a) + guard, int(b) - guard)
            centres.append(float(np.mean(record.time[j])))
            errors.append(float(np.mean(y[j] - w[j])))
            speeds.append(float(np.mean(w[j])))
    m = len(errors)
    if m < _CALIBRATING_PHASES:
        return np.zeros(n)
    # the sensor model's own terms out: its offset and, where the phases' speeds spread
    # (a speed step or sweep tells a gain from a drift), its gain error (linear in the
    # phases' speed; the gain is identified by the model, not calibrated away here)
    v = np.asarray(speeds)
    spread = _speeds_spread(v, float(np.mean(v)))
    design = np.column_stack((np.ones(m), v)) if spread else np.ones((m, 1))
    coef = np.linalg.lstsq(design, np.asarray(errors), rcond=None)[0]
    e = np.asarray(errors) - design @ coef
    c = np.concatenate(([0.0], np.cumsum(e)))
    tc = np.asarray(centres)
    trials: list[tuple[float, float, FloatArray]] = []  # (cv, its standard error, smooth)
    half = SMOOTH_TIME
    while True:
        lo = np.searchsorted(tc, tc - half, side='left')
        hi = np.searchsorted(tc, tc + half, side='right')
        total, count = c[hi] - c[lo], hi - lo
        ok = count > 1
        if ok.any():  # a window that holds only its own phase predicts nothing
            sq = (e[ok] - (total[ok] - e[ok]) / (count[ok] - 1)) ** 2
            trials.append((float(np.mean(sq)), float(np.std(sq)) / math.sqrt(m), total / count))
        if half >= tc[-1] - tc[0]:
            break
        half *= 2.0
    trials = [x for x in trials if math.isfinite(x[0])]
    if not trials:
        return np.zeros(n)
    least = min(trials, key=lambda x: x[0])
    smooth = next(x[2] for x in reversed(trials) if x[0] <= least[0] + least[1])
    return np.interp(record.time, tc, smooth - float(np.mean(smooth)))


#: Length of the record pieces the torsion lag is estimated on [s] (the spread of
#: the pieces' estimates gives its standard error) and the window of the local
#: mean that fixes the compensation's constant and drift [s].
_TQ_LAG_PIECE = 1.0
_TQ_LAG_MEAN_WIN = 0.005
#: Largest accelerometer lag behind the torsion moment that is identified [s] (an
#: accelerometer's bandwidth is a kilohertz or more; its lag a fraction of a ms).
MAX_ACCEL_LAG = 1e-3


@dataclass(frozen=True)
class TorsionLag:
    """Identified lag of the torsion amplifier, first or second order.

    Parameters
    ----------
    tau : float
        The lag of the torsion channel relative to the accelerometer [s] (its
        first-order coefficient ``a1``; NaN: not estimated); negative: the
        accelerometer lags the torsion moment by ``-tau``.
    se : float
        Its standard error [s] (spread of the estimates on the record pieces).
    n : int
        Number of record pieces estimated on.
    used : float
        The lag compensated [s] (0 = none; negative: the accelerometer's).
    shape : float
        The second order's shape ``q = a2/tau**2`` [-] (0: first order;
        ``1/(4*zeta**2)`` of a damping ratio zeta).
    shape_se : float
        Its standard error [-].
    shape_used : float
        The shape compensated [-] (0: first order).
    """

    tau: float
    se: float
    n: int
    used: float
    shape: float = 0.0
    shape_se: float = math.nan
    shape_used: float = 0.0

    @property
    def a2(self) -> float:
        """The compensated second-order coefficient ``a2 = q*tau**2`` [s^2]."""
        return self.shape_used * self.used * self.used if self.used > 0.0 else 0.0

    def report(self) -> dict[str, float | int | str]:
        """Return the ``instrument`` entry of discrepancy.json.

        Returns
        -------
        dict
            ``value`` [s], ``se`` [s], ``unit``, ``used`` [s], ``pieces`` and the
            second order's ``shape``, ``shape_se`` and ``shape_used`` [-].
        """
        return {
            'value': self.tau, 'se': self.se, 'unit': 's', 'used': self.used,
            'pieces': self.n, 'shape': self.shape, 'shape_se': self.shape_se,
            'shape_used': self.shape_used,
        }  # fmt: skip


def _median_se(arr: FloatArray) -> tuple[float, float]:
    """Return the median of piece estimates and its standard error.

    ``1.2533*sd/sqrt(n)`` (the median's efficiency under normal scatter), the pieces'
    standard deviation: with the handful of pieces a record has, their median absolute
    deviation can come out near zero by chance (on 40 records without a lag it called
    2 of them significant at ``alpha`` = 0.01; the standard deviation none). The
    pieces without kinematics are censored before (:func:`identify_torsion_lag`).
    """
    med = float(np.median(arr))
    se = float(1.2533 * np.std(arr, ddof=1) / math.sqrt(arr.size)) if arr.size > 1 else math.nan
    return med, se


def identify_torsion_lag(
    record: Record, rig: RigParams, *, enabled: bool = True, alpha: float = 0.01
) -> TorsionLag:
    """Identify the torsion amplifier's lag from the record, friction-free.

    :func:`sticks.fit_torsion_lag` (chamber kinematics ``M_t = C1*phi1``,
    ``phi1'' = a``, Equ. 1/4) on pieces of ~1 s, first order (the accelerometer's lag
    below zero; a piece's estimate at an end of the range is censored, no
    estimate, while any piece's lies inside); a lag of the amplifier that is used is
    then searched over the shapes
    of a second order (:data:`sticks.TORSION_LAG_SHAPES`). The medians are the lag and
    its shape, the pieces' spread their standard errors (:func:`_median_se`); a shape within
    3 standard errors of 0 leaves the first-order lag. Used
    (compensated) when the median is significant, beyond the two-sided ``alpha``
    quantile of Student's t law with one degree of freedom fewer than the pieces
    times its standard error (no lag: the pieces' estimates scatter about 0), and
    inside the estimator's range (an estimate at the range's end, 3 ms, is left to
    the workflow's ``torque_sensor_lag`` candidate); a fraction of a sample counts
    at a low sample rate.

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (C1, Tab. 1).
    enabled : bool
        False: estimate nothing (NaN lag, none used).
    alpha : float
        Probability of using a lag where there is none [-].

    Returns
    -------
    TorsionLag
        The estimate, its standard error and the lag to compensate.
    """
    if not enabled:
        return TorsionLag(math.nan, math.nan, 0, 0.0)
    fs = record.fs
    n = record.time.size
    # ~1 s pieces; at least 4 (of >= 0.2 s) on a shorter record for the spread
    m = max(1, int(n // round(_TQ_LAG_PIECE * fs)), min(4, int(n // round(0.2 * fs))))
    edges = np.linspace(0, n, m + 1).astype(int)
    pieces = list(itertools.pairwise(edges.tolist()))

    def each(shapes: tuple[float, ...]) -> tuple[FloatArray, FloatArray]:
        taus: list[float] = []
        qs: list[float] = []
        for a, b in pieces:
            try:
                tau, q = fit_torsion_lag(
                    record.torsion_moment[a:b], record.angular_acceleration[a:b], fs,
                    rig.C1, rig.fastest_mode_hz, min_lag=-MAX_ACCEL_LAG, shapes=shapes,
                )  # fmt: skip
            except (ValueError, np.linalg.LinAlgError):
                continue
            if math.isfinite(tau):
                taus.append(tau)
                qs.append(q)
        t_arr, q_arr = np.asarray(taus), np.asarray(qs)
        # a piece whose estimate sits at an end of the range found no minimum inside it
        # (a piece at rest, without the kinematics): censored, not an estimate, unless
        # every piece ends there (a lag beyond the range)
        inside = (t_arr > -0.98 * MAX_ACCEL_LAG) & (t_arr < 0.98 * MAX_TORSION_LAG)
        if inside.any():
            t_arr, q_arr = t_arr[inside], q_arr[inside]
        return t_arr, q_arr

    def used(tau: float, se: float, n: int) -> float:
        ok = (
            -0.98 * MAX_ACCEL_LAG < tau < 0.98 * MAX_TORSION_LAG
            and n > 1
            and math.isfinite(se)
            and abs(tau) > float(student_t.ppf(1.0 - 0.5 * alpha, n - 1)) * se
        )
        return tau if ok else 0.0

    taus, _ = each((0.0,))
    if taus.size == 0:
        return TorsionLag(math.nan, math.nan, 0, 0.0)
    tau, se = _median_se(taus)
    first = TorsionLag(tau, se, taus.size, used(tau, se, taus.size))
    if not first.used > 0.0:
        return first  # no lag of the amplifier's own to give a shape to
    taus, qs = each(TORSION_LAG_SHAPES)
    if taus.size == 0:
        return first
    q, q_se = _median_se(qs)
    if not (q > 0.0 and math.isfinite(q_se) and q > 3.0 * q_se):
        return replace(first, shape=q, shape_se=q_se)
    tau, se = _median_se(taus)
    lag = used(tau, se, taus.size)
    return TorsionLag(tau, se, taus.size, lag, q, q_se, q if lag > 0.0 else 0.0)


def torsion_compensated_record(
    record: Record, rig: RigParams, tau: float, *, a2: float = 0.0
) -> Record:
    """Return the record with the torsion amplifier's lag taken out.

    :func:`sticks.torsion_lag_compensated` is exact: ``M_t = y + tau*C1*lag(w1)``
    (Equ. 4). The integrated acceleration gives ``w1`` up to a constant and a
    drift (the trapezoid's error at the acceleration's jumps); the correction's
    local mean (5 ms: shorter than the stick and slip phases between the jumps)
    is therefore replaced by its true value, the local mean of ``tau*y'`` (a
    difference quotient of the measured ``y``: noise ~0.015 N m for a 1 ms lag
    at config/rig.yaml). A second-order amplifier (``a2`` > 0) adds
    ``a2*y'' = a2*C1*lag(a)``, which the measured acceleration gives without a
    constant.

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (C1, Tab. 1).
    tau : float
        Lag to take out [s] (its first-order coefficient; 0: the record unchanged;
        negative: the accelerometer's lag ``-tau``, inverted on the acceleration).
    a2 : float
        The amplifier's second-order coefficient [s^2] (0: first order).

    Returns
    -------
    Record
        The record with the compensated torsion moment [N m].
    """
    if tau < 0.0:
        # the accelerometer's lag inverted: a = a_meas + |tau|*a_meas'
        acc = record.angular_acceleration
        return replace(
            record, angular_acceleration=np.asarray(acc - tau * np.gradient(acc, record.dt))
        )
    if tau == 0.0:
        return record
    fs = record.fs
    dt = record.dt
    y = record.torsion_moment
    acc = record.angular_acceleration
    w = chamber_speed_integral(acc, dt)
    corr = torsion_lag_compensated(y, w, dt, tau, rig.C1, a2=a2) - y
    # the second-order term a2*C1*lag(a) carries no integration constant: kept whole
    known = a2 * rig.C1 * second_order_filter(acc, dt, tau, a2) if a2 > 0.0 else 0.0
    n = y.size
    # the mean's window stays shorter than the stick and slip phases between the
    # jumps: at most a quarter period of the rig's fastest mode
    h = rig_half(round(0.5 * _TQ_LAG_MEAN_WIN * fs), fs, rig.fastest_mode_hz, least=1)
    h = max(1, min(n // 2, h))
    i = np.arange(n)
    lo = np.maximum(0, i - h)
    hi = np.minimum(n - 1, i + h)
    mean_slope = (y[hi] - y[lo]) / ((hi - lo) * dt)  # local mean of y' [N m/s]
    corr = corr - drive_speed_level(corr, fs, 2 * h / fs) + tau * mean_slope + known
    return replace(record, torsion_moment=np.asarray(y + corr, dtype=np.float64))


@dataclass(frozen=True)
class SpeedSensor:
    """Identified speed-sensor model.

    Parameters
    ----------
    tau : float
        First-order lag [s].
    tau_se : float
        Its standard error [s].
    offset : float
        Zero offset [rad/s].
    offset_se : float
        Its standard error [rad/s].
    n : int
        Number of stick samples used.
    drift : float
        How far the speed channel and the stick phases' chamber speed drift apart
        over the record, relative to the mean stick speed [-] (NaN: not estimated).
    drift_se : float
        Its standard error [-].
    gain : float
        The speed channel's gain relative to the chamber speed from the torsion
        moment [-] (1: not identified, the sticks all at one speed).
    gain_se : float
        Its standard error [-].
    gain_rejected : float
        A gain the regression gave beyond :data:`SPEED_GAIN_BOUND` of 1 [-]: not
        used (NaN: none).
    tau_raw : float
        The regression's lag before it is limited to [0, 20 ms] [s] (NaN: none).
    offset_rejected : float
        An offset the regression gave beyond :data:`SPEED_OFFSET_BOUND` of the
        record's peak speed [rad/s]: not used (NaN: none).
    """

    tau: float
    tau_se: float
    offset: float
    offset_se: float
    n: int
    drift: float = math.nan
    drift_se: float = math.nan
    gain: float = 1.0
    gain_se: float = math.nan
    gain_rejected: float = math.nan
    tau_raw: float = math.nan
    offset_rejected: float = math.nan

    def identified(self) -> bool:
        """Tell whether the stick phases gave the regression anything to estimate.

        Stick phases shorter than twice the guard (:func:`stick_guard`) leave no
        samples, and without samples the lag has no standard error: the sensor is
        then unknown, not free of a lag and an offset.

        Returns
        -------
        bool
            True if the lag has a finite standard error.
        """
        return math.isfinite(self.tau_se)

    def consistent(self) -> bool:
        """Tell whether the regression's sensor model holds on the stick phases.

        It does not when the regression had nothing to estimate on
        (:meth:`identified`), when its lag is more than 3 standard errors below zero
        (no sensor's: the phases are not described by ``y = w - tau*y' + offset``, a
        sensor slower than the stick phases, whose output there still carries the
        slip before, or an uncompensated torsion lag) or when its gain or offset lies
        beyond :data:`SPEED_GAIN_BOUND` or :data:`SPEED_OFFSET_BOUND` (no
        tachometer's calibration: the same misfit, typically on sticks of a few ms
        behind a lag of as many). Its lag and offset are then no estimates either.

        Returns
        -------
        bool
            False if the regression's model does not hold.
        """
        if not self.within_bounds():
            return False
        return not self.tau_raw < -3.0 * self.tau_se

    def within_bounds(self) -> bool:
        """Tell whether the sticks identified a sensor within its physical bounds.

        Stick samples there, and neither the gain nor the offset beyond
        :data:`SPEED_GAIN_BOUND` or :data:`SPEED_OFFSET_BOUND`: the phases' speed errors
        are then the sensor's (:func:`speed_error_at_sticks`). A lag a few
        microseconds below zero (:meth:`consistent`) leaves them so.

        Returns
        -------
        bool
            True if the sensor is identified within its bounds.
        """
        return self.identified() and (
            math.isnan(self.gain_rejected) and math.isnan(self.offset_rejected)
        )

    def drifting(self) -> bool:
        """Tell whether the stick-phase kinematics drift during the record.

        True when :attr:`drift` exceeds :data:`MAX_MISMATCH_DRIFT` and
        :data:`DRIFT_Z` standard errors. While the discs stick ``w2 = w1`` whatever
        the friction, so no friction effect can cause it: the torsion element's
        stiffness C1 (``w1 = (dM_t/dt)/C1``) or a sensor gain changes, a mismatch of
        the rig or the instrument, not missing friction physics.

        Returns
        -------
        bool
            True if the record's stick phases drift.
        """
        return (
            math.isfinite(self.drift)
            and math.isfinite(self.drift_se)
            and abs(self.drift) > MAX_MISMATCH_DRIFT
            and abs(self.drift) > DRIFT_Z * self.drift_se
        )

    def drift_report(self) -> dict[str, object]:
        """Return the ``speed_mismatch_drift`` entry of ``discrepancy.json``.

        Returns
        -------
        dict
            ``value`` and ``se`` [-], ``unit``, ``limit`` [-] and ``drifting``.
        """
        return {
            'value': self.drift,
            'se': self.drift_se,
            'unit': '-',
            'limit': MAX_MISMATCH_DRIFT,
            'drifting': self.drifting(),
        }

    def values(self) -> dict[str, float]:
        """Return the sensor as model values (:data:`.records.INSTRUMENT_FIELDS`).

        A value within 3 standard errors of zero is not used (0): the model is
        very sensitive to a wrong speed offset (it shifts the drive speed), so
        noise must not enter it; nor is an offset beyond the physical bound.

        Returns
        -------
        dict of str to float
            ``speed_lag_tau`` [s] and ``speed_offset`` [rad/s].
        """

        def significant(v: float, se: float) -> float:
            return v if math.isfinite(se) and abs(v) > 3.0 * se else 0.0

        return {
            'speed_lag_tau': significant(self.tau, self.tau_se),
            'speed_offset': (
                significant(self.offset, self.offset_se)
                if math.isnan(self.offset_rejected)
                else 0.0
            ),
        }


#: Largest drift apart of the speed channel and the stick phases' chamber speed over
#: a record, relative to the mean stick speed [-], and the standard errors it must
#: also exceed [-] to count (:meth:`SpeedSensor.drifting`). Records without such a
#: drift stay within 0.7 % on the benchmark matrix (speed step, start-up, 5 ms lag,
#: noise x3) and reach 0.96 % (6 SE) on a 6 s record with a speed step behind a 5 ms
#: lag, a thin margin; a 2 % stiffness drift shows 1.3-2.3 % at 14-55 SE.
MAX_MISMATCH_DRIFT = 0.01
DRIFT_Z = 5.0
#: Largest error of a speed channel's gain that is identified [-]: a tachometer's
#: calibration is within a few percent (docs/physics.md section 9); a regression over
#: the stick phases that gives more says its sensor model (lag and offset) does not
#: hold there, and the gain is not used.
SPEED_GAIN_BOUND = 0.1
#: Largest zero offset of a speed channel that is identified, relative to the
#: record's peak speed (99th percentile of |speed|, a lower bound of the channel's full
#: scale) [-]: a tachometer's zero is calibrated to a fraction of its range, as its gain
#: is; a regression that gives more says its sensor model does not hold on the stick
#: phases (docs/physics.md section 9), and the offset is not used.
SPEED_OFFSET_BOUND = 0.1
#: Spread of the stick phases' mean speeds (p90 - p10 over the mean) [-] above which
#: a sensor gain is fitted with the drift (a speed step tells a gain from a drift).
_GAIN_SPREAD = 0.2


def _speeds_spread(per_phase: FloatArray, mean: float) -> bool:
    """Tell whether the stick phases' mean speeds [rad/s] spread beyond :data:`_GAIN_SPREAD`.

    Their 10th to 90th percentile over ``|mean|`` [rad/s]: a speed step or sweep, which
    tells a sensor gain from a drift or an offset.
    """
    lo, hi = np.percentile(per_phase, (10.0, 90.0))
    return bool((hi - lo) > _GAIN_SPREAD * abs(mean))


def speed_offset_bound(record: Record) -> float:
    """Return the largest speed-channel zero offset a tachometer can have here [rad/s].

    :data:`SPEED_OFFSET_BOUND` of the record's peak speed, the 99th percentile of
    ``|speed|`` (the channel's range covers at least the speeds it shows). A physical
    bound on the regression's offset and on every fit's (docs/physics.md section 9).

    Parameters
    ----------
    record : Record
        The record (speed [rad/s]).

    Returns
    -------
    float
        The bound [rad/s].
    """
    return SPEED_OFFSET_BOUND * float(np.percentile(np.abs(record.speed), 99.0))


def _cluster_lstsq(
    X: FloatArray, d: FloatArray, cluster: IntArray
) -> tuple[FloatArray, FloatArray] | None:
    """Least squares ``d ~ X``, standard errors cluster-robust over ``cluster``.

    :func:`tribo_estimation.core.lsq.cluster_robust_se` over the stick phases.
    Returns the coefficients and their standard errors (None if X is rank-deficient).
    """
    coef, _, rank, _ = np.linalg.lstsq(X, d, rcond=None)
    if rank < X.shape[1]:
        return None
    _, g = np.unique(cluster, return_inverse=True)
    se = cluster_robust_se(X, d - X @ coef, g.astype(np.int64))
    return np.asarray(coef, dtype=np.float64), se


def _mismatch_drift(
    t: FloatArray, w: FloatArray, base: FloatArray, d: FloatArray, cluster: IntArray
) -> tuple[float, float]:
    """Drift of ``d = y - w`` over the stick samples, relative to the mean stick speed.

    The sensor regression's columns ``base`` plus the time (scaled to the record's
    span) and, when the sticks are at several speeds, a gain column ``w - mean(w)``.
    Returns the drift over the span / ``|mean(w)|`` and its standard error [-].
    """
    span = float(t.max() - t.min())
    w_mean = float(np.mean(w))
    if span <= 0.0 or w_mean == 0.0:
        return math.nan, math.nan
    cols = [base, (t - float(np.mean(t))) / span]
    _, first = np.unique(cluster, return_index=True)
    per_stick = np.asarray([float(np.mean(x)) for x in np.split(w, first[1:])])
    if _speeds_spread(per_stick, w_mean):
        cols.append((w - w_mean)[:, None])
    fit = _cluster_lstsq(np.column_stack(cols), d, cluster)
    if fit is None:
        return math.nan, math.nan
    coef, se = fit
    k = base.shape[1]
    return float(coef[k]) / abs(w_mean), float(se[k]) / abs(w_mean)


def identify_speed_sensor(
    record: Record, rig: RigParams, runs: tuple[IntArray, IntArray] | None = None
) -> SpeedSensor:
    """Identify the speed-sensor lag and offset from the stick phases, friction-free.

    While the discs stick, the shaft speed equals the chamber speed
    ``w = (dM_t/dt)/C1`` (Equ. 4; from the torsion moment, which carries neither
    of the speed sensor's errors). A first-order sensor shows ``y`` with
    ``w = y + tau*y'`` (``y'`` from a local cubic through the speed channel), so
    ``y - w = offset - tau*y'``: a linear regression over the stick samples
    (10 samples from each end of a phase left out) gives both; standard errors
    are cluster-robust over the stick phases. ``tau`` is limited to [0, 20 ms].
    The same regression with a time column (and a gain column when the sticks are
    at several speeds) gives the drift of ``y - w`` over the record
    (:meth:`SpeedSensor.drifting`).

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (C1, Tab. 1).
    runs : tuple of (IntArray, IntArray), optional
        First and stop sample of each stick phase (default: :func:`.segments.stick_runs`).

    Returns
    -------
    SpeedSensor
        Lag [s] and offset [rad/s] with standard errors.
    """
    if runs is None:
        a0, b0, _ = stick_runs(record, rig)
    else:
        a0, b0 = runs
    w = rig_chamber_speed(record, rig)
    # y' from the speed channel itself (during a stick it follows w' through the lag,
    # and before it the shaft's own acceleration)
    acc = speed_slope(record.speed, record.dt, rig)
    guard = stick_guard(record, rig)
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
    gain, gain_se, rejected = 1.0, math.nan, math.nan
    # y = g*lag(w) + b: regressed as w = (y - b)/g + (tau/g)*y' (the speed channel is the
    # regressor: its noise is far below that of w from the torsion moment's slope); the
    # gain is used where 1/g is beyond 3 standard errors from 1 (sticks all at one speed
    # make it collinear with the offset: a large error) and within the physical bound
    fit_g = _cluster_lstsq(
        np.column_stack((np.ones(idx.size), record.speed[idx], acc[idx])), w[idx], cl
    )
    if fit_g is not None:
        inv, inv_se = float(fit_g[0][1]), float(fit_g[1][1])
        if math.isfinite(inv_se) and abs(inv - 1.0) > 3.0 * inv_se and inv > 0.0:
            if abs(1.0 / inv - 1.0) <= SPEED_GAIN_BOUND:
                gain, gain_se = 1.0 / inv, inv_se / (inv * inv)
                d = record.speed[idx] / gain - w[idx]
                X = np.column_stack((np.ones(idx.size), -acc[idx] / gain))
            else:
                rejected = 1.0 / inv
    fit = _cluster_lstsq(X, d, cl)
    if fit is None:
        return SpeedSensor(0.0, math.nan, 0.0, math.nan, int(idx.size))
    coef, se = fit
    tau = min(max(float(coef[1]), 0.0), SPEED_LAG.upper)
    drift, drift_se = _mismatch_drift(record.time[idx], w[idx], X, d, cl)
    off_rejected = float(coef[0]) if abs(coef[0]) > speed_offset_bound(record) else math.nan
    return SpeedSensor(
        tau, float(se[1]), float(coef[0]), float(se[0]), int(idx.size), drift, drift_se,
        gain, gain_se, rejected, float(coef[1]), off_rejected,
    )  # fmt: skip


@dataclass(frozen=True)
class AccelSensor:
    """The accelerometer's gain and offset relative to the torsion moment's kinematics.

    Parameters
    ----------
    gain : float
        Gain [-] (1: not significant).
    gain_se : float
        Its standard error [-].
    offset : float
        Zero offset [rad/s^2].
    offset_se : float
        Its standard error [rad/s^2].
    offset_used : bool
        The offset lies beyond 3 standard errors of 0 and is taken out
        (:meth:`correct`).
    """

    gain: float = 1.0
    gain_se: float = math.nan
    offset: float = 0.0
    offset_se: float = math.nan
    offset_used: bool = False

    def correct(self, accel: FloatArray) -> FloatArray:
        """Return the acceleration with the sensor's gain and used offset taken out [rad/s^2]."""
        return (accel - (self.offset if self.offset_used else 0.0)) / self.gain

    @property
    def changes(self) -> bool:
        """Tell whether :meth:`correct` changes the acceleration."""
        return self.gain != 1.0 or self.offset_used

    def report(self) -> dict[str, object]:
        """Return the ``accel_sensor`` entry of ``discrepancy.json``."""
        return {
            'gain': self.gain,
            'gain_se': self.gain_se,
            'offset': self.offset,
            'offset_se': self.offset_se,
            'offset_used': self.offset_used,
            'unit': 'rad/s^2',
        }


#: Length of the windows of the accelerometer's regression [s]: the clusters of its
#: standard errors (each with its own offset term).
ACCEL_WINDOW = 0.2


def _stick_offset(
    d: FloatArray, k_a: FloatArray, gain: float, h: int, n: int,
    sticks: tuple[IntArray, IntArray],
) -> tuple[float, float]:  # fmt: skip
    """Return the accelerometer's offset from the kinematic pair in stick interiors.

    ``K - g*D = b`` sample by sample (:func:`identify_accel_sensor`); inside a stick
    phase both sides are smooth (no switching jump between samples), so their
    difference is the sensor's offset plus noise. Mean over the samples whose pair
    window lies inside a phase, standard error cluster-robust over the phases
    (:func:`_cluster_lstsq`) [rad/s^2] (NaN with fewer than two phases).
    """
    phase = np.full(n, -1, dtype=np.int64)
    for j, (a, b) in enumerate(zip(*sticks, strict=True)):
        if b - 2 * h > a + 2 * h:
            phase[a + 2 * h : b - 2 * h] = j
    phase = phase[h : n - h]
    m = phase >= 0
    if np.unique(phase[m]).size < 2:
        return math.nan, math.nan
    fit = _cluster_lstsq(np.ones((int(m.sum()), 1)), k_a[m] - gain * d[m], phase[m])
    if fit is None:
        return math.nan, math.nan
    return float(fit[0][0]), float(fit[1][0])


def identify_accel_sensor(
    record: Record, rig: RigParams, sticks: tuple[IntArray, IntArray] | None = None
) -> AccelSensor:
    """Identify the accelerometer's gain and offset from the chamber kinematics.

    Stick or slip, ``M_t'' = C1*a`` (Equ. 1: ``M_t = C1*phi1``) and the accelerometer
    shows ``a_meas = g*a + b``. On the pair of :func:`..sticks.kinematic_pair`
    (second difference of the torsion moment ``D``, triangle-weighted mean of the
    measured acceleration ``K``, over a quarter period of the rig's fastest mode)
    ``D = (K - b)/g``: a linear regression of ``D`` on ``K`` (the low-noise
    side as regressor), standard errors cluster-robust over windows of
    :data:`ACCEL_WINDOW`. No integral is carried across stick-slip cycles, so it
    holds at 2 kHz as at 20 kHz. The gain is used where beyond 3 standard errors.
    The regression's intercept is not an offset to use: the switching jumps fall
    between samples the same way in every cycle of a one-way stick-slip, and their
    error has a mean (docs/physics.md). With ``sticks`` the offset is measured inside
    the stick phases instead, where the pair holds without jumps, and used where beyond
    3 standard errors (it integrates into the chamber speed the fits compare, a ramp
    over every segment).

    Parameters
    ----------
    record : Record
        The measured record (torsion lag compensated).
    rig : RigParams
        Rig parameters (C1; its fastest mode).
    sticks : tuple of IntArray or None
        First and stop sample of each stick phase (None: the regression's offset).

    Returns
    -------
    AccelSensor
        The gain and offset.
    """
    fs = record.fs
    h = kinematic_half(fs, rig.fastest_mode_hz)
    d, k_a = kinematic_pair(record.torsion_moment, record.angular_acceleration, fs, rig.C1, h)
    m = max(16, round(ACCEL_WINDOW * fs))
    cluster = (np.arange(d.size) // m).astype(np.int64)
    if d.size < 3 * m:
        return AccelSensor()
    fit = _cluster_lstsq(np.column_stack((k_a, np.ones(d.size))), d, cluster)
    if fit is None:
        return AccelSensor()
    (slope, icpt), (slope_se, icpt_se) = fit
    if not slope > 0.0:
        return AccelSensor()
    g = 1.0 / float(slope)
    g_se = float(slope_se) * g * g
    b = -float(icpt) * g
    b_se = float(icpt_se) * g
    use_g = math.isfinite(g_se) and abs(g - 1.0) > 3.0 * g_se and g > 0.5
    if sticks is None:
        return AccelSensor(g if use_g else 1.0, g_se, b, b_se)
    bs, bs_se = _stick_offset(d, k_a, g, h, record.time.size, sticks)
    if not math.isfinite(bs_se):
        return AccelSensor(g if use_g else 1.0, g_se, b, b_se)
    return AccelSensor(g if use_g else 1.0, g_se, bs, bs_se, abs(bs) > 3.0 * bs_se)


#: Fewest samples of the stick regression of :func:`stuck_sensor_states` (its two or
#: three columns and at least three degrees of freedom left) [-].
_STUCK_FIT_MIN = 6


def stuck_sensor_states(
    record: Record,
    segments: Segments,
    speed_start: FloatArray,
    slope: FloatArray,
    tau: float,
    a2: float = 0.0,
    *,
    guard: int,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Return the shaft speed and the speed sensor's state at the segment starts.

    Inverting ``w = y + tau*y'`` pointwise multiplies the speed noise by ``tau``
    over the derivative's window (x10 at 5 ms); instead the whole stick phase is
    used: while stuck, ``w = w_s + A(t)`` with ``A`` the integrated measured
    acceleration, and the sensor (first order, or ``a2*y'' + tau*y' + y = w``) shows
    ``y = w_s + L(A) + c1*h1 (+ c2*h2)`` with ``L`` its response from rest and ``h1``
    (``h2``) its free response from a unit output (slope): the filter's memory of
    the slip before. A linear regression over the phase gives ``w_s``, and the
    fitted output (and slope) before each start is the sensor's state there, the
    same for either order as ``a2`` goes to 0 (a smoothed slope of the measured
    speed is no second-order state: at a stick onset the sensor still rings).

    Parameters
    ----------
    record : Record
        The measured record.
    segments : Segments
        The segments (their stick phases bound the regression).
    speed_start : FloatArray
        Measured speed at the segment starts (local mean) [rad/s].
    slope : FloatArray
        Slope of the speed channel per sample (:func:`speed_slope`) [rad/s^2].
    tau : float
        First-order coefficient (lag) of the sensor [s], > 0.
    a2 : float
        Second-order coefficient of the sensor [s^2] (0: first order).
    guard : int
        Samples left out at each end of a stick phase, whose detected ends may still
        slip (``CHAMBER_HALF`` shortened to a quarter period of the rig's fastest
        mode by :func:`tribo_estimation.core.signal.rig_half`, as the windows are:
        at 2 kHz a stick phase is often 14 samples long).

    Returns
    -------
    tuple of FloatArray
        Shaft speed at each segment start [rad/s] (sensor offset not removed;
        ``y + tau*y'`` where a stick phase is too short for the regression), the
        sensor's output [rad/s] and slope [rad/s^2] before each start (the measured
        speed and slope at the start where too short).
    """
    seg = segments
    dt = record.dt
    acc = record.angular_acceleration
    w = speed_start + tau * slope[seg.start]
    y0 = speed_start.copy()
    yd0 = slope[seg.start].copy()
    if seg.run_start is None or seg.run_stop is None:
        return w, y0, yd0
    second = a2 > 0.0
    c = second_order_lag(tau, a2, dt) if second else np.zeros(8)
    alpha = math.exp(-dt / tau)
    c_hold = (1.0 - alpha) * tau / dt
    zero = np.zeros(1, np.int64)
    for k, (i, ra, rb) in enumerate(zip(seg.start, seg.run_start, seg.run_stop, strict=True)):
        # regressed over the phase less its ends (the detected onset may still slip),
        # the model running from the start when the start lies before that window
        lo = int(ra) + guard
        hi = int(rb) - guard
        if hi - lo < _STUCK_FIT_MIN or not int(ra) <= int(i) < hi:
            continue
        base = min(int(i), lo)
        a = acc[base:hi]
        big_a = running_integral(a, dt)
        m = big_a.size
        # columns: the response from rest to A, then the free responses from a unit
        # output and (second order) a unit slope before the first sample
        cols = np.zeros((3, m))
        slopes = np.zeros((3, m))
        if second:
            free = np.zeros(m)
            for row, (x, s0, d0) in enumerate(
                ((big_a, 0.0, 0.0), (free, 1.0, 0.0), (free, 0.0, 1.0))
            ):
                lag2_segments(
                    x, zero, zero + m, np.array([s0]), np.array([d0]), c, cols[row], slopes[row]
                )
        else:
            lag_segments(big_a, zero, zero + m, np.zeros(1), alpha, cols[0], c_hold)
            cols[1] = alpha ** np.arange(1, m + 1)
        x_mat = np.column_stack((np.ones(m), cols[1], cols[2]) if second else (np.ones(m), cols[1]))
        fit = slice(lo - base, m)
        try:
            coef, *_ = np.linalg.lstsq(x_mat[fit], record.speed[lo:hi] - cols[0][fit], rcond=None)
        except np.linalg.LinAlgError:
            continue
        c_free = np.append(coef[1:], 0.0)
        j = int(i) - base - 1
        w[k] = float(coef[0]) + float(big_a[j + 1])
        if j < 0:  # the state before the first sample: the free responses' own
            y0[k] = float(coef[0] + c_free[0])
            yd0[k] = float(c_free[1])
        else:
            y0[k] = float(coef[0] + cols[0, j] + c_free[0] * cols[1, j] + c_free[1] * cols[2, j])
            yd0[k] = float(slopes[0, j] + c_free[0] * slopes[1, j] + c_free[1] * slopes[2, j])
    return w, y0, yd0


#: A second-order term ``a2`` below this fraction of dt^2 is the first order [-]: its
#: response differs from the first order's by about 1e-8 of a sample's change, and
#: the matrix exponential of :func:`~tribo_estimation.core.signal.second_order_lag`
#: is accurate to 1e-7 down to 1e-9 dt^2 (below, it loses digits). Kept this low so
#: that a forward-difference step of ``speed_lag_shape`` from 0 (1e-5) reaches the
#: second order for any lag above 0.1 dt.
FIRST_ORDER_A2 = 1e-7


def speed_sensor_output(
    w2: FloatArray,
    segments: Segments,
    sel: npt.NDArray[np.bool_],
    speed_start: FloatArray,
    dt: float,
    values: Mapping[str, float],
    slope_start: FloatArray | None = None,
) -> FloatArray:
    """Pass a simulated shaft speed through the speed sensor.

    Lag ``speed_lag_tau`` [s] (its state before each segment start given, less the
    offset) and zero offset ``speed_offset`` [rad/s]; the lag is the exact form for an
    input linear between samples: first order
    (:func:`tribo_estimation.core.signal.lag_segments`) or, with
    ``speed_lag_shape`` > 0, second order ``a2*y'' + tau*y' + y = w`` with
    ``a2 = speed_lag_shape*tau^2`` (:func:`tribo_estimation.core.signal.lag2_segments`,
    its slope state given too).

    Parameters
    ----------
    w2 : FloatArray
        Simulated shaft speed [rad/s] on the record's time base.
    segments : Segments
        The segments.
    sel : numpy.ndarray of bool
        Selected segments.
    speed_start : FloatArray
        The sensor's output before every segment start, offset included [rad/s]
        (:func:`stuck_sensor_states`, or the measured speed there).
    dt : float
        Sample interval [s].
    values : mapping of str to float
        Model values holding the instrument terms (missing: 0).
    slope_start : FloatArray, optional
        The sensor's output slope before every segment start [rad/s^2] (a
        second-order sensor's state; default 0).

    Returns
    -------
    FloatArray
        The speed as the sensor shows it [rad/s].
    """
    tau = float(values.get('speed_lag_tau', 0.0))
    off = float(values.get('speed_offset', 0.0))
    a2 = float(values.get('speed_lag_shape', 0.0)) * tau * tau
    if tau <= 0.0 and off == 0.0:
        return w2
    out = w2.copy()
    if tau > 0.0 and a2 > FIRST_ORDER_A2 * dt * dt:
        yd = np.zeros(segments.n) if slope_start is None else slope_start
        lag2_segments(
            w2,
            segments.start[sel],
            segments.stop[sel],
            speed_start[sel] - off,
            yd[sel],
            second_order_lag(tau, a2, dt),
            out,
            np.empty_like(out),
        )
    elif tau > 0.0:
        a = math.exp(-dt / tau)
        lag_segments(
            w2,
            segments.start[sel],
            segments.stop[sel],
            speed_start[sel] - off,
            a,
            out,
            (1.0 - a) * tau / dt,
        )
    return out + off


#: A stick phase whose speed channel departs from the chamber speed by more than
#: this many robust standard deviations (over the phases) [-] and at least
#: :data:`FALSE_STICK_MIN` [rad/s] is no stick (:func:`false_stick_phases`).
FALSE_STICK_SIGMA = 10.0
FALSE_STICK_MIN = 0.1


def false_stick_phases(
    record: Record, rig: RigParams, a0: IntArray, b0: IntArray
) -> npt.NDArray[np.float64]:
    """Return how far each detected stick phase is from a stick: the slip speed seen.

    While the discs stick, the shaft speed equals the chamber speed
    ``w1 = (dM_t/dt)/C1`` (Equ. 4), and the speed channel shows it through the
    sensor model of :func:`identify_speed_sensor` (``y = w - tau*y' + offset``).
    The median of ``y + tau*y' - offset - w1`` over the phase's interior
    (:func:`tribo_estimation.core.sticks.speed_mismatch`, the detector's own check,
    here with this known sensor) is
    ~0.01 rad/s in a stick and the slip speed (rad/s) in a phase the stick
    detector took for a stick while the discs still slip (seen at the slow end of a
    slip just before a real stick: 3 ms at 2-6 rad/s slip).

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (C1, Tab. 1).
    a0, b0 : IntArray
        First and stop sample of each detected stick phase.

    Returns
    -------
    numpy.ndarray of float
        Median speed disagreement per phase [rad/s] (0 for a phase too short to tell).
    """
    if a0.size == 0:
        return np.zeros(0)
    slope, w1, sensor = sensor_view(record, rig, a0, b0)
    spans = list(zip(a0.tolist(), b0.tolist(), strict=True))
    guard = stick_guard(record, rig)
    mismatch = speed_mismatch(record.speed, slope, w1, spans, guard=guard, sensor=sensor)
    return np.asarray(mismatch, dtype=np.float64)


def sensor_view(
    record: Record, rig: RigParams, a0: IntArray, b0: IntArray
) -> tuple[FloatArray, FloatArray, tuple[float, float]]:
    """Return what the stick checks compare: speed slope, chamber speed, speed sensor.

    The speed channel's slope y' (:func:`speed_slope`), the chamber speed
    ``w1 = (dM_t/dt)/C1`` (Equ. 4) and the speed sensor ``(tau [s], offset [rad/s])``
    identified from the stick phases (:func:`identify_speed_sensor`; 0 where not
    identified), so that ``y + tau*y' - offset - w1`` is the slip speed seen.

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (C1, Tab. 1).
    a0, b0 : IntArray
        First and stop sample of each detected stick phase.

    Returns
    -------
    tuple
        y' [rad/s^2], w1 [rad/s] per sample, and ``(tau, offset)``.
    """
    sensor = identify_speed_sensor(record, rig, (a0, b0))
    tau = sensor.tau if math.isfinite(sensor.tau) else 0.0
    off = sensor.offset if math.isfinite(sensor.offset) else 0.0
    return speed_slope(record.speed, record.dt, rig), rig_chamber_speed(record, rig), (tau, off)


#: Mains frequencies whose lines on a channel are instrument (hum), not physics [Hz].
MAINS_HZ: tuple[float, ...] = (50.0, 60.0)
#: Harmonics of a mains frequency tested [-].
MAINS_HARMONICS = 5
#: Neighbouring frequencies (multiples of the record's resolution 1/T) that give a
#: line's local null level [-].
_HUM_NEIGHBOURS = tuple(j for j in range(-12, 13) if abs(j) >= 2)
#: Largest relative deviation of a grid's frequency from its nominal value [-] that a
#: line is taken for one of its harmonics at (EN 50160: an interconnected grid stays
#: within +-1 % for 99.5 % of a year).
MAINS_TOLERANCE = 0.01


@dataclass(frozen=True)
class Hum:
    """Mains hum on the channels: the lines found and taken out.

    Parameters
    ----------
    lines : tuple of (str, float, float, float)
        Per line: channel name, frequency [Hz], amplitude [unit of the channel],
        phase [rad] (``x += amplitude*sin(2 pi f t + phase)``).
    """

    lines: tuple[tuple[str, float, float, float], ...] = ()

    def remove(self, record: Record) -> Record:
        """Return the record with the lines subtracted from their channels."""
        if not self.lines:
            return record
        cols = {c: record.channel(c).copy() for c in HUM_CHANNELS}
        t = record.time
        for c, f, a, p in self.lines:
            cols[c] -= a * np.sin(2.0 * math.pi * f * t + p)
        return replace(
            record,
            torsion_moment=cols['torsion_moment'],
            angular_acceleration=cols['angular_acceleration'],
            speed=cols['speed'],
        )

    def report(self) -> list[dict[str, object]]:
        """Return the ``mains_hum`` entry of ``discrepancy.json``."""
        return [
            {'channel': c, 'frequency': f, 'amplitude': a, 'phase': p} for c, f, a, p in self.lines
        ]


#: Channels whose mains lines are taken out.
HUM_CHANNELS: tuple[str, str, str] = ('torsion_moment', 'angular_acceleration', 'speed')


def _line(t: FloatArray, r: FloatArray, f: float) -> tuple[float, float]:
    """Least-squares sine at ``f`` [Hz] through ``r``: amplitude and phase.

    The 2 x 2 normal equations of the sine and cosine columns.
    """
    w = 2.0 * math.pi * f * t
    s, c = np.sin(w), np.cos(w)
    ss, cc, sc = float(s @ s), float(c @ c), float(s @ c)
    rs, rc = float(s @ r), float(c @ r)
    det = ss * cc - sc * sc
    if not det > 0.0:
        return 0.0, 0.0
    a = (cc * rs - sc * rc) / det
    b = (ss * rc - sc * rs) / det
    return math.hypot(a, b), math.atan2(b, a)


def mains_grids(frequencies: Iterable[float]) -> dict[float, float]:
    """Return the grid frequency [Hz] per nominal one (:data:`MAINS_HZ`) of known lines.

    A line at ``f`` is harmonic ``k = round(f/fm)`` of the nominal ``fm`` when ``f/k``
    lies within :data:`MAINS_TOLERANCE` of it; the first such line gives the grid.
    """
    out: dict[float, float] = {}
    for f in frequencies:
        for fm in MAINS_HZ:
            k = round(f / fm)
            if (
                fm not in out
                and 1 <= k <= MAINS_HARMONICS
                and abs(f / k - fm) <= MAINS_TOLERANCE * fm
            ):
                out[fm] = f / k
    return out


def identify_hum(
    time: FloatArray,
    residuals: Mapping[str, FloatArray],
    alpha: float,
    grids: Mapping[float, float] | None = None,
) -> Hum:
    """Find the mains lines on a model's residuals (instrument, not physics).

    For each channel, mains frequency (:data:`MAINS_HZ`) and harmonic (up to
    :data:`MAINS_HARMONICS`) the residual's power at the line is compared with its
    power at the neighbouring frequencies ``f + j/T`` (|j| = 2..12, T the record's
    span), from one zero-padded FFT per channel (bins of about 1/(4T)): without a
    line each bin's power is exponentially distributed around the neighbours'
    median, so the largest of the three bins nearest the line exceeds ``x`` times
    that median with probability about ``3*2^-x``. A line is taken out when the ratio
    exceeds ``log2(3*m/alpha)`` (m the lines tested: Bonferroni), so noise and a
    model mismatch's broad spectrum leave it alone; its amplitude and phase are the
    least-squares sine through the residual at the grid's frequency (one per nominal
    frequency, measured on its most significant line, :func:`_grid_frequency`: a grid
    runs off its nominal frequency, EN 50160 allows 1 %).

    Parameters
    ----------
    time : FloatArray
        Sample times [s] (the residuals' samples).
    residuals : mapping of str to FloatArray
        Per channel of :data:`HUM_CHANNELS`, measured - simulated [unit]; NaN samples
        are set to zero for the spectrum and left out of the sine fit.
    alpha : float
        Chance that a record without hum has a line taken out [-].
    grids : mapping of float to float or None
        Grid frequencies [Hz] per nominal one measured before (:func:`mains_grids` of
        the lines an earlier pass took out): used instead of measuring them again on
        what the earlier lines left.

    Returns
    -------
    Hum
        The lines found.
    """
    span = float(time[-1] - time[0]) if time.size > 1 else 0.0
    if span <= 0.0:
        return Hum()
    fs = (time.size - 1) / span
    tests = [
        (c, fm, k)
        for c in HUM_CHANNELS
        for fm in MAINS_HZ
        for k in range(1, MAINS_HARMONICS + 1)
        if k * fm < 0.45 * fs
    ]
    if not tests:
        return Hum()
    limit = math.log2(3.0 * len(tests) / alpha)
    n_fft = 1 << math.ceil(math.log2(4 * time.size))
    per_t = n_fft / time.size  # bins per 1/T
    power: dict[str, FloatArray] = {}

    def significant(c: str, f: float) -> float:
        """Peak over level of the line at ``f`` on channel ``c`` (0: not a line there)."""
        r = residuals[c]
        ok = np.isfinite(r)
        if np.count_nonzero(ok) < 100:
            return 0.0
        if c not in power:
            x = np.where(ok, r - float(np.mean(r[ok])), 0.0)
            power[c] = np.abs(np.fft.rfft(x, n_fft)) ** 2
        p = power[c]
        k0 = round(f * n_fft / fs)
        near = [round(k0 + j * per_t) for j in _HUM_NEIGHBOURS]
        if k0 < 2 or max(near) >= p.size or min(near) < 0:
            return 0.0
        level = float(np.median(p[near]))
        peak = float(np.max(p[k0 - 1 : k0 + 2]))
        # a mains line peaks at the mains frequency: a line beside it (a stick-slip
        # harmonic within the main lobe, 1/T) has its maximum elsewhere
        lobe = p[max(0, k0 - round(per_t)) : k0 + round(per_t) + 1]
        if level > 0.0 and peak / level > limit and peak >= float(np.max(lobe)):
            return peak / level
        return 0.0

    # one grid, one frequency: measured on the most significant line found at the
    # nominal frequencies; the harmonics tested and fitted at its multiples
    lines: list[tuple[str, float, float, float]] = []
    known = dict(grids or {})
    for fm in MAINS_HZ:
        if fm in known:
            grid = known[fm]
        else:
            mine = [(q, c, k) for c, g, k in tests if g == fm and (q := significant(c, k * fm))]
            if not mine:
                continue
            _, c0, k0 = max(mine)
            grid = _grid_frequency(time, residuals[c0], k0 * fm, span) / k0
        for c, g, k in tests:
            if g == fm and significant(c, k * grid):
                r = residuals[c]
                ok = np.isfinite(r)
                amp, phase = _line(time[ok], r[ok] - float(np.mean(r[ok])), k * grid)
                lines.append((c, k * grid, amp, phase))
    return Hum(tuple(lines))


def _grid_frequency(time: FloatArray, r: FloatArray, f: float, span: float) -> float:
    """Return the frequency of the line found at its nominal ``f`` [Hz].

    The least-squares sine's frequency within half the record's resolution (1/(2T))
    of ``f``: the line test takes a line whose peak lies within a zero-padded bin of
    the nominal frequency, and a grid runs off it (a line fitted at its nominal
    frequency turns against the hum over the record).
    """
    from scipy.optimize import minimize_scalar

    ok = np.isfinite(r)
    t, x = time[ok], r[ok] - float(np.mean(r[ok]))
    half = 0.5 / span
    fit = minimize_scalar(
        lambda g: -_line(t, x, g)[0],
        bounds=(f - half, f + half),
        method='bounded',
        options={'xatol': 1e-3 / span},
    )
    return float(fit.x) if fit.success else f
