"""The event-accurate stick/slip integrator of the rig (the kernel's entry points).

:func:`integrate` / :func:`integrate_logged` advance the state vector ``s`` (indices
``S_*`` of :mod:`.layout`) by ``n_out`` output samples: RK4 steps (:mod:`.step`),
switching events located and the step restarted from each event (:mod:`.events`),
outputs sampled at the exact instants ``t_base + i*dt``.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .equations import (
    _derivatives_call,
    breakaway_state,
    derivatives,
    static_coefficient,
    stick_moment,
)
from .events import EV_BREAKAWAY, EV_NONE, EV_PEAK, EV_SLIP_END, _locate
from .layout import (
    D_M,
    OUT_ACCEL,
    OUT_FRICTION,
    OUT_SLIP,
    OUT_SPEED,
    OUT_STICK,
    OUT_TORSION,
    OUT_W1,
    P_C1,
    P_FN,
    P_I1,
    P_I2,
    P_R,
    S_DIR,
    S_PEAK,
    S_STUCK,
    S_T,
    S_TSTICK,
    S_VMAX,
    Y_PHI1,
    Y_PHI2,
    Y_W1,
    Y_W2,
)
from .state import FASTMATH, FloatTuple, from_state, to_state, with_entry
from .step import STEP_RATE, _rk4, slip_rate

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_MAX_ZERO_EVENTS = 8


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def _stick_together(p: FloatArray, y: FloatTuple) -> FloatTuple:
    """Return ``y`` with both discs at their common, momentum-conserving speed [rad/s].

    ``w = (I1*w1 + I2*w2)/(I1 + I2)`` (the discs join at a slip end or a sticking start).
    """
    i1 = p[P_I1]
    i2 = p[P_I2]
    w = (i1 * y[Y_W1] + i2 * y[Y_W2]) / (i1 + i2)
    return with_entry(with_entry(y, Y_W1, w), Y_W2, w)


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def integrate(
    p: FloatArray, s: FloatArray, n_out: int, dt: float, n_sub: int, out: FloatArray
) -> int:
    """Simulate ``n_out`` output samples of the rig; the kernel behind ``simulate``.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    s : FloatArray
        State vector (length ``NS``, indices ``S_*``), advanced in place to
        ``s[S_T] + n_out*dt``.
    n_out : int
        Number of output samples; sample i is the state at ``t_start + i*dt``.
    dt : float
        Output sample interval [s].
    n_sub : int
        RK4 steps per output interval (>= 1; see :func:`substeps_for`).
    out : FloatArray
        Output channels, shape (``N_CH``, >= n_out) (indices ``OUT_*``).

    Returns
    -------
    int
        The number of located stick/slip/peak events.
    """
    return integrate_logged(p, s, n_out, dt, n_sub, out, np.empty(0), np.empty(0, dtype=np.int64))


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def integrate_logged(
    p: FloatArray,
    s: FloatArray,
    n_out: int,
    dt: float,
    n_sub: int,
    out: FloatArray,
    ev_time: FloatArray,
    ev_kind: IntArray,
) -> int:
    """:func:`integrate` that also logs the located events.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    s, n_out, dt, n_sub, out
        As :func:`integrate`.
    ev_time : FloatArray
        Receives the time [s] of the k-th event while k < len(ev_time).
    ev_kind : IntArray
        Receives the kind of the k-th event: ``EV_SLIP_END`` = slip ended and the
        discs stick, ``-EV_SLIP_END`` = slip ended and sliding reverses, ``EV_PEAK``,
        ``EV_BREAKAWAY``.

    Returns
    -------
    int
        The number of events (counted beyond the log's length too).
    """
    t_base = s[S_T]
    t = t_base
    y = from_state(s)
    stuck = s[S_STUCK] > 0.5
    direction = 1.0 if s[S_DIR] >= 0.0 else -1.0
    peak = s[S_PEAK] > 0.5
    vmax = s[S_VMAX]
    t_stick = s[S_TSTICK]
    fnr = p[P_FN] * p[P_R]
    h = dt / n_sub
    n_events = 0
    if stuck:
        y = _stick_together(p, y)
    k1 = _derivatives_call(p, t, y, stuck, direction, peak)
    for i in range(n_out):
        out[OUT_TORSION, i] = p[P_C1] * y[Y_PHI1]
        out[OUT_ACCEL, i] = k1[Y_W1]
        out[OUT_SPEED, i] = y[Y_W2]
        out[OUT_FRICTION, i] = k1[D_M]
        out[OUT_SLIP, i] = y[Y_W2] - y[Y_W1]
        out[OUT_STICK, i] = 1.0 if stuck else 0.0
        out[OUT_W1, i] = y[Y_W1]
        for j in range(n_sub):
            t_end = t_base + (i * n_sub + j + 1) * h
            n_zero = 0
            while True:
                hh = t_end - t
                if hh <= 1e-12 * h:
                    t = t_end
                    break
                t_step = t_end
                if not stuck:
                    # local step control where the falling friction curve makes the
                    # slip dynamics fast (negative damping right after breakaway)
                    lam = slip_rate(p, t, abs(y[Y_W2] - y[Y_W1]), peak)
                    if lam * hh > STEP_RATE:
                        hh = STEP_RATE / lam
                        t_step = t + hh
                y1 = _rk4(p, t, y, k1, hh, stuck, direction, peak)
                k1n = derivatives(p, t_step, y1, stuck, direction, peak)
                ev = EV_NONE
                tau = hh
                if stuck:
                    ms = k1n[D_M]
                    g_b = fnr * static_coefficient(p, t_step, t_stick + hh) - abs(ms)
                    if g_b < 0.0:
                        g_a = fnr * static_coefficient(p, t, t_stick) - abs(k1[D_M])
                        tau = _locate(
                            p, EV_BREAKAWAY, t, y, k1, hh, g_a, g_b, stuck, direction, peak, t_stick
                        )
                        ev = EV_BREAKAWAY
                else:
                    g_b = direction * (y1[Y_W2] - y1[Y_W1])
                    if g_b < 0.0:
                        g_a = direction * (y[Y_W2] - y[Y_W1])
                        tau = _locate(
                            p, EV_SLIP_END, t, y, k1, hh, g_a, g_b, stuck, direction, peak, t_stick
                        )
                        ev = EV_SLIP_END
                    if not peak:
                        gp_b = direction * (k1n[Y_W2] - k1n[Y_W1])
                        gp_a = direction * (k1[Y_W2] - k1[Y_W1])
                        if gp_b <= 0.0 and gp_a > 0.0:
                            tp = _locate(
                                p,
                                EV_PEAK,
                                t,
                                y,
                                k1,
                                hh,
                                gp_a,
                                gp_b,
                                stuck,
                                direction,
                                peak,
                                t_stick,
                            )
                            if tp < tau:
                                tau = tp
                                ev = EV_PEAK
                if ev == EV_NONE:
                    y = y1
                    k1 = k1n
                    if stuck:
                        t_stick += hh
                    else:
                        va = abs(y[Y_W2] - y[Y_W1])
                        if va > vmax:
                            vmax = va
                    t = t_step
                    if t_step == t_end:
                        break
                    continue
                # advance to the event and switch
                if tau <= 0.0:
                    n_zero += 1
                    if n_zero > _MAX_ZERO_EVENTS:
                        # cannot make progress at this instant: accept the trial step
                        y = y1
                        k1 = k1n
                        t = t_step
                        if t_step == t_end:
                            break
                        continue
                else:
                    y = _rk4(p, t, y, k1, tau, stuck, direction, peak)
                    t = t + tau
                    if stuck:
                        t_stick += tau
                if n_events < ev_time.shape[0]:
                    ev_time[n_events] = t
                    ev_kind[n_events] = ev
                n_events += 1
                if ev == EV_PEAK:
                    peak = True
                elif ev == EV_SLIP_END:
                    y = _stick_together(p, y)
                    ms = stick_moment(p, t, y[Y_PHI1], y[Y_W1], y[Y_PHI2])
                    if abs(ms) <= fnr * static_coefficient(p, t, 0.0):
                        stuck = True
                        t_stick = 0.0
                    else:
                        direction = 1.0 if ms >= 0.0 else -1.0
                        if n_events <= ev_kind.shape[0]:
                            ev_kind[n_events - 1] = -EV_SLIP_END
                    peak = False
                    vmax = 0.0
                else:  # breakaway
                    ms = stick_moment(p, t, y[Y_PHI1], y[Y_W1], y[Y_PHI2])
                    mus = static_coefficient(p, t, t_stick)
                    stuck = False
                    direction = 1.0 if ms >= 0.0 else -1.0
                    peak = False
                    vmax = 0.0
                    y = breakaway_state(p, t, y, mus)
                k1 = _derivatives_call(p, t, y, stuck, direction, peak)
    s[S_T] = t
    to_state(y, s)
    s[S_STUCK] = 1.0 if stuck else 0.0
    s[S_DIR] = direction
    s[S_PEAK] = 1.0 if peak else 0.0
    s[S_VMAX] = vmax
    s[S_TSTICK] = t_stick
    return n_events
