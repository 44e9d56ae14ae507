"""Independent reference simulator of the rig (the truth for tests and benchmarks).

This module shares **no computational code** with the fitting path: its own
plain-Python right-hand side of the equations of motion (paper Equ. 1, 2, 3,
6, 8 as corrected in the physics notes, with the paper's deceleration rule),
its own drive profile, and scipy's ``solve_ivp`` (DOP853) as the integrator.
From :mod:`.model` it takes only the parameter dataclasses (``RigParams``,
``FrictionLaw``, ``Extensions``, ``DriveProfile``, ``RigState`` values); the
result container is :class:`.simulate.SimResult`. A fit that agrees with records
from here is checked against an implementation written separately from it.

Equations (K = viscous damping, C = torsional stiffness; v = w2 - w1)::

    I1*w1' = -K1*w1 - C1*phi1 - M_b(w1) + M                        (1)
    I2*w2' = -K2*(w2 - w0) - C2*(phi2 - phi0) - M                  (2)
    sliding:  M = F_N*R*dir*mu(|v|) + viscous*v                    (3), (8)
    sticking: w1 = w2, M = M_stick = (I1*Q2 - I2*Q1)/(I1 + I2)     (6)

with ``Q1``, ``Q2`` the non-friction moments on the chamber and the shaft,
``mu = (mu0 - mu_inf)*exp(-k*|v|) + mu_inf`` rising, ``mu = mu_inf`` after the
slip-speed peak of a sliding phase (deceleration rule), static coefficient
``mu_s = mu0`` (plus the dwell-time stiction extension). Extensions of the model
(:class:`.model.Extensions`): dwell-time stiction, frictional lag (the sliding
coefficient follows Equ. 8 through a first-order lag starting at ``mu_s``),
contact viscous friction, drift of mu0/mu_inf with test time, drive ripple and
the chamber bearing's (regularised) Coulomb moment. The measurement-side
extensions (torque offset, drift, lag) belong to the instrument model
(:mod:`.reference_records`).

Segments: each stick or slip phase is integrated as one smooth segment that ends
at a terminal event located by scipy's root finder: slip end ``v = 0``, slip-speed
peak (``dv/dt = 0``, deceleration rule), breakaway ``|M_stick| = F_N*R*mu_s``.
Drive-profile breakpoints also end a segment (the profile has kinks there).
Outputs are read from the dense output at the sample instants.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.integrate import solve_ivp

from tribo_estimation.core.model import (
    DriveProfile,
    Extensions,
    FrictionLaw,
    RigParams,
    RigState,
)
from tribo_estimation.core.simulate import SimResult
from tribo_estimation.errors import InvalidParameterError, SimulationError

# event kinds of the log (same codes as the compiled kernel's log, so the two logs compare)
EV_SLIP_END = 1  # slip ended, discs stick (-1: slip ended without sticking, reversal)
EV_PEAK = 2  # slip-speed peak (deceleration rule switches to mu_inf)
EV_BREAKAWAY = 3  # stick ended


@dataclass(frozen=True)
class SpeedProfile:
    """Describe a piecewise-linear drive speed.

    w0(t) [rad/s] through ``breakpoints``
    ``((t0, w0), (t1, w1), ...)`` (time [s] increasing, speed [rad/s]); constant
    before the first and after the last breakpoint. The drive angle phi0(t) [rad]
    is its exact integral from t = 0. A start-up ramp is ``((0, 0), (0.2, w))``,
    a speed step from 12 to 30 rpm at 2 s in 50 ms ``((0, 0), (0.2, w12),
    (2.0, w12), (2.05, w30))``.
    """

    breakpoints: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        """Refuse non-finite or non-increasing breakpoints."""
        bp = self.breakpoints
        if len(bp) < 1:
            raise InvalidParameterError('SpeedProfile.breakpoints needs at least one point')
        for t, w in bp:
            if not (math.isfinite(t) and math.isfinite(w)):
                raise InvalidParameterError(f'SpeedProfile breakpoint ({t!r}, {w!r}) not finite')
        ts = [t for t, _ in bp]
        if any(b <= a for a, b in itertools.pairwise(ts)):
            raise InvalidParameterError(f'SpeedProfile breakpoint times must increase: {ts}')

    # ------------------------------------------------------------------ constructors
    @classmethod
    def constant(cls, speed: float) -> SpeedProfile:
        """Constant speed [rad/s] for all t (phi0 = speed*t)."""
        return cls(((0.0, float(speed)),))

    @classmethod
    def startup(cls, speed: float, ramp: float = 0.2) -> SpeedProfile:
        """At rest before t = 0, linear start-up to ``speed`` [rad/s] over ``ramp`` [s]."""
        if ramp <= 0.0:
            return cls.constant(speed)
        return cls(((0.0, 0.0), (float(ramp), float(speed))))

    @classmethod
    def from_drive(cls, drive: DriveProfile) -> SpeedProfile:
        """Build the same w0(t), phi0(t) as the model's :class:`.model.DriveProfile`."""
        return cls.startup(drive.nominal_speed, drive.ramp_time)

    @classmethod
    def steps(
        cls,
        speeds: Sequence[float],
        step_times: Sequence[float],
        *,
        ramp: float = 0.2,
        transition: float = 0.05,
    ) -> SpeedProfile:
        """Build a start-up ramp followed by speed steps.

        Start-up ramp (``ramp`` [s], 0 = none) to ``speeds[0]``, then a linear change
        to ``speeds[i]`` over ``transition`` [s] starting at ``step_times[i-1]`` [s].
        """
        if len(speeds) != len(step_times) + 1:
            raise InvalidParameterError('steps: need one step time less than speeds')
        bp: list[tuple[float, float]] = (
            [(0.0, 0.0), (ramp, speeds[0])] if ramp > 0.0 else [(0.0, speeds[0])]
        )
        for ts, w_prev, w_new in zip(step_times, speeds[:-1], speeds[1:], strict=True):
            bp.append((float(ts), float(w_prev)))
            bp.append((float(ts) + transition, float(w_new)))
        return cls(tuple(bp))

    # ------------------------------------------------------------------ evaluation
    def _cum_angles(self) -> list[float]:
        bp = self.breakpoints
        cum = [0.0] * len(bp)
        # angle at the first breakpoint, integrating from 0 (constant speed before it)
        t0, w0 = bp[0]
        cum[0] = w0 * t0
        for i in range(1, len(bp)):
            (ta, wa), (tb, wb) = bp[i - 1], bp[i]
            cum[i] = cum[i - 1] + 0.5 * (wa + wb) * (tb - ta)
        return cum

    def speed_at(self, t: float) -> float:
        """w0(t) [rad/s] at one instant t [s]."""
        bp = self.breakpoints
        if t <= bp[0][0]:
            return bp[0][1]
        if t >= bp[-1][0]:
            return bp[-1][1]
        i = bisect.bisect_right(self.times, t)
        (ta, wa), (tb, wb) = bp[i - 1], bp[i]
        return wa + (wb - wa) * (t - ta) / (tb - ta)

    def angle_at(self, t: float) -> float:
        """phi0(t) = integral_0^t w0 dt' [rad] at one instant t [s]."""
        bp = self.breakpoints
        cum = self.cum_angles
        if t <= bp[0][0]:
            return cum[0] + bp[0][1] * (t - bp[0][0])
        if t >= bp[-1][0]:
            return cum[-1] + bp[-1][1] * (t - bp[-1][0])
        i = bisect.bisect_right(self.times, t)
        (ta, wa), (tb, wb) = bp[i - 1], bp[i]
        s = t - ta
        return cum[i - 1] + wa * s + 0.5 * (wb - wa) / (tb - ta) * s * s

    @cached_property
    def times(self) -> list[float]:
        """Breakpoint times [s]."""
        return [t for t, _ in self.breakpoints]

    @cached_property
    def cum_angles(self) -> list[float]:
        """phi0 at the breakpoints [rad]."""
        return self._cum_angles()

    def speed(self, t: np.ndarray | float) -> np.ndarray:
        """w0(t) [rad/s], vectorised."""
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        bp = np.asarray(self.breakpoints, dtype=float)
        out: np.ndarray = np.interp(tt, bp[:, 0], bp[:, 1])
        return out

    def angle(self, t: np.ndarray | float) -> np.ndarray:
        """phi0(t) [rad], vectorised."""
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        return np.array([self.angle_at(float(x)) for x in tt])


