"""Independent tight-tolerance reference integrator (for tests and the benchmark).

Integrates the same equations of motion (the compiled functions of
:mod:`tribo_estimation.core.kernel`, called from Python) with scipy's
``solve_ivp`` DOP853 (rtol 1e-10 by default), one smooth segment at a time:
each stick or slip phase ends at a terminal event located by scipy's own root
finder (slip end ``v = 0``, slip-speed peak of the deceleration rule, breakaway
``|M_stick| = F_N*R*mu_s``); the next segment restarts from the event state.
Outputs are taken from the dense output at the sample instants. Independent of
the kernel's fixed-step RK4 and its Illinois event location; about two to three
orders of magnitude slower.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.integrate import solve_ivp

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.model import (
    DriveProfile,
    Extensions,
    FrictionLaw,
    RigParams,
    RigState,
    pack_params,
)
from tribo_estimation.core.simulate import SimResult
from tribo_estimation.errors import InvalidParameterError, SimulationError


def simulate_reference(
    rig: RigParams,
    friction: FrictionLaw,
    drive: DriveProfile,
    duration: float,
    fs: float = 10_000.0,
    *,
    initial: RigState | None = None,
    extensions: Extensions | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_segments: int = 100_000,
) -> SimResult:
    """Reference solution sampled like :func:`simulate.simulate` (no noise, no
    measurement-side extensions). Same output arrays and ``final_state``."""
    if not (math.isfinite(duration) and duration > 0.0 and fs > 0.0):
        raise InvalidParameterError(f'bad duration {duration!r} s or fs {fs!r} Hz')
    n = round(duration * fs)
    p = pack_params(rig, friction, drive, extensions)
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
    fnr = rig.F_N * rig.R
    if stuck:
        w = (rig.I1 * y[1] + rig.I2 * y[3]) / (rig.I1 + rig.I2)
        y[1] = y[3] = w
    out = np.full((kn.N_CH, n), np.nan)
    t = t_start
    n_events = 0
    ev_times: list[float] = []
    ev_kinds: list[int] = []
    k = 0  # next sample index
    segments = 0
    while True:
        segments += 1
        if segments > max_segments:
            raise SimulationError('reference: too many segments')
        mode = (stuck, direction, peak)

        def rhs(tt: float, yy: np.ndarray, mode: tuple[bool, float, bool] = mode) -> list[float]:
            d = kn.derivatives(p, tt, yy[0], yy[1], yy[2], yy[3], yy[4], *mode)
            return [d[0], d[1], d[2], d[3], d[4]]

        events: list[Callable[..., float]] = []
        if stuck:
            t_ss = t_stick_start

            def ev_break(tt: float, yy: np.ndarray, t_ss: float = t_ss) -> float:
                ms = kn.stick_moment(p, tt, yy[0], yy[1], yy[2])
                return float(fnr * kn.static_coefficient(p, tt, tt - t_ss) - abs(ms))

            ev_break.terminal = True  # type: ignore[attr-defined]
            ev_break.direction = -1  # type: ignore[attr-defined]
            events.append(ev_break)
        else:

            def ev_slip(tt: float, yy: np.ndarray, dr: float = direction) -> float:
                return float(dr * (yy[3] - yy[1]))

            ev_slip.terminal = True  # type: ignore[attr-defined]
            ev_slip.direction = -1  # type: ignore[attr-defined]
            events.append(ev_slip)
            if not peak:

                def ev_peak(tt: float, yy: np.ndarray, mode: tuple = mode) -> float:
                    d = kn.derivatives(p, tt, yy[0], yy[1], yy[2], yy[3], yy[4], *mode)
                    return float(mode[1] * (d[3] - d[1]))

                ev_peak.terminal = True  # type: ignore[attr-defined]
                ev_peak.direction = -1  # type: ignore[attr-defined]
                events.append(ev_peak)
        sol = solve_ivp(
            rhs,
            (t, t_end),
            y,
            method='DOP853',
            rtol=rtol,
            atol=atol,
            events=events,
            dense_output=True,
        )
        if sol.status == -1:
            raise SimulationError(f'reference integration failed: {sol.message}')
        t_seg_end = float(sol.t[-1])
        # samples inside [t, t_seg_end)
        while k < n and (times[k] < t_seg_end or (sol.status == 0 and times[k] <= t_seg_end)):
            yk = sol.sol(times[k])
            d = kn.derivatives(p, times[k], yk[0], yk[1], yk[2], yk[3], yk[4], *mode)
            out[kn.OUT_TORSION, k] = rig.C1 * yk[0]
            out[kn.OUT_ACCEL, k] = d[1]
            out[kn.OUT_SPEED, k] = yk[3]
            out[kn.OUT_FRICTION, k] = d[5]
            out[kn.OUT_SLIP, k] = yk[3] - yk[1]
            out[kn.OUT_STICK, k] = 1.0 if stuck else 0.0
            out[kn.OUT_W1, k] = yk[1]
            if not stuck:
                vmax = max(vmax, abs(yk[3] - yk[1]))
            k += 1
        y = np.asarray(sol.y[:, -1], dtype=float).copy()
        t = t_seg_end
        if sol.status == 0:
            break
        # terminal event: which one?
        n_events += 1
        fired = [i for i, te in enumerate(sol.t_events) if len(te) > 0]
        ev = fired[0]
        ev_times.append(t)
        if stuck:
            ev_kinds.append(kn.EV_BREAKAWAY)
            ms = kn.stick_moment(p, t, y[0], y[1], y[2])
            mus = kn.static_coefficient(p, t, t - t_stick_start)
            stuck = False
            direction = 1.0 if ms >= 0.0 else -1.0
            peak = False
            vmax = 0.0
            y[4] = mus
        elif ev == 0:
            w = (rig.I1 * y[1] + rig.I2 * y[3]) / (rig.I1 + rig.I2)
            y[1] = y[3] = w
            ms = kn.stick_moment(p, t, y[0], w, y[2])
            if abs(ms) <= fnr * kn.static_coefficient(p, t, 0.0):
                stuck = True
                t_stick_start = t
                ev_kinds.append(kn.EV_SLIP_END)
            else:
                direction = 1.0 if ms >= 0.0 else -1.0
                ev_kinds.append(-kn.EV_SLIP_END)
            peak = False
            vmax = 0.0
        else:
            peak = True
            ev_kinds.append(kn.EV_PEAK)
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
        torsion_moment=out[kn.OUT_TORSION].copy(),
        angular_acceleration=out[kn.OUT_ACCEL].copy(),
        speed=out[kn.OUT_SPEED].copy(),
        friction_moment=out[kn.OUT_FRICTION].copy(),
        slip_speed=out[kn.OUT_SLIP].copy(),
        stick=out[kn.OUT_STICK] > 0.5,
        chamber_speed=out[kn.OUT_W1].copy(),
        final_state=final,
        n_events=n_events,
        fs=fs,
        event_times=np.array(ev_times),
        event_kinds=np.array(ev_kinds, dtype=np.int64),
    )
