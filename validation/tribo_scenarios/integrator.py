"""Event-accurate integration of the rig (Dormand-Prince 5(4), compiled with numba).

The state is advanced by explicit Dormand-Prince 5(4) steps with error control
(mixed tolerance ``atol_i = rtol*scale_i``, max norm, step growth limited to 5x).
Every output sample time, every fixed boundary (the drive profile's corners) and
every pending discontinuity of a delayed friction coefficient ends a step exactly,
so no step straddles a kink the error estimate does not see, and the output needs
no interpolation.

Switching events are functions of the state checked at every step end::

    stick:  g = |M_stick| - F_N R mu_s          breakaway when g > 0    (Equ. 5, 6)
    slip:   g = sgn*v                           slip end when g < 0
            g = sgn*v'  (until the peak)        |v| passed its maximum  (deceleration rule)

A step in which one changes sign is cut at the root, found by regula falsi with the
Illinois modification on the step length (each trial is a fresh 5th-order step
from the step's start), safeguarded by bisection, to 1e-12 s. At a slip end the
two bodies take the momentum-conserving common speed and stick if the static limit
holds, else slide on in the direction of ``M_stick``; at a breakaway sliding starts
in the direction of ``M_stick``.

``restart_idx`` lets a second run (the record without the hidden effect) restart
from states of the first at chosen samples (see :mod:`.generate`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .dynamics import forces, normal_force, rhs
from .layout import (
    NM,
    NY,
    P_I1,
    P_I2,
    P_LAG_T,
    P_R,
    PEAK,
    Q_LAG,
    SDIR,
    STUCK,
    TSTICK0,
    W1,
    W2,
    Z,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

# Dormand-Prince 5(4) tableau (nodes C, stages A, 5th-order weights B, error weights E)
C2, C3, C4, C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63 = 9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0
A64, A65 = 49.0 / 176.0, -5103.0 / 18656.0
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
# E = B(5th) - B(4th): 4th-order weights 5179/57600, 0, 7571/16695, 393/640,
# -92097/339200, 187/2100, 1/40
E1 = B1 - 5179.0 / 57600.0
E3 = B3 - 7571.0 / 16695.0
E4 = B4 - 393.0 / 640.0
E5 = B5 - (-92097.0 / 339200.0)
E6 = B6 - 187.0 / 2100.0
E7 = -1.0 / 40.0

#: Status codes of :func:`integrate`.
OK, STEP_UNDERFLOW, CHATTER = 0, 1, 2

EV_NONE, EV_BREAKAWAY, EV_SLIP_END, EV_PEAK = 0, 1, 2, 3


@njit(cache=True)
def dp_step(
    t: float,
    y: FloatArray,
    h: float,
    m: FloatArray,
    P: FloatArray,
    Q: IntArray,
    TR: FloatArray,
    RIP: FloatArray,
    DR: FloatArray,
    H: FloatArray,
    nh: int,
    K: FloatArray,
    tmp: FloatArray,
    y5: FloatArray,
) -> None:
    """Take one Dormand-Prince step of length ``h`` from (t, y); ``K[0]`` must hold f(t, y).

    Writes the 5th-order solution to ``y5``, the stage derivatives to ``K[1:7]``
    (``K[6]`` = f(t + h, y5)).

    Parameters
    ----------
    t, h : float
        Start time and step [s].
    y, m : ndarray
        State and mode at t.
    P, Q, TR, RIP, DR : ndarray
        Parameters, form codes, drive, ripple and drift tables.
    H : ndarray
        Slip history (time-delay form).
    nh : int
        Rows of the history.
    K : ndarray, shape (7, NY)
        Stage derivatives (row 0 given).
    tmp, y5 : ndarray
        Work array and the result.
    """
    n = y.shape[0]
    for i in range(n):
        tmp[i] = y[i] + h * A21 * K[0, i]
    rhs(t + C2 * h, tmp, m, P, Q, TR, RIP, DR, H, nh, K[1])
    for i in range(n):
        tmp[i] = y[i] + h * (A31 * K[0, i] + A32 * K[1, i])
    rhs(t + C3 * h, tmp, m, P, Q, TR, RIP, DR, H, nh, K[2])
    for i in range(n):
        tmp[i] = y[i] + h * (A41 * K[0, i] + A42 * K[1, i] + A43 * K[2, i])
    rhs(t + C4 * h, tmp, m, P, Q, TR, RIP, DR, H, nh, K[3])
    for i in range(n):
        tmp[i] = y[i] + h * (A51 * K[0, i] + A52 * K[1, i] + A53 * K[2, i] + A54 * K[3, i])
    rhs(t + C5 * h, tmp, m, P, Q, TR, RIP, DR, H, nh, K[4])
    for i in range(n):
        tmp[i] = y[i] + h * (
            A61 * K[0, i] + A62 * K[1, i] + A63 * K[2, i] + A64 * K[3, i] + A65 * K[4, i]
        )
    rhs(t + h, tmp, m, P, Q, TR, RIP, DR, H, nh, K[5])
    for i in range(n):
        y5[i] = y[i] + h * (
            B1 * K[0, i] + B3 * K[2, i] + B4 * K[3, i] + B5 * K[4, i] + B6 * K[5, i]
        )
    rhs(t + h, y5, m, P, Q, TR, RIP, DR, H, nh, K[6])


@njit(cache=True)
def error_norm(
    y: FloatArray, y5: FloatArray, K: FloatArray, h: float, scale: FloatArray, rtol: float
) -> float:
    """Return the max-norm of the local error estimate relative to the tolerance (<= 1: accept).

    Parameters
    ----------
    y, y5 : ndarray
        State at the start and the 5th-order solution at the end.
    K : ndarray
        Stage derivatives of the step.
    h : float
        Step [s].
    scale : ndarray
        Typical magnitude of each state entry (``atol_i = rtol*scale_i``).
    rtol : float
        Relative tolerance [-].

    Returns
    -------
    float
        Error ratio [-].
    """
    worst = 0.0
    for i in range(y.shape[0]):
        e = h * (E1 * K[0, i] + E3 * K[2, i] + E4 * K[3, i] + E5 * K[4, i] + E6 * K[5, i])
        e += h * E7 * K[6, i]
        tol = rtol * (scale[i] + max(abs(y[i]), abs(y5[i])))
        r = abs(e) / tol
        if r > worst:
            worst = r
    return worst


@njit(cache=True)
def event_value(
    kind: int,
    t: float,
    y: FloatArray,
    m: FloatArray,
    P: FloatArray,
    Q: IntArray,
    TR: FloatArray,
    RIP: FloatArray,
    DR: FloatArray,
    H: FloatArray,
    nh: int,
) -> float:
    """Return an event function at (t, y) in mode ``m`` (its sign change is the event).

    Parameters
    ----------
    kind : int
        ``EV_BREAKAWAY`` (``|M_stick| - F_N R mu_s`` [N m], event when > 0),
        ``EV_SLIP_END`` (``sgn*v`` [rad/s], event when < 0) or ``EV_PEAK``
        (``sgn*v'`` [rad/s^2], event when < 0).
    t : float
        Time [s].
    y, m : ndarray
        State and mode.
    P, Q, TR, RIP, DR, H : ndarray
        Model tables and the slip history.
    nh : int
        Rows of the history.

    Returns
    -------
    float
        The event function.
    """
    a1, a2, _M, ms, thr, _c, _w0, _r = forces(t, y, m, P, Q, TR, RIP, DR, H, nh)
    if kind == EV_BREAKAWAY:
        return abs(ms) - thr
    if kind == EV_SLIP_END:
        return float(m[SDIR] * (y[W2] - y[W1]))
    return float(m[SDIR] * (a2 - a1))


@njit(cache=True)
def _crossed(kind: int, g: float) -> bool:
    if kind == EV_BREAKAWAY:
        return g > 0.0
    return g < 0.0


@njit(cache=True)
def _history_push(
    H: FloatArray,
    nh: int,
    t: float,
    y: FloatArray,
    m: FloatArray,
    P: FloatArray,
    Q: IntArray,
    TR: FloatArray,
    RIP: FloatArray,
    DR: FloatArray,
) -> tuple[FloatArray, int]:
    """Append (t, v, v', mode) to the slip history, growing it when full."""
    if nh >= H.shape[0]:
        H2 = np.empty((2 * H.shape[0], 4))
        H2[:nh] = H[:nh]
        H = H2
    f = forces(t, y, m, P, Q, TR, RIP, DR, H, nh)
    H[nh, 0] = t
    H[nh, 1] = y[W2] - y[W1]
    H[nh, 2] = f[1] - f[0]
    H[nh, 3] = 0.0 if m[STUCK] > 0.5 else 2.0 if m[PEAK] > 0.5 else 1.0
    return H, nh + 1


@njit(cache=True)
def _sign(x: float) -> float:
    return 1.0 if x >= 0.0 else -1.0


@njit(cache=True)
def integrate(
    P: FloatArray,
    Q: IntArray,
    TR: FloatArray,
    RIP: FloatArray,
    DR: FloatArray,
    y0: FloatArray,
    m0: FloatArray,
    t0: float,
    t_out: FloatArray,
    boundaries: FloatArray,
    restart_idx: IntArray,
    restart_y: FloatArray,
    restart_m: FloatArray,
    scale: FloatArray,
    rtol: float,
    hmax: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, IntArray]:
    """Integrate the rig from t0 and return its state at the sample times ``t_out``.

    Parameters
    ----------
    P, Q, TR, RIP, DR : ndarray
        Parameters, form codes, drive transitions, ripple and drift components.
    y0, m0 : ndarray
        State and mode at ``t0``.
    t0 : float
        Start time [s].
    t_out : ndarray
        Increasing sample times [s], all >= t0.
    boundaries : ndarray
        Sorted times [s] at which a step must end (profile corners).
    restart_idx : ndarray of int
        Sample indices at which the state is replaced (empty: none).
    restart_y, restart_m : ndarray
        The replacing states and modes, one row per restart.
    scale : ndarray
        Typical magnitude of each state entry (absolute tolerance ``rtol*scale``).
    rtol : float
        Relative tolerance [-].
    hmax : float
        Largest step [s].

    Returns
    -------
    tuple of ndarray
        ``(Y, MODE, ACC, FM, info)``: states (n, NY) and modes (n, NM) at the samples,
        chamber acceleration [rad/s^2] and friction moment [N m] at the samples, and
        ``info = (status, accepted steps, rejected steps, events)``.
    """
    n_out = t_out.shape[0]
    Y = np.empty((n_out, NY))
    MODE = np.empty((n_out, NM))
    ACC = np.empty(n_out)
    FM = np.empty(n_out)
    info = np.zeros(4, dtype=np.int64)
    y = y0.copy()
    m = m0.copy()
    K = np.empty((7, NY))
    tmp = np.empty(NY)
    y5 = np.empty(NY)
    ye = np.empty(NY)
    H = np.empty((4096, 4))
    nh = 0
    delay = Q[Q_LAG] == 2
    T_delay = P[P_LAG_T] if delay else 0.0
    pend = np.empty(256)  # pending discontinuities of the delayed coefficient [s]
    npend = 0
    t = t0
    h = min(hmax, 1e-5)
    ib = 0
    nb = boundaries.shape[0]
    k_restart = 0
    n_restart = restart_idx.shape[0]
    k1_ok = False
    max_events = 10_000 + int(20_000.0 * (t_out[n_out - 1] - t0 + 1.0))
    if delay:
        H, nh = _history_push(H, nh, t, y, m, P, Q, TR, RIP, DR)
    for i in range(n_out):
        t_target = t_out[i]
        while t < t_target:
            stop = t_target
            while ib < nb and boundaries[ib] <= t:
                ib += 1
            if ib < nb and boundaries[ib] < stop:
                stop = boundaries[ib]
            j = 0
            while j < npend:  # drop passed discontinuities, find the next one
                if pend[j] <= t:
                    pend[j] = pend[npend - 1]
                    npend -= 1
                else:
                    if pend[j] < stop:
                        stop = pend[j]
                    j += 1
            hh = min(h, hmax, stop - t)
            if delay:
                hh = min(hh, 0.5 * T_delay)
            if not k1_ok:
                rhs(t, y, m, P, Q, TR, RIP, DR, H, nh, K[0])
                k1_ok = True
            dp_step(t, y, hh, m, P, Q, TR, RIP, DR, H, nh, K, tmp, y5)
            err = error_norm(y, y5, K, hh, scale, rtol)
            if not err <= 1.0:
                info[2] += 1
                fac = 0.2 if not math.isfinite(err) else max(0.2, 0.9 * err**-0.2)
                h = hh * fac
                if h < 1e-13:
                    info[0] = STEP_UNDERFLOW
                    return Y, MODE, ACC, FM, info
                continue
            # --- events within the step
            stuck = m[STUCK] > 0.5
            if stuck:
                g_end = event_value(EV_BREAKAWAY, t + hh, y5, m, P, Q, TR, RIP, DR, H, nh)
                event = g_end > 0.0
            else:
                event = m[SDIR] * (y5[W2] - y5[W1]) < 0.0 or (
                    m[PEAK] < 0.5 and m[SDIR] * (K[6, W2] - K[6, W1]) < 0.0
                )
            if event:
                best_theta = 2.0
                best_kind = EV_NONE
                for kind in (EV_BREAKAWAY, EV_SLIP_END, EV_PEAK):
                    if stuck != (kind == EV_BREAKAWAY):
                        continue
                    if kind == EV_PEAK and m[PEAK] > 0.5:
                        continue
                    gb = event_value(kind, t + hh, y5, m, P, Q, TR, RIP, DR, H, nh)
                    if not _crossed(kind, gb):
                        continue
                    ga = event_value(kind, t, y, m, P, Q, TR, RIP, DR, H, nh)
                    if _crossed(kind, ga) or ga == 0.0:
                        # at a phase start the function is 0: take it as on the safe side
                        ga = -1e-300 if kind == EV_BREAKAWAY else 1e-300
                    lo, hi = 0.0, 1.0
                    glo, ghi = ga, gb
                    side = 0
                    for _ in range(200):
                        if (hi - lo) * hh <= 1e-12:
                            break
                        th = lo + (hi - lo) * glo / (glo - ghi)
                        w = hi - lo
                        if not (lo + 1e-3 * w < th < hi - 1e-3 * w):
                            th = 0.5 * (lo + hi)
                        dp_step(t, y, th * hh, m, P, Q, TR, RIP, DR, H, nh, K, tmp, ye)
                        g = event_value(kind, t + th * hh, ye, m, P, Q, TR, RIP, DR, H, nh)
                        if _crossed(kind, g):
                            hi, ghi = th, g
                            if side == 1:
                                glo *= 0.5
                            side = 1
                        else:
                            lo, glo = th, g
                            if side == -1:
                                ghi *= 0.5
                            side = -1
                    if hi < best_theta:
                        best_theta = hi
                        best_kind = kind
                if best_kind == EV_NONE:  # a sign change seen but not confirmed: smaller step
                    h = 0.5 * hh
                    continue
                te = t + best_theta * hh
                dp_step(t, y, best_theta * hh, m, P, Q, TR, RIP, DR, H, nh, K, tmp, ye)
                for q in range(NY):
                    y[q] = ye[q]
                t = te
                if delay:
                    H, nh = _history_push(H, nh, t, y, m, P, Q, TR, RIP, DR)
                info[3] += 1
                if info[3] > max_events:
                    info[0] = CHATTER
                    return Y, MODE, ACC, FM, info
                if best_kind == EV_PEAK:
                    m[PEAK] = 1.0
                elif best_kind == EV_BREAKAWAY:
                    f = forces(t, y, m, P, Q, TR, RIP, DR, H, nh)
                    m[STUCK] = 0.0
                    m[SDIR] = _sign(f[3])
                    m[PEAK] = 0.0
                    if Q[Q_LAG] == 1:  # the lagged coefficient starts at mu_s
                        y[Z] = f[4] / (normal_force(t, P, Q) * P[P_R])
                else:  # slip end: common speed, then stick or slide on
                    wc = (P[P_I1] * y[W1] + P[P_I2] * y[W2]) / (P[P_I1] + P[P_I2])
                    y[W1] = wc
                    y[W2] = wc
                    m[STUCK] = 1.0
                    m[TSTICK0] = t
                    f = forces(t, y, m, P, Q, TR, RIP, DR, H, nh)
                    if abs(f[3]) > f[4]:
                        m[STUCK] = 0.0
                        m[SDIR] = _sign(f[3])
                        m[PEAK] = 0.0
                k1_ok = False
                if delay:
                    H, nh = _history_push(H, nh, t, y, m, P, Q, TR, RIP, DR)
                    if npend < pend.shape[0]:
                        pend[npend] = t + T_delay
                        npend += 1
                h = max(hh, 1e-9)
                continue
            # --- accept
            t = stop if hh == stop - t else t + hh
            for q in range(NY):
                y[q] = y5[q]
                K[0, q] = K[6, q]
            info[1] += 1
            if delay:
                H, nh = _history_push(H, nh, t, y, m, P, Q, TR, RIP, DR)
            fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err**-0.2))
            h = max(h, hh * fac) if hh < h else hh * fac
        if k_restart < n_restart and restart_idx[k_restart] == i:
            for q in range(NY):
                y[q] = restart_y[k_restart, q]
            for q in range(NM):
                m[q] = restart_m[k_restart, q]
            k_restart += 1
            k1_ok = False
            if m[STUCK] > 0.5:
                f = forces(t, y, m, P, Q, TR, RIP, DR, H, nh)
                if abs(f[3]) > f[4]:  # this model cannot hold the stick: it breaks away now
                    m[STUCK] = 0.0
                    m[SDIR] = _sign(f[3])
                    m[PEAK] = 0.0
                    if Q[Q_LAG] == 1:
                        y[Z] = f[4] / (normal_force(t, P, Q) * P[P_R])
        f = forces(t, y, m, P, Q, TR, RIP, DR, H, nh)
        for q in range(NY):
            Y[i, q] = y[q]
        for q in range(NM):
            MODE[i, q] = m[q]
        ACC[i] = f[0]
        FM[i] = f[2]
    return Y, MODE, ACC, FM, info