@dataclass(frozen=True)
class Unmodelled:
    """Describe effects outside the discrepancy workflow's candidate library.

    Benchmark truth (no fitting model has them): ``backlash`` full width [rad] of a dead band in the
    belt deflection phi2 - phi0 of Equ. 2 (drive backlash: the belt transmits no
    torque within +-backlash/2); ``stiffness_drift`` relative change of the
    measuring-spring stiffness C1 of Equ. 1 per second of test time [1/s]
    (C1(t) = C1*(1 + stiffness_drift*t); the torsion channel shows C1(t)*phi1).
    """

    backlash: float = 0.0
    stiffness_drift: float = 0.0


class _Model:
    """Plain-Python right-hand side of the rig (see the module docstring)."""

    def __init__(
        self,
        rig: RigParams,
        law: FrictionLaw,
        drive: SpeedProfile,
        ext: Extensions,
        unmodelled: Unmodelled | None = None,
    ) -> None:
        self.I1, self.K1, self.C1 = rig.I1, rig.K1, rig.C1
        self.un = unmodelled or Unmodelled()
        self.I2, self.K2, self.C2 = rig.I2, rig.K2, rig.C2
        self.fnr = rig.F_N * rig.R
        self.mu0, self.muinf, self.k = law.mu0, law.mu_inf, law.k
        self.drive = drive
        self.ext = ext
        self.rip_om = 2.0 * math.pi * ext.ripple_freq

    # drive with ripple
    def w0(self, t: float) -> float:
        w = self.drive.speed_at(t)
        e = self.ext
        if e.ripple_amp != 0.0:
            w += e.ripple_amp * math.sin(self.rip_om * t + e.ripple_phase)
        return w

    def phi0(self, t: float) -> float:
        a = self.drive.angle_at(t)
        e = self.ext
        if e.ripple_amp != 0.0 and self.rip_om > 0.0:
            a += (
                e.ripple_amp
                / self.rip_om
                * (math.cos(e.ripple_phase) - math.cos(self.rip_om * t + e.ripple_phase))
            )
        return a

    def levels(self, t: float) -> tuple[float, float]:
        return self.mu0 + self.ext.drift_mu0 * t, self.muinf + self.ext.drift_mu_inf * t

    def mu_slide(self, t: float, v_abs: float, peak: bool) -> float:
        mu0, muinf = self.levels(t)
        if peak:
            return muinf
        shape = self.ext.stribeck_shape  # Stribeck exponent delta = 1 + shape (0: Equ. 8)
        if shape == 0.0:
            return (mu0 - muinf) * math.exp(-self.k * v_abs) + muinf
        return (mu0 - muinf) * math.exp(-((self.k * v_abs) ** (1.0 + shape))) + muinf

    def mu_static(self, t: float, t_stick: float) -> float:
        mu0, _ = self.levels(t)
        g = self.ext.stiction_gain
        if g != 0.0:
            tau = self.ext.stiction_tau
            mu0 += g * (1.0 - math.exp(-t_stick / tau)) if tau > 0.0 else g
        return mu0

    def c1(self, t: float) -> float:
        """Measuring-spring stiffness at test time ``t`` [N m/rad] (:class:`Unmodelled`)."""
        return self.C1 * (1.0 + self.un.stiffness_drift * t)

    def q1(self, phi1: float, w1: float, t: float = 0.0) -> float:
        q = -self.K1 * w1 - self.c1(t) * phi1
        mb = self.ext.bearing_moment
        if mb != 0.0:
            reg = self.ext.bearing_reg_speed
            q -= mb * w1 / math.sqrt(w1 * w1 + reg * reg)
        return q

    def q2(self, t: float, phi2: float, w2: float) -> float:
        d = phi2 - self.phi0(t)
        half = 0.5 * self.un.backlash
        if half > 0.0:
            d = math.copysign(max(abs(d) - half, 0.0), d)
        return -self.K2 * (w2 - self.w0(t)) - self.C2 * d

    def m_stick(self, t: float, phi1: float, w: float, phi2: float) -> float:
        """Equ. 6 [N m]."""
        return (self.I1 * self.q2(t, phi2, w) - self.I2 * self.q1(phi1, w, t)) / (self.I1 + self.I2)

    def rhs(
        self, t: float, y: Sequence[float] | np.ndarray, stuck: bool, direction: float, peak: bool
    ) -> tuple[float, float, float, float, float, float]:
        """(phi1', w1', phi2', w2', lag', M) [rad/s, rad/s^2, rad/s, rad/s^2, 1/s, N m]."""
        phi1, w1, phi2, w2, lag = y[0], y[1], y[2], y[3], y[4]
        q1 = self.q1(phi1, w1, t)
        if stuck:
            q2 = self.q2(t, phi2, w1)
            s = self.I1 + self.I2
            wd = (q1 + q2) / s
            return w1, wd, w1, wd, 0.0, (self.I1 * q2 - self.I2 * q1) / s
        q2 = self.q2(t, phi2, w2)
        v = w2 - w1
        tau = self.ext.lag_tau
        if tau > 0.0:
            mu = lag
            dlag = (self.mu_slide(t, abs(v), peak) - lag) / tau
        else:
            mu = self.mu_slide(t, abs(v), peak)
            dlag = 0.0
        m = self.fnr * direction * mu + self.ext.viscous * v
        return w1, (q1 + m) / self.I1, w2, (q2 - m) / self.I2, dlag, m


