"""The baseline fit: simulate a record's segments with the rig model and fit its values.

:class:`Problem` holds a record, its segments (:mod:`.segments`), the known rig
and the drive profile measured from the record (:mod:`tribo_estimation.core.drive`).
Each segment is simulated with the compiled kernel (:func:`tribo_estimation.core.kernel.integrate`,
Equ. 1-3, 6, 8 plus the :class:`~tribo_estimation.core.model.Extensions`) from the
state re-initialised from the measurements at its start
(:mod:`tribo_estimation.core.shooting`), so long records do not drift. The
simulated channels pass through the instrument model (:mod:`.instrument`) before
they are compared. The cost is the mean of the squared, channel-weighted
residuals (measured - simulated) of :data:`.records.CHANNELS`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.drive import (
    COSINE,
    MIN_PIECE,
    SMOOTH_TIME,
    TRANSITION_MAX,
    DriveEstimate,
    estimate_drive,
    refine_with_angles,
    transitions,
    untimed_transitions,
    with_durations,
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
    local_cubic,
    shoot,
    shoot_on,
    stuck_kinematics,
    stuck_states_averaged,
    stuck_windows,
    window_mean,
)
from tribo_estimation.core.signal import (
    CHAMBER_HALF,
    moving_average,
    noise_level,
    rig_half,
    running_integral,
)
from tribo_estimation.errors import InvalidParameterError

from .. import candidates as cand_lib
from ..candidates import ParamSpec
from ..stats import FloatArray, noise_floor
from .instrument import (
    FIRST_ORDER_A2,
    rig_chamber_speed,
    speed_error_at_sticks,
    speed_sensor_output,
    speed_slope,
    stuck_sensor_states,
)
from .records import (
    CHANNELS,
    EXT_FIELDS,
    INSTRUMENT_FIELDS,
    MU0,
    MU_INF,
    RIG_FACTOR_FIELDS,
    RIG_FACTORS,
    FitOutcome,
    Record,
    Segments,
    SimulatedRecord,
)
from .segments import (
    begins_at_drive_start,
    make_segments,
    sliding_chamber_speed,
    sliding_start_states,
    slip_samples,
    waits_at_rest,
)

#: Cell of the speed-sensor lag [s] and offset [rad/s] within which the drive profile
#: keeps one placement of its corners (:meth:`Problem._fit_drive`).
_REPLACE_LAG = 1e-4
_REPLACE_OFFSET = 1e-2
#: No drive ripple (amplitude, frequency, phase, second harmonic's amplitude, phase;
#: the angle-locked ripple's relative amplitude, order, phase, its second harmonic's
#: relative amplitude and phase).
_NO_RIPPLE = (0.0,) * 10


def _squares(r: FloatArray) -> float:
    """Return the sum of squares of a residual (inf if it is empty or not finite)."""
    return float(r @ r) if r.size and bool(np.all(np.isfinite(r))) else math.inf


def _ripple_of(ext: Extensions) -> tuple[float, ...]:
    """Return the model's drive ripple in the order of :data:`_NO_RIPPLE`."""
    return (
        ext.ripple_amp, ext.ripple_freq, ext.ripple_phase, ext.ripple2_amp, ext.ripple2_phase,
        ext.ripple_rel, ext.ripple_order, ext.ripple_angle_phase, ext.ripple2_rel,
        ext.ripple2_angle_phase,
    )  # fmt: skip


#: Fewest drive angles the profile is fitted to [-] (fewer: the smoothed speed).
_MIN_ANGLES = 20
#: Durations a transition's search tries (:meth:`Problem.set_transition_durations`),
#: from the profile's shortest piece (:data:`~tribo_estimation.core.drive.MIN_PIECE`):
#: trials per doubling of the grid [-] and golden-section steps after it [-] (from the
#: best's two grid neighbours, a factor 2 apart, the bracket ends 2.4 % wide).
_DURATION_PER_OCTAVE = 2
_DURATION_GOLDEN = 6
#: Share of the excess over the white noise, in the segments spanning a transition
#: that angles inside time, that a transition tried by the torsion moment must
#: remove to replace the placed one [-]: more than half, so the transition is the
#: larger part of what misfits there; otherwise the misfit is the model's (an effect
#: it lacks acts at the step too) and the placement by the angles, which does not
#: depend on the model, is kept (:meth:`Problem.set_transition_durations`).
_TRANSITION_SHARE = 0.5


def _golden_log(
    cost: Callable[[float], float], lo: float, hi: float, steps: int
) -> tuple[float, float]:
    """Return the argument in ``[lo, hi]`` (> 0) of least ``cost`` and that cost.

    Golden-section steps on the logarithm of the argument.
    """
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    a, b = math.log(lo), math.log(hi)
    x1, x2 = b - g * (b - a), a + g * (b - a)
    c1, c2 = cost(math.exp(x1)), cost(math.exp(x2))
    for _ in range(steps):
        if c1 <= c2:
            b, x2, c2 = x2, x1, c1
            x1 = b - g * (b - a)
            c1 = cost(math.exp(x1))
        else:
            a, x1, c1 = x1, x2, c2
            x2 = a + g * (b - a)
            c2 = cost(math.exp(x2))
    return (math.exp(x1), c1) if c1 <= c2 else (math.exp(x2), c2)


def scaled_fit(
    residuals: Callable[[dict[str, float]], FloatArray],
    free: Sequence[ParamSpec],
    start: Mapping[str, float],
    max_nfev: int,
) -> tuple[dict[str, float], float, int, bool, dict[str, float]]:
    """Fit ``free`` by bounded least squares in the solver's coordinates; the one home.

    Each parameter is value/scale (log(value) for time constants) within its box;
    :func:`~tribo_estimation.core.lsq.levenberg_marquardt` minimises the squared
    ``residuals`` of the value mapping (the start's other names held fixed). Standard
    errors from the last Jacobian, ``s^2 (J^T J)^-1``, in value units.

    Parameters
    ----------
    residuals : callable
        Residual vector of a value mapping [-].
    free : sequence of ParamSpec
        The fitted parameters (at least one).
    start : mapping of str to float
        Start values of every name the residuals need.
    max_nfev : int
        Most residual evaluations.

    Returns
    -------
    tuple
        The values, the sum of squared residuals [-], the evaluations, whether the
        solver converged, and the standard errors (SI) by name.
    """
    fixed = {k: float(v) for k, v in start.items()}

    def clip(p: ParamSpec, v: float) -> float:
        return min(max(v, p.lower), p.upper)

    def from_x(x: FloatArray) -> dict[str, float]:
        out = dict(fixed)
        for p, xi in zip(free, x, strict=True):
            out[p.name] = math.exp(float(xi)) if p.log else float(xi) * p.scale
        return out

    lo = np.asarray([math.log(p.lower) if p.log else p.lower / p.scale for p in free])
    hi = np.asarray([math.log(p.upper) if p.log else p.upper / p.scale for p in free])
    x0 = np.asarray(
        [
            math.log(clip(p, float(start.get(p.name, p.initial))))
            if p.log
            else clip(p, float(start.get(p.name, p.initial))) / p.scale
            for p in free
        ]
    )
    sol = levenberg_marquardt(
        lambda x: residuals(from_x(x)), x0, lo, hi, max_nfev=max_nfev, max_iter=max_nfev,
        ftol=1e-6, lam0=1e-3,
    )  # fmt: skip
    dof = max(1, sol.fun.size - len(free))
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * (sol.cost / dof)
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        sd = np.full(len(free), math.nan)
    se = {
        p.name: float(math.exp(float(xi)) * si if p.log else si * p.scale)
        for p, xi, si in zip(free, sol.x, sd, strict=True)
    }
    return from_x(sol.x), float(sol.cost), int(sol.nfev), bool(sol.converged), se


class Problem:
    """A record, its segments, the known rig and drive: simulate and fit models.

    ``mu0``, ``mu_inf`` and extension fields are the model values passed to
    :meth:`simulate` / :meth:`fit`; the drive speed is measured from the record.

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (Tab. 1 values, F_N, R).
    drive : DriveProfile
        RIG.yaml drive (nominal speed [rad/s]: a default and a check; start-up
        ramp time [s]).
    k : float
        Decay constant of Equ. 8 [s/rad].
    segments : Segments, optional
        Simulation segments (default: :func:`.segments.make_segments`).
    weights : mapping of str to float, optional
        Channel weights [1/unit] (default: :meth:`signal_weights`).
    block_time : float
        Length of a time block of the default segments [s].
    speed_calibration : bool
        Take the speed channel's slow error at the stick phases off its drive angles
        and stuck starts (:func:`.instrument.speed_error_at_sticks`; set where the stick
        regression's sensor model holds).
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
        block_time: float = 0.25,
        speed_calibration: bool = False,
    ) -> None:
        self.record = record
        #: the speed channel's slow error is calibrated at the stick phases
        #: (:meth:`_speed_error`; where the stick regression's sensor model holds)
        self.speed_calibration = bool(speed_calibration)
        self.block_time = float(block_time)
        self.rig = rig
        self.drive = drive
        self.k = float(k)
        #: drive speed measured from the record (the nominal speed only a check)
        self.drive_estimate: DriveEstimate = estimate_drive(
            record.time, record.speed, drive.nominal_speed
        )
        self.segments = (
            segments
            if segments is not None
            else make_segments(
                record,
                rig,
                block_time=self.block_time,
                dwell_from_start=begins_at_drive_start(
                    record, drive.ramp_time, self.drive_estimate.level
                ),
            )
        )
        self.n_evals = 0
        #: mains lines per raw channel [Hz] (instrument; projected out of the residuals)
        self.hum_lines: dict[str, tuple[float, ...]] = {}
        #: instrument parameters refitted with every model (the baseline frees the
        #: speed-sensor lag and offset when the lag is significant; none by default)
        self.free_instrument: tuple[ParamSpec, ...] = ()
        seg = self.segments
        i = seg.start
        fs = record.fs
        self._t0 = record.time[i].astype(np.float64)
        self._drive_speed0 = self.drive_estimate
        # a record that begins at the drive's start (RIG.yaml ramp from t = 0, and the
        # measured speed there at rest within the profile tolerance): w0 = 0 at t0
        self._start_speed: float | None = (
            0.0
            if begins_at_drive_start(record, drive.ramp_time, self.drive_estimate.level)
            else None
        )
        #: RIG.yaml's start-up ramp, (start, end) [s], where it begins at the record's
        #: first sample: a record that begins at rest and rests on (the motor started
        #: after the recording) has its start-up's corners placed as any other's
        self._ramp: FloatArray | None = None
        level = self.drive_estimate.level
        if self._start_speed is not None and not waits_at_rest(record, drive.ramp_time, level):
            self._ramp = np.array([float(record.time[0]), record.time[0] + drive.ramp_time])
        sp = record.speed
        #: the speed channel's error at the sticks [rad/s] and its integral [rad], per
        #: sensor lag
        self._speed_errors: dict[float, FloatArray] = {}
        #: the mains lines' basis last used (:meth:`_line_basis`)
        self._lines_cache: dict[tuple[float, ...], tuple[npt.NDArray[np.bool_], FloatArray]] = {}
        self._drift_angles: dict[float, FloatArray] = {}
        self._shaft_angle = running_integral(sp, record.dt)
        self._knots = DriveKnots.from_estimate(self.drive_estimate)
        # state at the segment starts: the torsion moment (local cubic) and the
        # acceleration; the common speed of the stuck discs from the speed channel
        # with its sensor model inverted (:meth:`_set_instrument`)
        # (the local fits stay inside a stuck start's stick phase; a sliding start has none)
        lo, hi = seg.run_start, seg.run_stop
        if lo is not None and hi is not None and seg.sliding_starts.any():
            lo = np.where(seg.sliding_starts, 0, lo)
            hi = np.where(seg.sliding_starts, record.time.size, hi)
        self._m_val, slope = local_cubic(record.torsion_moment, i, lo, hi)
        self._m_slope = np.where(np.isfinite(slope), slope * fs, 0.0)
        self._a0 = window_mean(record.angular_acceleration, i, 2, lo, hi)
        #: measured speed channel at the starts (the speed sensor's state there)
        self._speed_start = window_mean(record.speed, i, 5, lo, hi)
        #: common speed of the stuck discs at the starts from the speed channel
        #: without a sensor lag [rad/s]
        self._speed_stuck = self._speed_start.copy()
        #: torsion moment at the starts from the stick-phase regression [N m]
        self._m_stuck = self._m_val.copy()
        if seg.run_start is not None and seg.run_stop is not None:
            # in a stick phase the chamber kinematics (Equ. 4) tie torsion moment,
            # speed and the measured acceleration over the whole phase: a regression
            # over it gives the state far better than a local cubic
            m_k, _, w_k = stuck_kinematics(
                record.torsion_moment, record.angular_acceleration, record.speed, i,
                seg.run_start, seg.run_stop, record.dt, rig.C1,
            )  # fmt: skip
            ok = np.isfinite(m_k)
            # (kept apart: a model with a torsion-sensor lag sees a lagged torsion
            # moment, which the regression does not describe; it keeps the cubic)
            self._m_stuck = np.where(ok, m_k, self._m_val)
            self._speed_stuck = np.where(ok, w_k, self._speed_stuck)
        #: stick-phase windows of the stuck starts (the belt deflection's average; a
        #: sliding start's run is empty, so is its window)
        self._windows = stuck_windows(
            record.angular_acceleration, i,
            seg.run_start if seg.run_start is not None else i,
            seg.run_stop if seg.run_stop is not None else i, record.dt,
        )  # fmt: skip
        # stick samples (every 4th, away from the phase ends) and smoothed channels
        # for the drive angle (:meth:`_set_instrument`); the window and the guard
        # span at most a quarter period of the rig's fastest mode
        half = rig_half(CHAMBER_HALF, record.fs, rig.fastest_mode_hz)
        width = 2 * half + 1
        self._smooth_speed = moving_average(record.speed, width)
        self._speed_slope = speed_slope(record.speed, record.dt, rig)
        self._smooth_accel = moving_average(record.angular_acceleration, width)
        self._smooth_torque = moving_average(record.torsion_moment, width)
        guard = half + 1
        phases = seg.stick_phases()
        ra, rb = phases if phases is not None else (seg.start, seg.start + 1)
        idx = [
            np.arange(int(a) + guard, int(b) - guard, 4, dtype=np.int64)
            for a, b in zip(ra, rb, strict=True)
            if b - a > 2 * guard
        ]
        self._stick_samples = np.unique(np.concatenate(idx)) if idx else np.zeros(0, dtype=np.int64)
        #: samples of the sliding stretches (without a stick phase for longer than
        #: 2 x SMOOTH_TIME: a start-up, a speed step out of stick-slip, a record without
        #: it) and their shaft acceleration and chamber speed: their drive angle follows
        #: from the shaft's balance with the friction moment observed (:meth:`_angle_drive`)
        self._slip_samples = slip_samples(
            record.time.size, phases, round(2.0 * SMOOTH_TIME * fs), guard
        )
        if self._slip_samples.size:
            self._speed_curv = speed_slope(self._speed_slope, record.dt, rig)
            self._w1_slip = rig_chamber_speed(record, rig)
        self._meas: dict[str, FloatArray] = {
            'torsion_moment': record.torsion_moment,
            'chamber_speed': np.full(record.time.size, np.nan),
            'speed': record.speed,
        }
        self._w_start = self._speed_stuck.copy()
        #: chamber speed at sliding segment starts (from the torsion moment) [rad/s]
        self._w1_slide = (
            sliding_chamber_speed(record, i, rig) if seg.sliding_starts.any() else np.zeros(i.size)
        )
        self._instrument: tuple[float, ...] = (math.nan,) * 10
        #: the speed sensor's output and slope before each segment start [rad/s, rad/s^2]
        self._sensor_start: tuple[FloatArray, FloatArray] = (self._speed_start, np.zeros(0))
        #: the drive profile placed once per speed-sensor cell (:meth:`_fit_drive`)
        self._placed: dict[tuple[int, int], DriveEstimate] = {}
        #: the transitions chosen by the torsion moment, (mid-time [s], duration [s],
        #: shape [-]) (:meth:`set_transition_durations`)
        self.durations: tuple[tuple[float, float, float], ...] = ()
        self._set_instrument(0.0, 0.0)
        self.weights: dict[str, float] = dict(weights) if weights else self.signal_weights()

    @property
    def begins_at_drive_start(self) -> bool:
        """True when the record begins at rest at the drive's start (RIG.yaml's ramp).

        Its drive profile then starts from rest at the first sample
        (:func:`.segments.begins_at_drive_start`).
        """
        return self._start_speed is not None

    def like(self, record: Record) -> Problem:
        """Return the problem of another record with this one's rig, drive and settings.

        The same rig, drive configuration, decay constant k, channel weights, free
        instrument terms and block length; the segments, drive profile and stick
        phases are the new record's own.

        Parameters
        ----------
        record : Record
            The other record (e.g. a replica of this one's model).

        Returns
        -------
        Problem
            Its problem.
        """
        pb = Problem(
            record, self.rig, self.drive, k=self.k, weights=self.weights,
            block_time=self.block_time, speed_calibration=self.speed_calibration,
        )  # fmt: skip
        pb.free_instrument = self.free_instrument
        pb.hum_lines = dict(self.hum_lines)
        return pb

    # ------------------------------------------------------------------ weights
    def signal_weights(self) -> dict[str, float]:
        """Return the channel weights 1/std(measured channel) (a start before any fit).

        Returns
        -------
        dict of str to float
            Weight per channel of :data:`.records.CHANNELS` [1/unit].
        """
        out = {}
        for c in CHANNELS:
            m = self._meas[c] if hasattr(self, '_meas') else self.record.channel(c)
            s = float(np.nanstd(m))
            out[c] = 1.0 / s if s > 0 else 0.0
        return out

    def set_residual_weights(self, sim: SimulatedRecord, floor: Mapping[str, float]) -> None:
        """Set the weights to 1/rms(residual) per channel, never above 1/floor[c].

        Each channel then contributes equally to the cost of that model.

        Parameters
        ----------
        sim : SimulatedRecord
            Simulation of the model the weights are made for.
        floor : mapping of str to float
            Noise floor per channel [unit].
        """
        cov = sim.covered
        for c in CHANNELS:
            r = self._meas[c][cov] - sim.channel(c)[cov]
            s = max(float(np.sqrt(np.mean(r * r))), floor.get(c, 0.0))
            self.weights[c] = 1.0 / s if s > 0 else 0.0

    # --------------------------------------------------------------- simulation
    def rig_of(self, values: Mapping[str, float]) -> RigParams:
        """Return the rig with the factors of ``values`` applied (:data:`.RIG_FACTORS`).

        Parameters
        ----------
        values : mapping of str to float
            Model values; ``shaft_I2``, ``shaft_K2``, ``shaft_C2`` [-] scale the
            problem's I2, K2, C2 (Equ. 2), ``chamber_I1`` [-] its I1 (Equ. 1); a
            missing factor is 1.

        Returns
        -------
        RigParams
            The rig (the problem's own when no factor is given).
        """
        scaled = {
            field: getattr(self.rig, field) * float(values[name])
            for name, field in RIG_FACTORS.items()
            if name in values and float(values[name]) != 1.0
        }
        return replace(self.rig, **scaled) if scaled else self.rig

    def model_objects(self, values: Mapping[str, float]) -> tuple[FrictionLaw, Extensions]:
        """Return the FrictionLaw and Extensions of a value mapping.

        Parameters
        ----------
        values : mapping of str to float
            Model values (``mu0``, ``mu_inf``, the decay constant ``k`` of Equ. 8 [s/rad]
            (default: the problem's), Extensions fields, instrument terms).

        Returns
        -------
        tuple of (FrictionLaw, Extensions)
            The friction law (Equ. 8) and the model extensions.

        Raises
        ------
        InvalidParameterError
            A name that is neither a friction level, an instrument term nor an
            Extensions field.
        """
        level_names = {n for c in cand_lib.level_forms() for n in c.param_names}
        ext_vals = {
            k: float(v)
            for k, v in values.items()
            if k not in ('mu0', 'mu_inf', 'k')
            and k not in INSTRUMENT_FIELDS
            and k not in RIG_FACTOR_FIELDS
            and k not in level_names
        }
        unknown = set(ext_vals) - EXT_FIELDS
        if unknown:
            raise InvalidParameterError(f'unknown model parameter(s) {sorted(unknown)}')
        fr = FrictionLaw(
            max(float(values.get('mu0', MU0.initial)), 0.0),
            max(float(values.get('mu_inf', MU_INF.initial)), 0.0),
            float(values.get('k', self.k)),
        )
        return fr, replace(Extensions(), **ext_vals)

    def simulate(
        self,
        values: Mapping[str, float],
        seg_mask: npt.NDArray[np.bool_] | None = None,
        *,
        continuous: bool = False,
        start_delta: FloatArray | None = None,
    ) -> SimulatedRecord:
        """Simulate the (selected) segments with the model ``values``.

        Parameters
        ----------
        values : mapping of str to float
            Model values (see :meth:`model_objects`).
        seg_mask : numpy.ndarray of bool, optional
            Segments to simulate (default: all).
        continuous : bool
            Simulate one stretch from the first segment's start state to the record's
            end (no re-initialisation: the model's own motion, as a record of it would
            show; ``seg_mask`` is ignored).
        start_delta : FloatArray or None
            Added to every segment's start state (rows: segments, columns: the
            kernel's state slots; :meth:`refined`).

        Returns
        -------
        SimulatedRecord
            The model output, NaN outside the simulated segments.
        """
        if continuous:
            seg_mask = np.zeros(self.segments.n, dtype=bool)
            seg_mask[0] = True
        fr, ext = self.model_objects(values)
        p = pack_params(self.rig_of(values), fr, self.drive, ext)
        rec = self.record
        seg = self.segments
        sel = np.ones(seg.n, dtype=bool) if seg_mask is None else seg_mask
        # measured torsion at the segment starts -> true C1*phi1 (the effects'
        # measurement transforms inverted: offset, then first-order lag)
        t0 = self._t0[sel]
        m_meas = (self._m_val if ext.torque_lag_tau > 0.0 else self._m_stuck)[sel]
        m_true = true_torsion_at_starts(ext, t0, m_meas, self._m_slope[sel], rec.dt)
        self._set_instrument(
            float(values.get('speed_lag_tau', 0.0)),
            float(values.get('speed_offset', 0.0)),
            float(values.get('speed_lag_shape', 0.0)),
            _ripple_of(ext),
            (ext.torque_offset, ext.torque_offset_drift),
        )
        dk = self._knots
        # sliding starts from the measured sliding state, the others from the stuck one
        slides = seg.sliding_starts[sel]
        states = np.empty((int(np.count_nonzero(sel)), kn.NS))
        if slides.any():
            ss = seg.start[sel][slides]
            states[slides] = sliding_start_states(
                p, rec, ss, m_true[slides], self._w1_slide[sel][slides],
                self._w_start[sel][slides], self._speed_slope[ss], dk,
            )  # fmt: skip
        if not slides.all():
            st = ~slides
            rows = np.flatnonzero(sel)[st]
            tau, acc, a1, a2, n_win = self._windows
            states[st] = stuck_states_averaged(
                p, t0[st], m_true[st], self._w_start[sel][st], self._a0[sel][st],
                seg.stick_time[sel][st], dk.time, dk.speed, dk.shape,
                tau[rows], acc[rows], a1[rows], a2[rows], n_win[rows],
            )  # fmt: skip
        if start_delta is not None:
            states += start_delta[np.flatnonzero(sel)]
        n = rec.time.size
        out = np.full((kn.N_CH, n), np.nan)
        n_sub = kn.substeps_for(p, rec.dt)
        stops = np.full(1, n, dtype=np.int64) if continuous else seg.stop[sel]
        hooks = [
            c for c in cand_lib.level_forms() if any(values.get(x, 0.0) for x in c.param_names)
        ]
        if hooks:
            # friction levels that change with test time: per segment, their tangent at
            # its start (the kernel's linear drift of mu0 and mu_inf)
            def levelled(t_k: float) -> np.ndarray:
                p_k = p.copy()
                for c in hooks:
                    assert c.levels is not None
                    d0, r0, di, ri = c.levels(values, np.full(1, t_k))
                    p_k[kn.P_MU0] += float(d0[0]) - float(r0[0]) * t_k
                    p_k[kn.P_DRIFT_MU0] += float(r0[0])
                    p_k[kn.P_MUINF] += float(di[0]) - float(ri[0]) * t_k
                    p_k[kn.P_DRIFT_MUINF] += float(ri[0])
                return p_k

            starts = seg.start[sel]
            if continuous:
                # one motion, its state carried; the levels' tangent renewed at every
                # segment start (the fit's own pieces), not held over the whole record
                a = int(starts[0])
                cuts = [*np.unique(seg.start[seg.start > a]).tolist(), n]
                buf = np.empty((kn.N_CH, int(np.max(np.diff([a, *cuts])))))
                s_run = states[0].copy()
                for b in cuts:
                    shoot_on(
                        levelled(float(rec.time[a])), s_run, a, int(b), dk.time, dk.speed, dk.shape,
                        rec.dt, n_sub, out, buf,
                    )  # fmt: skip
                    a = int(b)
            else:
                for j, b in enumerate(stops):
                    shoot(
                        levelled(float(rec.time[starts[j]])), states[j : j + 1],
                        starts[j : j + 1], np.full(1, b, np.int64), dk.time, dk.speed, dk.shape,
                        rec.dt, n_sub, out,
                    )  # fmt: skip
        else:
            shoot(p, states, seg.start[sel], stops, dk.time, dk.speed, dk.shape, rec.dt, n_sub, out)
        self.n_evals += 1
        used = (
            replace(seg, start=seg.start[:1], stop=stops, stick_time=seg.stick_time[:1],
                    block=seg.block[:1], slides=seg.sliding_starts[:1])
            if continuous
            else seg
        )  # fmt: skip
        sel_used = np.ones(1, dtype=bool) if continuous else sel
        y0, yd0 = self._sensor_start
        speed = speed_sensor_output(
            out[kn.OUT_SPEED], used, sel_used, y0[sel] if continuous else y0, rec.dt, values,
            yd0[sel] if continuous else yd0,
        )  # fmt: skip
        torsion, _ = apply_measurement_transforms(
            ext, rec.time, out[kn.OUT_TORSION].copy(), rec.dt,
            segments=(seg.start[sel], stops), measured_first=m_meas,
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

    def refined(self, values: Mapping[str, float]) -> SimulatedRecord:
        """Simulate the model with every segment's start corrected by its own samples.

        The adequacy statistics judge the model, not the start states' estimates;
        the fit itself runs from the estimated starts. Per segment, one Gauss-Newton
        step on its start state: the chamber's and the shaft's angles and their
        speed (the chamber's, and the shaft's with it at a stuck start, which keeps
        it stuck) set off the lightly damped swings that an error of the estimate
        (a few ms of noisy samples) carries through the whole segment, as large as
        the noise where the windows are short (low sample rates, short sticks). The
        sensitivities come from one simulation per direction (every segment at once),
        the residuals weighted per channel with the mains lines taken out. Each
        direction is scaled to one noise level of the torsion moment (the angle's,
        or the swing's amplitude of the speed's) and the step is the posterior mode
        with the estimate's error taken as one such unit (a unit prior), so the starts
        are shrunk toward their estimates: a model error of many noise levels keeps
        most of its excess (a 3 % error of mu_inf at 5 rpm and 2 kHz: 89 % of its
        mean square). A segment keeps its step only where its own cost falls (a
        stick or a breakaway that moves with the start is not linear); the others
        keep their estimated start.

        Parameters
        ----------
        values : mapping of str to float
            The model.

        Returns
        -------
        SimulatedRecord
            Its simulation, each segment from its corrected (or estimated) start.
        """
        seg = self.segments
        base = self.simulate(values)
        if seg.n == 0:
            return base
        rig = self.rig_of(values)
        dm = max(noise_level(self.record.torsion_moment), 1e-6)  # [N m]
        # the directions [state units per unit coefficient]: chamber angle, shaft angle,
        # chamber speed (the shaft's too while stuck)
        dirs = np.zeros((3, seg.n, kn.NS))
        dirs[0, :, kn.S_PHI1] = dm / rig.C1
        dirs[1, :, kn.S_PHI2] = dm / rig.C2
        w_scale = dm * math.sqrt(rig.C1 / rig.I1) / rig.C1
        dirs[2, :, kn.S_W1] = w_scale
        dirs[2, ~seg.sliding_starts, kn.S_W2] = w_scale
        r0 = self._segment_residuals(base)
        # a direction's change of the weighted residual is the simulations' difference
        # (the measurement and its mains lines are the same for both)
        cov = base.covered
        weighted = [(ch, w) for ch in CHANNELS if (w := self.weights.get(ch, 0.0)) > 0]
        cols = np.empty((len(dirs), *r0.shape))  # (direction, channel, sample)
        for k, d in enumerate(dirs):
            moved = self.simulate(values, start_delta=d)
            for i, (ch, w) in enumerate(weighted):
                cols[k, i] = np.where(cov, w * (base.channel(ch) - moved.channel(ch)), np.nan)
        # per segment, the normal equations over its samples of every channel
        ok = np.all(np.isfinite(cols), axis=(0, 1)) & np.all(np.isfinite(r0), axis=0)
        y = np.where(ok, r0, 0.0)
        J = np.where(ok, cols, 0.0)
        bounds = seg.start.astype(np.int64)
        JJ = np.add.reduceat(np.einsum('acn,bcn->abn', J, J), bounds, axis=2)
        Jy = np.add.reduceat(np.einsum('acn,cn->an', J, y), bounds, axis=1)
        counts = np.add.reduceat(ok.astype(np.int64), bounds)
        # (samples between or after segments are not simulated: NaN, outside ``ok``)
        A = np.moveaxis(JJ, 2, 0) + np.eye(3)
        c = -np.linalg.solve(A, Jy.T[..., None])[..., 0]  # (segment, direction)
        c[counts <= 6] = 0.0
        delta = np.einsum('sd,dsk->sk', c, dirs)
        after = self.simulate(values, start_delta=delta)
        r1 = self._segment_residuals(after)
        e0 = np.add.reduceat(np.where(np.isfinite(r0), r0 * r0, 0.0).sum(axis=0), bounds)
        e1 = np.add.reduceat(np.where(np.isfinite(r1), r1 * r1, 0.0).sum(axis=0), bounds)
        f0 = np.add.reduceat(np.isfinite(r0).sum(axis=0), bounds)
        f1 = np.add.reduceat(np.isfinite(r1).sum(axis=0), bounds)
        better = (e1 < e0) & (f1 == f0)
        if better.all():
            return after
        # the segments are independent: each keeps the simulation of the start it keeps
        use = np.zeros(base.covered.size, dtype=bool)
        for j in np.flatnonzero(better):
            use[seg.start[j] : seg.stop[j]] = True
        fields = {
            f.name: np.where(use, getattr(after, f.name), getattr(base, f.name))
            for f in dataclasses.fields(base)
        }
        return SimulatedRecord(**fields)

    def _segment_residuals(self, sim: SimulatedRecord) -> FloatArray:
        """Weighted residuals per channel (rows) and sample (NaN where not covered).

        The channels of :meth:`residual_vector` in the record's sample order, so that
        they can be summed per segment.
        """
        cov = sim.covered
        parts = self._weighted_parts(sim)
        out = np.full((len(parts), cov.size), np.nan)
        for row, part in zip(out, parts, strict=True):
            row[cov] = part
        return out

    def _weighted_parts(self, sim: SimulatedRecord) -> list[FloatArray]:
        """Return per weighted channel its residual times its weight over the covered samples.

        Measured minus simulated, each channel's mains lines taken out
        (:meth:`without_lines`); NaN where the simulation diverged.
        """
        cov = sim.covered
        parts = []
        for c in CHANNELS:
            w = self.weights.get(c, 0.0)
            if w > 0:
                r = self._meas[c][cov] - sim.channel(c)[cov]
                src = 'angular_acceleration' if c == 'chamber_speed' else c
                parts.append(w * self.without_lines(src, r, cov))
        return parts

    def set_transition_durations(
        self, values: Mapping[str, float]
    ) -> tuple[tuple[float, float, float], ...]:
        """Choose the duration and shape of each drive transition by the torsion moment.

        The drive angles at the stick phases on either side of a speed step fix its
        mid-time; its duration and shape (linear or raised cosine) they fix only
        through the angles of stick phases inside it, which may be few or none
        (:func:`~tribo_estimation.core.drive.untimed_transitions`). The belt moment
        ``C2*(phi0 - phi2) + K2*(w0 - w2)`` (Equ. 2) that drives the shaft while it
        lasts decides them. Per transition of the placed profile
        (:func:`~tribo_estimation.core.drive.transitions`), for either shape the
        duration whose model ``values`` fits the torsion moment of the segments
        spanning it best (least squares): a grid from the shortest piece
        (:data:`~tribo_estimation.core.drive.MIN_PIECE`) to the room between the
        neighbouring knots (at most
        :data:`~tribo_estimation.core.drive.TRANSITION_MAX`), then golden-section
        steps around the best, at the mid-time the angles give; a transition that
        angles inside time keeps its placed duration and shape unless one of these
        removes more than half of the excess over the noise there
        (:data:`_TRANSITION_SHARE`). The choice holds for every speed-sensor cell from then on
        (:attr:`durations`).

        Parameters
        ----------
        values : mapping of str to float
            The model (a fitted baseline).

        Returns
        -------
        tuple of (float, float, float)
            Mid-time [s], duration [s] and shape (0 linear,
            :data:`~tribo_estimation.core.drive.COSINE`) of each transition.
        """
        self.durations = ()
        self._drive_stale()
        self.simulate(values)  # the profile of the values' speed-sensor cell
        if self._stick_samples.size + self._slip_samples.size < _MIN_ANGLES:
            return ()  # no drive angles: the smoothed speed's profile has no corners to time
        drive = self.drive_estimate
        seg = self.segments
        rec = self.record
        angles = rec.time[np.concatenate((self._stick_samples, self._slip_samples))]
        open_ = set(untimed_transitions(drive, angles))
        t_start = rec.time[seg.start]
        t_stop = rec.time[np.minimum(seg.stop, rec.time.size) - 1]
        chosen: list[tuple[float, float, float]] = []
        for j in transitions(drive):
            tk = drive.knot_time
            mid = 0.5 * float(tk[j] + tk[j + 1])
            room = min(mid - float(tk[j - 1]), float(tk[j + 2]) - mid)
            longest = min(TRANSITION_MAX, 2.0 * room)
            # the segments whose span meets the longest transition tried
            mask = (t_stop >= mid - 0.5 * longest) & (t_start <= mid + 0.5 * longest)
            if longest <= MIN_PIECE or not mask.any():
                continue
            fixed = tuple(chosen)
            best: tuple[float, float, float] = (math.inf, math.nan, math.nan)
            bar = math.inf  # what a tried transition's cost must come under
            if j not in open_:  # timed by angles inside: the placed transition competes
                placed = (float(tk[j + 1] - tk[j]), float(drive.shapes()[j]))
                r = self._transition_residual(values, drive, fixed, mid, mask, *placed)
                c_placed = _squares(r)
                best = (c_placed, *placed)
                if math.isfinite(c_placed):
                    excess = max(c_placed - r.size * noise_floor(r) ** 2, 0.0)
                    bar = c_placed - _TRANSITION_SHARE * excess
            n = 1 + int(_DURATION_PER_OCTAVE * math.log2(longest / MIN_PIECE))
            grid = np.geomspace(MIN_PIECE, longest, max(n, 2))
            for shape in (0.0, COSINE):
                trial = functools.partial(
                    self._transition_residual, values, drive, fixed, mid, mask, shape=shape
                )

                def cost(d: float, trial: Callable[..., FloatArray] = trial) -> float:
                    return _squares(trial(d))

                costs = [cost(float(d)) for d in grid]
                k = int(np.argmin(costs))
                # golden section in log(duration) between the best's grid neighbours
                best_d, best_c = _golden_log(
                    cost, float(grid[max(k - 1, 0)]), float(grid[min(k + 1, grid.size - 1)]),
                    _DURATION_GOLDEN,
                )  # fmt: skip
                if costs[k] <= best_c:
                    best_d, best_c = float(grid[k]), costs[k]
                if best_c < min(best[0], bar):
                    best = (best_c, best_d, shape)
            if math.isfinite(best[0]):
                chosen.append((mid, best[1], best[2]))
        self.durations = tuple(chosen)
        if self.drive_estimate is not drive:  # the trials left theirs: the cell's, timed
            key = self._instrument  # (tau, offset, shape, *ripple, *torque)
            end = 3 + len(_NO_RIPPLE)
            self._fit_drive(key[0], key[1], key[3:end], (key[end], key[end + 1]))
        return self.durations

    def _transition_residual(
        self,
        values: Mapping[str, float],
        drive: DriveEstimate,
        fixed: tuple[tuple[float, float, float], ...],
        mid: float,
        mask: npt.NDArray[np.bool_],
        duration: float,
        shape: float,
    ) -> FloatArray:
        """Return the torsion moment's residual [N m] of the segments ``mask``.

        Simulated with ``drive`` given the transitions ``fixed`` and one of ``duration``
        [s] and ``shape`` [-] at ``mid`` [s] (its knot speeds kept) and the model
        ``values``, whose speed-sensor cell is the current one.
        """
        trial = with_durations(drive, (*fixed, (mid, duration, shape)))
        self.drive_estimate = trial
        self._knots = DriveKnots.from_estimate(trial)
        sim = self.simulate(values, mask)
        cov = sim.covered
        return np.asarray(self.record.torsion_moment[cov] - sim.torsion_moment[cov])

    def _drive_stale(self) -> None:
        """Make the next simulation fit the drive profile again (same sensor state)."""
        self._instrument = (*self._instrument[:3], math.nan)

    def _set_instrument(
        self,
        tau: float,
        offset: float,
        shape: float = 0.0,
        ripple: tuple[float, ...] = _NO_RIPPLE,
        torque: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        """Invert the speed sensor (lag ``tau`` [s], offset [rad/s]) at the segment starts.

        While stuck the discs share one speed w with w' = the measured
        acceleration a, and a first-order sensor shows y with ``w = y + tau*y'``,
        ``y' = a`` (slowly varying a): ``w = y - offset + tau*a``, taken from a
        regression over the stick phase, which gives the sensor's state there too,
        of first or (``shape`` > 0, :data:`.records.SPEED_SHAPE`) second order
        (:func:`.instrument.stuck_sensor_states`); the drive profile uses the
        first-order inversion. The measured chamber speed channel is
        ``w1(start) + integral of a`` per segment (a sliding start's w1 from the torsion
        moment, :func:`.segments.sliding_chamber_speed`). The drive profile is then
        re-fitted (:meth:`_fit_drive`).

        Parameters
        ----------
        tau : float
            Speed-sensor lag [s].
        offset : float
            Speed-sensor offset [rad/s].
        shape : float
            The sensor's second order (:data:`.records.SPEED_SHAPE`) [-].
        ripple : tuple of float
            The model's drive ripple (amplitude [rad/s], frequency [Hz], phase [rad],
            second harmonic's amplitude [rad/s] and phase [rad]; the angle-locked
            ripple's relative amplitude [-], order [-] and phase [rad], its second
            harmonic's relative amplitude [-] and phase [rad]).
        torque : tuple of float
            The model's torque offset [N m] and drift [N m/s].
        """
        key = (tau, offset, shape, *ripple, *torque)
        if self._instrument == key:
            return
        same_sensor = self._instrument[:3] == (tau, offset, shape)
        self._instrument = key
        if same_sensor:  # only the model's drive ripple or torque offset changed
            self._fit_drive(tau, offset, ripple, torque)
            return
        rec = self.record
        if tau > 0.0:
            a2 = shape * tau * tau
            w, y0, yd0 = stuck_sensor_states(
                rec, self.segments, self._speed_start, self._speed_slope, tau,
                a2 if a2 > FIRST_ORDER_A2 * rec.dt * rec.dt else 0.0,
                guard=rig_half(CHAMBER_HALF, rec.fs, self.rig.fastest_mode_hz, least=1),
            )  # fmt: skip
            self._w_start = w - offset - self._speed_error(tau)[self.segments.start]
            self._sensor_start = (y0, yd0)
        else:
            self._w_start = self._speed_stuck - offset - self._speed_error(0.0)[self.segments.start]
            self._sensor_start = (self._speed_start, self._speed_slope[self.segments.start])
        w1 = np.full(rec.time.size, np.nan)
        acc = rec.angular_acceleration
        # a stuck start's chamber speed is the shaft's; a sliding one's is the model's
        # start state (the torsion moment's slope)
        w1_start = np.where(self.segments.sliding_starts, self._w1_slide, self._w_start)
        for k, (a, b) in enumerate(zip(self.segments.start, self.segments.stop, strict=True)):
            inc = 0.5 * (acc[a + 1 : b] + acc[a : b - 1]) * rec.dt
            w1[a] = w1_start[k]
            w1[a + 1 : b] = w1_start[k] + np.cumsum(inc)
        self._meas['chamber_speed'] = w1
        self._fit_drive(tau, offset, ripple, torque)

    def _fit_drive(
        self,
        tau: float,
        offset: float,
        ripple: tuple[float, ...],
        torque: tuple[float, float],
    ) -> None:
        """Fit the drive profile to the drive angles (stick and sliding-stretch samples).

        The profile is a function of the arguments alone, whatever was simulated
        before: its corners are those placed for the speed sensor's cell (lag in steps
        of :data:`_REPLACE_LAG`, offset in steps of :data:`_REPLACE_OFFSET`: a sensor
        change moves the corners by about the change of the lag, below the
        placement's 0.1 ms grid within a cell), placed once per cell: the cell without
        a sensor from the smoothed speed's profile, every other cell locally (fine
        grids) from that cell's corners; the knot speeds are then solved for these arguments
        (:meth:`_angle_drive`, whose parameters ``tau``, ``offset``, ``ripple`` and
        ``torque`` these are).
        """
        if self._stick_samples.size + self._slip_samples.size < _MIN_ANGLES:
            # no drive angles: the smoothed shaft speed alone
            self.drive_estimate = self._sliding_drive(offset)
        else:
            cell = (round(tau / _REPLACE_LAG), round(offset / _REPLACE_OFFSET))
            placed = self._placed.get(cell)
            if placed is None:
                # the sensor-free cell is placed when the problem is built
                ref = self._placed.get((0, 0))
                placed = self._angle_drive(
                    cell[0] * _REPLACE_LAG, cell[1] * _REPLACE_OFFSET, _NO_RIPPLE, (0.0, 0.0),
                    self._drive_speed0 if ref is None else ref, place=True,
                    local=ref is not None,
                )  # fmt: skip
                self._placed[cell] = placed
            if self.durations:
                placed = with_durations(placed, self.durations)
            self.drive_estimate = self._angle_drive(
                tau, offset, ripple, torque, placed, place=False
            )
        self._knots = DriveKnots.from_estimate(self.drive_estimate)

    def _angle_drive(
        self,
        tau: float,
        offset: float,
        ripple: tuple[float, ...],
        torque: tuple[float, float],
        drive: DriveEstimate,
        *,
        place: bool,
        local: bool = False,
    ) -> DriveEstimate:
        """Return the drive profile fitted to the drive angles (stick and sliding samples).

        The speed sensor is inverted, the model's torque offset and drift taken
        off the torsion moment and the model's drive-speed ripple (its angle)
        taken out.

        Parameters
        ----------
        tau : float
            Speed-sensor lag [s].
        offset : float
            Speed-sensor offset [rad/s].
        ripple : tuple of float
            Drive ripple (amplitude [rad/s], frequency [Hz], phase [rad], second
            harmonic's amplitude [rad/s] and phase [rad]; the angle-locked ripple's
            relative amplitude [-], order [-] and phase [rad], its second harmonic's
            relative amplitude [-] and phase [rad]).
        torque : tuple of float
            Torque offset [N m] and drift [N m/s].
        drive : DriveEstimate
            The profile to start from (its corners kept unless ``place``).
        place : bool
            Search the corner times.
        local : bool
            The corners of ``drive`` were placed before (for another speed-sensor
            cell): searched locally from there (fine grids only).

        Returns
        -------
        DriveEstimate
            The profile.
        """
        rec = self.record
        # drive angle = shaft angle (integral of the speed channel, less the offset; a
        # lag shifts it by -tau*(y(t) - y(t_first))) - belt deflection, which Equ. 2
        # gives from the moment q2 = C2*(phi0 - phi2) + K2*(w0 - w2) = I2*w2' + M:
        # while stuck M = I1*w1' + K1*w + M_t with w1' = w2' (the accelerometer), in a
        # sliding stretch M is observed alike (Equ. 1) and w2' is the slope of the
        # speed channel with its lag inverted; the profile is fitted to these angles
        rig = self.rig
        j = np.concatenate((self._stick_samples, self._slip_samples))
        n_stick = self._stick_samples.size
        y = self._smooth_speed[j]
        slope = self._speed_slope[j]
        w = y - offset + tau * slope
        t = rec.time[j]
        accel = self._smooth_accel[j]
        moment = self._smooth_torque[j] - torque[0] - torque[1] * t
        w1 = w.copy()
        shaft_accel = accel.copy()
        if n_stick < j.size:
            s = self._slip_samples
            w1[n_stick:] = self._w1_slip[s]
            shaft_accel[n_stick:] = slope[n_stick:] + tau * self._speed_curv[s]
        q2 = rig.I1 * accel + rig.I2 * shaft_accel + rig.K1 * w1 + moment
        phi2 = (
            self._shaft_angle[j]
            - offset * (t - rec.time[0])
            + tau * (y - float(self._smooth_speed[0]))
            - self._drift_angle(tau)[j]
        )
        amp, freq, phase, amp2, phase2, rel, order, aphase, rel2, aphase2 = ripple
        ripple_angle = np.zeros_like(t)
        if amp2 != 0.0 and freq > 0.0:  # the second harmonic's angle (kernel.drive_angle)
            om2 = 4.0 * math.pi * freq
            ripple_angle = amp2 / om2 * (math.cos(phase2) - np.cos(om2 * t + phase2))
        if amp != 0.0 and freq > 0.0:  # the ripple's angle (kernel.drive_angle)
            om = 2.0 * math.pi * freq
            ripple_angle = ripple_angle + amp / om * (math.cos(phase) - np.cos(om * t + phase))
        hints = self._ramp
        # the drive's known start speed only where the ramp begins at the first sample:
        # a wait's own angles pin its speed; pinned as well, a tachometer offset (a
        # linear drift of the angles that a common shift of the knot speeds takes up)
        # would move the start-up's corners
        start = self._start_speed if hints is not None else None
        # the damping term K2*(w - w0) needs w0: the starting profile first, then once
        # more with the profile from the angles; the smoothed speed blurs a speed
        # step over 150 ms, so its angles bias the corners: they are placed again
        # (locally) with the angles of the first placement
        for it in range(2):
            w0 = drive.speed(t)
            locked = np.zeros_like(t)
            if (rel != 0.0 or rel2 != 0.0) and order > 0.0:  # kernel.drive_angle
                n_theta = order * drive.angle(t)  # on the profile's angle
                w0 = w0 * (
                    1.0 + rel * np.sin(n_theta + aphase) + rel2 * np.sin(2.0 * n_theta + aphase2)
                )
                locked = rel / order * (math.cos(aphase) - np.cos(n_theta + aphase)) + rel2 / (
                    2.0 * order
                ) * (math.cos(aphase2) - np.cos(2.0 * n_theta + aphase2))
            defl = -(q2 + rig.K2 * (w - w0)) / rig.C2
            drive = refine_with_angles(
                drive, t, phi2 - defl - ripple_angle - locked, hints, place=place,
                start_speed=start, keep_corners=local or it > 0,
                prior=self._drive_speed0,
            )  # fmt: skip
        return drive

    def _speed_error(self, tau: float) -> FloatArray:
        """Return the speed channel's slowly varying error at the sticks [rad/s].

        :func:`.instrument.speed_error_at_sticks` with the sensor's lag ``tau`` [s]
        inverted (one per lag: kept; zeros without :attr:`speed_calibration`); taken off
        the stuck starts' speed and, integrated (:meth:`_drift_angle`), off the shaft
        angle.
        """
        out = self._speed_errors.get(tau)
        if out is None:
            if self.speed_calibration:
                out = speed_error_at_sticks(
                    self.record, self.rig, self.segments.stick_phases(), tau, self._speed_slope
                )
            else:
                out = np.zeros(self.record.time.size)
            self._speed_errors[tau] = out
        return out

    def _drift_angle(self, tau: float) -> FloatArray:
        """Return the integral of :meth:`_speed_error` from the record's start [rad]."""
        out = self._drift_angles.get(tau)
        if out is None:
            out = running_integral(self._speed_error(tau), self.record.dt)
            self._drift_angles[tau] = out
        return out

    def _sliding_drive(self, offset: float) -> DriveEstimate:
        """Return the drive profile of a record without drive angles (fewer than 20).

        The smoothed shaft speed (:func:`~tribo_estimation.core.drive.estimate_drive`)
        less the speed sensor's offset; it blurs the start-up ramp over
        :data:`~tribo_estimation.core.drive.SMOOTH_TIME`, so a record whose start-up
        ramp begins at its first sample gets RIG.yaml's ramp (0 at the start, the
        measured speed at the ramp's end) instead.

        Parameters
        ----------
        offset : float
            Speed-sensor offset [rad/s].

        Returns
        -------
        DriveEstimate
            The profile.
        """
        d = self._drive_speed0.shifted(-offset)
        if self._ramp is None:
            return d
        t0, t_ramp = self._ramp.tolist()
        t_after = t_ramp + SMOOTH_TIME
        if t_after >= float(d.knot_time[-1]):
            return d
        keep = d.knot_time > t_after
        tk = np.concatenate(([t0, t_ramp], d.knot_time[keep]))
        vk = np.concatenate(([0.0, float(d.speed(t_after))], d.knot_speed[keep]))
        return replace(d, knot_time=tk, knot_speed=vk, shape=None)

    def measured(self, name: str) -> FloatArray:
        """Return a compared measured channel.

        Parameters
        ----------
        name : str
            One of :data:`.records.CHANNELS`.

        Returns
        -------
        FloatArray
            The channel [unit] (the chamber speed is NaN off-segment).
        """
        return self._meas[name]

    def residual_vector(self, sim: SimulatedRecord) -> FloatArray:
        """Return the weighted residuals of all channels over the covered samples.

        Parameters
        ----------
        sim : SimulatedRecord
            The model output.

        Returns
        -------
        FloatArray
            Residuals times channel weights [-] (a diverged simulation gives 1e3).
        """
        v = np.concatenate(self._weighted_parts(sim))
        # a diverged simulation (NaN) is a very bad fit, not a crash of the optimiser
        return np.where(np.isfinite(v), v, 1e3)

    def cost(self, sim: SimulatedRecord) -> float:
        """Return the mean squared weighted residual per sample, summed over channels.

        Parameters
        ----------
        sim : SimulatedRecord
            The model output.

        Returns
        -------
        float
            The cost [-].
        """
        v = self.residual_vector(sim)
        n = int(np.count_nonzero(sim.covered))
        return float(np.sum(v * v)) / max(n, 1)

    def torque_rms(self, sim: SimulatedRecord) -> float:
        """Return the rms of the torsion-moment residual (measured - simulated).

        Parameters
        ----------
        sim : SimulatedRecord
            The model output.

        Returns
        -------
        float
            The rms over the covered samples [N m].
        """
        cov = sim.covered
        r = self.record.torsion_moment[cov] - sim.torsion_moment[cov]
        r = self.without_lines('torsion_moment', r, cov)
        return float(np.sqrt(np.mean(r * r)))

    def without_lines(
        self, channel: str, residual: FloatArray, covered: npt.NDArray[np.bool_]
    ) -> FloatArray:
        """Return a residual with the channel's mains lines projected out.

        The lines (:attr:`hum_lines`, instrument, not physics: :func:`.identify_hum`)
        are linear nuisance terms: the least-squares sine and cosine at each of their
        frequencies over the compared samples are taken out, whatever the model.

        Parameters
        ----------
        channel : str
            The raw channel (``torsion_moment``, ``angular_acceleration``, ``speed``).
        residual : FloatArray
            Measured - simulated over the ``covered`` samples [unit].
        covered : numpy.ndarray of bool
            The compared samples of the record.

        Returns
        -------
        FloatArray
            The residual without the lines [unit].
        """
        freqs = self.hum_lines.get(channel, ())
        if not freqs or residual.size < 4 * len(freqs) + 1:
            return residual
        if not np.all(np.isfinite(residual)):
            return residual
        q = self._line_basis(freqs, covered)
        return np.asarray(residual - q @ (q.T @ residual), dtype=np.float64)

    def _line_basis(self, freqs: tuple[float, ...], covered: npt.NDArray[np.bool_]) -> FloatArray:
        """Return an orthonormal basis of the sines and cosines at ``freqs`` [Hz].

        Over the ``covered`` samples; projecting on it is the least-squares fit of
        the lines (the left singular vectors above ``numpy.linalg.lstsq``'s default
        cut-off: lines closer than the record resolves count once). The basis per
        set of frequencies is kept for the samples it was last asked for.
        """
        last = self._lines_cache.get(freqs)
        if last is not None and np.array_equal(last[0], covered):
            return last[1]
        t = self.record.time[covered]
        cols: list[FloatArray] = []
        for f in freqs:
            w = 2.0 * math.pi * f * t
            cols.extend((np.sin(w), np.cos(w)))
        u, sv, _ = np.linalg.svd(np.column_stack(cols), full_matrices=False)
        keep = sv > sv[0] * np.finfo(float).eps * max(t.size, len(cols))
        q = np.ascontiguousarray(u[:, keep])
        self._lines_cache[freqs] = (covered.copy(), q)
        return q

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
        """Fit the ``free`` parameters by least squares of the output error.

        Uses :func:`~tribo_estimation.core.lsq.levenberg_marquardt` on
        value/scale coordinates (log for time constants).

        Parameters
        ----------
        free : sequence of ParamSpec
            The fitted parameters.
        start : mapping of str to float
            Their start values (other names in it stay fixed).
        fixed : mapping of str to float, optional
            Further model values held constant.
        seg_mask : numpy.ndarray of bool, optional
            Segments fitted (default: all).
        max_nfev : int
            Most simulations.

        Returns
        -------
        FitOutcome
            Values, cost, evaluations, convergence and standard errors.
        """
        fixed_vals = {k: float(v) for k, v in start.items() if k not in {p.name for p in free}}
        fixed_vals.update(fixed or {})
        if not free:
            sim = self.simulate(fixed_vals, seg_mask)
            return FitOutcome(dict(fixed_vals), self.cost(sim), 1, True)
        values, sse, nfev, converged, se = scaled_fit(
            lambda v: self.residual_vector(self.simulate(v, seg_mask)),
            free, {**start, **fixed_vals}, max_nfev,
        )  # fmt: skip
        n = int(np.count_nonzero(self.segments.sample_mask(self.record.time.size, seg_mask)))
        return FitOutcome(values, sse / max(n, 1), nfev, converged, se)