def simulate_reference(
    rig: RigParams,
    friction: FrictionLaw,
    drive: DriveProfile | SpeedProfile,
    duration: float,
    fs: float = 10_000.0,
    *,
    initial: RigState | None = None,
    extensions: Extensions | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_segments: int = 1_000_000,
    unmodelled: Unmodelled | None = None,
) -> SimResult:
    """Compute the reference solution.

    No noise, no measurement side, at ``fs`` [Hz] for
    ``duration`` [s] from ``initial`` (default at rest, sticking, t = 0).

    Same output arrays as :func:`.simulate.simulate`; ``event_times`` [s] and
    ``event_kinds`` (``EV_*``) log every switching event. ``rtol``/``atol`` of
    DOP853 (1e-8 is ample for records; the default serves the kernel's
    convergence tests).
    """
    if not (math.isfinite(duration) and duration > 0.0 and math.isfinite(fs) and fs > 0.0):
        raise InvalidParameterError(f'bad duration {duration!r} s or fs {fs!r} Hz')
    n = round(duration * fs)
    if n < 1:
        raise InvalidParameterError(f'duration {duration} s at fs {fs} Hz gives no sample')
    prof = drive if isinstance(drive, SpeedProfile) else SpeedProfile.from_drive(drive)
    ext = extensions if extensions is not None else Extensions()
    mdl = _Model(rig, friction, prof, ext, unmodelled)
    st = initial if initial is not None else RigState.at_rest()
    t_start = st.t
    t_end = t_start + n / fs
    times = t_start + np.arange(n) / fs
    y = np.array([st.phi1, st.w1, st.phi2, st.w2, st.lag], dtype=float)
    stuck = st.stuck
    direction = float(st.slip_dir)
    peak = st.peak_passed
    t_stick_start = st.t - st.stick_time
    vmax = st.v_max
    if stuck:
        w = (rig.I1 * y[1] + rig.I2 * y[3]) / (rig.I1 + rig.I2)
        y[1] = y[3] = w
    out = np.full((7, n), np.nan)  # torsion, accel, w2, M, v, stick, w1
    kinks = [tb for tb in prof.times if t_start < tb < t_end]
    t = t_start
    ev_times: list[float] = []
    ev_kinds: list[int] = []
    k = 0
    segments = 0
    while True:
        segments += 1
        if segments > max_segments:
            raise SimulationError(f'reference: more than {max_segments} segments')
        i_k = bisect.bisect_right(kinks, t)
        t_stop = kinks[i_k] if i_k < len(kinks) else t_end
        mode = (stuck, direction, peak)

        def rhs(tt: float, yy: np.ndarray, mode: tuple[bool, float, bool] = mode) -> list[float]:
            d = mdl.rhs(tt, yy, *mode)
            return [d[0], d[1], d[2], d[3], d[4]]

        events: list[Callable[..., float]] = []
        if stuck:

            def ev_break(tt: float, yy: np.ndarray, t_ss: float = t_stick_start) -> float:
                ms = mdl.m_stick(tt, yy[0], yy[1], yy[2])
                return mdl.fnr * mdl.mu_static(tt, tt - t_ss) - abs(ms)

            events.append(ev_break)
        else:

            def ev_slip(tt: float, yy: np.ndarray, dr: float = direction) -> float:
                return float(dr * (yy[3] - yy[1]))

            events.append(ev_slip)
            if not peak:

                def ev_peak(
                    tt: float, yy: np.ndarray, mode: tuple[bool, float, bool] = mode
                ) -> float:
                    d = mdl.rhs(tt, yy, *mode)
                    return float(mode[1] * (d[3] - d[1]))

                events.append(ev_peak)
        for ev in events:
            ev.terminal = True  # type: ignore[attr-defined]
            ev.direction = -1  # type: ignore[attr-defined]
        sol = solve_ivp(
            rhs, (t, t_stop), y, method='DOP853', rtol=rtol, atol=atol,
            events=events, dense_output=True,
        )  # fmt: skip
        if sol.status == -1:
            raise SimulationError(f'reference integration failed at t = {t:.6f} s: {sol.message}')
        t_seg_end = float(sol.t[-1])
        last = sol.status == 0 and t_stop >= t_end
        k1 = k
        while k1 < n and (times[k1] < t_seg_end or (last and times[k1] <= t_seg_end)):
            k1 += 1
        if k1 > k:
            ys = sol.sol(times[k:k1])
            for j in range(k1 - k):
                yj = ys[:, j]
                d = mdl.rhs(float(times[k + j]), yj, *mode)
                out[0, k + j] = mdl.c1(float(times[k + j])) * yj[0]
                out[1, k + j] = d[1]
                out[3, k + j] = d[5]
            out[2, k:k1] = ys[3]
            out[4, k:k1] = ys[3] - ys[1]
            out[5, k:k1] = 1.0 if stuck else 0.0
            out[6, k:k1] = ys[1]
            if not stuck:
                vmax = max(vmax, float(np.max(np.abs(ys[3] - ys[1]))))
            k = k1
        y = np.asarray(sol.y[:, -1], dtype=float).copy()
        t = t_seg_end
        if sol.status == 0:
            if last:
                break
            continue  # drive breakpoint: same mode, next segment
        fired = [i for i, te in enumerate(sol.t_events) if len(te) > 0]
        ev_times.append(t)
        if stuck:
            ev_kinds.append(EV_BREAKAWAY)
            ms = mdl.m_stick(t, y[0], y[1], y[2])
            mus = mdl.mu_static(t, t - t_stick_start)
            stuck = False
            direction = 1.0 if ms >= 0.0 else -1.0
            peak = False
            vmax = 0.0
            y[4] = mus
        elif fired[0] == 0:
            w = (rig.I1 * y[1] + rig.I2 * y[3]) / (rig.I1 + rig.I2)
            y[1] = y[3] = w
            ms = mdl.m_stick(t, y[0], w, y[2])
            if abs(ms) <= mdl.fnr * mdl.mu_static(t, 0.0):
                stuck = True
                t_stick_start = t
                ev_kinds.append(EV_SLIP_END)
            else:
                direction = 1.0 if ms >= 0.0 else -1.0
                ev_kinds.append(-EV_SLIP_END)
            peak = False
            vmax = 0.0
        else:
            peak = True
            ev_kinds.append(EV_PEAK)
    final = RigState(
        t=t_end,
        phi1=float(y[0]),
        w1=float(y[1]),
        phi2=float(y[2]),
        w2=float(y[3]),
        stuck=stuck,
        slip_dir=1 if direction >= 0 else -1,
        peak_passed=peak,
        v_max=vmax,
        stick_time=(t_end - t_stick_start) if stuck else 0.0,
        lag=float(y[4]),
    )
    return SimResult(
        time=times,
        torsion_moment=out[0].copy(),
        angular_acceleration=out[1].copy(),
        speed=out[2].copy(),
        friction_moment=out[3].copy(),
        slip_speed=out[4].copy(),
        stick=out[5] > 0.5,
        chamber_speed=out[6].copy(),
        final_state=final,
        n_events=len(ev_times),
        fs=fs,
        event_times=np.array(ev_times),
        event_kinds=np.array(ev_kinds, dtype=np.int64),
    )


def stick_intervals(
    event_times: np.ndarray, event_kinds: np.ndarray, t_first: float, t_last: float, stuck0: bool
) -> list[tuple[float, float]]:
    """List the exact stick phases of an event log.

    ``(start, end)`` [s], clipped to
    ``[t_first, t_last]`` [s]; ``stuck0`` whether the run started sticking.
    """
    out: list[tuple[float, float]] = []
    start: float | None = t_first if stuck0 else None
    for te, kind in zip(event_times.tolist(), event_kinds.tolist(), strict=True):
        if kind == EV_SLIP_END:
            start = te
        elif kind == EV_BREAKAWAY and start is not None:
            out.append((start, te))
            start = None
    if start is not None:
        out.append((start, t_last))
    return [(max(a, t_first), min(b, t_last)) for a, b in out if b > t_first and a < t_last]
