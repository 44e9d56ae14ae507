"""The rig's equations of motion with every drawn effect (compiled with numba).

2-DOF torsional rig of the paper (Equ. 1, 2; K = damping, C = stiffness), written
here from the corrected equations of ``docs/physics.md`` without using the project's
kernel::

    I1*w1' = Q1 + M,   Q1 = -K1*w1 - C1(t)*phi1 - C_b*phi1 - M_b(w1)             [N m]
    I2*w2' = Q2 - M,   Q2 = -K2*(w2 - w0) - C2*s(phi2 - phi0)                     [N m]

with ``s(d) = d`` (paper), a dead band (backlash) or ``d*(1 + beta*(d/d_ref)^2)``
(hardening belt). Sliding (Equ. 3, 8)::

    M  = sgn(v)*F_N(t)*R*mu_eff + M_v(v),   v = w2 - w1
    mu = (mu0 - mu_inf)*shape(|v|) + mu_inf,  shape = exp(-k|v|) in the paper

with the paper's deceleration rule (``mu = mu_inf`` once |v| passed its maximum in
the sliding phase) and ``mu_eff`` = mu, its first-order lag, its pure time delay or
mu plus a rate-and-state term. Sticking (Equ. 4, 6)::

    (I1 + I2)*w' = Q1 + Q2,   M_stick = (I1*Q2 - I2*Q1)/(I1 + I2)

holds while ``|M_stick| <= F_N(t)*R*mu_s``, ``mu_s = mu0(t) + dwell(t_stick)``.
The drive speed ``w0 = w0_base(t) + ripple``; the drive angle ``phi0`` is its
integral (the base profile's in closed form, the ripple's as the state ``RHO``).

Slots of the vectors: :mod:`.layout`. All functions are ``njit`` and also run as
plain Python (``NUMBA_DISABLE_JIT=1``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .layout import (
    AF,
    AFD,
    DEFL,
    P_AF_W,
    P_AF_Z,
    P_BH_BETA,
    P_BH_DREF,
    P_BL_B,
    P_BR_C,
    P_BR_M,
    P_BR_WR,
    P_C1,
    P_C1CAL,
    P_C1D_D,
    P_C1D_T0,
    P_C1D_TAU,
    P_C2,
    P_CB,
    P_DR_A0,
    P_DR_AINF,
    P_DR_TAU,
    P_DW_A,
    P_DW_B,
    P_FN,
    P_FNR_A,
    P_FNR_F,
    P_FNR_P,
    P_I1,
    P_I2,
    P_K,
    P_K1,
    P_K2,
    P_LAG_B,
    P_LAG_DC,
    P_LAG_T,
    P_LAG_VR,
    P_MU0,
    P_MUINF,
    P_R,
    P_RIP_F,
    P_SF_W,
    P_SF_Z,
    P_STR_D,
    P_STR_VS,
    P_TF_W,
    P_TF_Z,
    P_VIS_C,
    P_VIS_N,
    PEAK,
    PHI1,
    Q_AF,
    Q_BEARING,
    Q_BELT,
    Q_C1DRIFT,
    Q_DRIFT,
    Q_DWELL,
    Q_FNRIP,
    Q_LAG,
    Q_RIPPLE,
    Q_SF,
    Q_STRIB,
    Q_TF,
    Q_VISC,
    RHO,
    SDIR,
    SF,
    SFD,
    STUCK,
    TF,
    TFD,
    TSTICK0,
    W1,
    W2,
    Z,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def drive_base(t: float, TR: FloatArray) -> tuple[float, float]:
    """Return the base drive speed w0_base(t) [rad/s] and its integral phi0_base(t) [rad].

    The profile is a sum of transitions from rest at t = 0; row ``j`` of ``TR`` is
    (start [s], duration [s], speed change [rad/s], shape: 0 linear, 1 raised cosine).

    Parameters
    ----------
    t : float
        Test time [s] (0 = the motor's start).
    TR : ndarray, shape (n, 4)
        The transitions.

    Returns
    -------
    tuple of float
        ``(w0_base, phi0_base)``.
    """
    w = 0.0
    phi = 0.0
    for j in range(TR.shape[0]):
        s, T, dw = TR[j, 0], TR[j, 1], TR[j, 2]
        x = (t - s) / T
        if x <= 0.0:
            continue
        if x >= 1.0:
            w += dw
            phi += dw * T * (x - 0.5)
        elif TR[j, 3] == 0.0:
            w += dw * x
            phi += dw * T * 0.5 * x * x
        else:
            w += dw * 0.5 * (1.0 - math.cos(math.pi * x))
            phi += dw * T * (0.5 * x - math.sin(math.pi * x) / TWO_PI)
    return w, phi


@njit(cache=True)
def ripple(
    t: float, w0b: float, phi0b: float, P: FloatArray, Q: IntArray, RIP: FloatArray
) -> float:
    """Return the drive speed ripple added to w0 [rad/s].

    Form 1: ``sum_i a_i*sin(2 pi m_i f t + p_i)`` (a_i [rad/s]); form 2, locked to the
    motor angle: ``w0_base*sum_i a_i*sin(m_i*phi0_base + p_i)`` (a_i [-], m_i per
    revolution). Rows of ``RIP``: (a_i, m_i, p_i).

    Parameters
    ----------
    t : float
        Test time [s].
    w0b, phi0b : float
        Base drive speed [rad/s] and angle [rad].
    P, Q : ndarray
        Parameters and form codes (:mod:`.layout`).
    RIP : ndarray, shape (n, 3)
        Ripple components.

    Returns
    -------
    float
        Ripple [rad/s].
    """
    form = Q[Q_RIPPLE]
    if form == 0:
        return 0.0
    r = 0.0
    if form == 1:
        for i in range(RIP.shape[0]):
            r += RIP[i, 0] * math.sin(TWO_PI * RIP[i, 1] * P[P_RIP_F] * t + RIP[i, 2])
        return r
    for i in range(RIP.shape[0]):
        r += RIP[i, 0] * math.sin(RIP[i, 1] * phi0b + RIP[i, 2])
    return w0b * r


@njit(cache=True)
def mu_pair(t: float, P: FloatArray, Q: IntArray, DR: FloatArray) -> tuple[float, float]:
    """Return (mu0(t), mu_inf(t)) [-] with the friction drift of the test time.

    Form 1: linear rates ``P_DR_A0``, ``P_DR_AINF`` [1/s]; form 2: saturating,
    ``mu + A*(1 - exp(-t/tau))``; form 3: both scaled by ``1 + f(t)`` (mu_inf by
    ``1 + P_DR_AINF*f``), ``f = sum_i a_i sin(2 pi f_i t + p_i)``, rows of ``DR``.

    Parameters
    ----------
    t : float
        Test time [s].
    P, Q : ndarray
        Parameters and form codes.
    DR : ndarray, shape (n, 3)
        Components of the smooth random drift (a_i [-], f_i [Hz], p_i [rad]).

    Returns
    -------
    tuple of float
        ``(mu0, mu_inf)``.
    """
    m0 = P[P_MU0]
    mi = P[P_MUINF]
    form = Q[Q_DRIFT]
    if form == 1:
        m0 += P[P_DR_A0] * t
        mi += P[P_DR_AINF] * t
    elif form == 2:
        e = 1.0 - math.exp(-t / P[P_DR_TAU])
        m0 += P[P_DR_A0] * e
        mi += P[P_DR_AINF] * e
    elif form == 3:
        f = 0.0
        for i in range(DR.shape[0]):
            f += DR[i, 0] * math.sin(TWO_PI * DR[i, 1] * t + DR[i, 2])
        m0 *= 1.0 + f
        mi *= 1.0 + P[P_DR_AINF] * f
    return m0, mi


@njit(cache=True)
def curve(av: float, m0: float, mi: float, P: FloatArray, Q: IntArray) -> float:
    """Return the friction coefficient on the curve at slip speed ``|v| = av`` [-].

    Paper (Equ. 8): ``(m0 - mi)*exp(-k*av) + mi``; form 1 ``exp(-(k*av)^delta)``,
    form 2 ``1/(1 + (av/v_s)^2)``, form 3 ``exp(-(av/v_s)^2)`` in place of the
    exponential.

    Parameters
    ----------
    av : float
        Slip speed magnitude [rad/s].
    m0, mi : float
        mu0 and mu_inf [-].
    P, Q : ndarray
        Parameters and form codes.

    Returns
    -------
    float
        mu [-].
    """
    form = Q[Q_STRIB]
    if form == 0:
        s = math.exp(-P[P_K] * av)
    elif form == 1:
        s = math.exp(-((P[P_K] * av) ** P[P_STR_D]))
    elif form == 2:
        x = av / P[P_STR_VS]
        s = 1.0 / (1.0 + x * x)
    else:
        x = av / P[P_STR_VS]
        s = math.exp(-x * x)
    return (m0 - mi) * s + mi


@njit(cache=True)
def dwell(ts: float, P: FloatArray, Q: IntArray) -> float:
    """Return the static coefficient's growth with the stick duration ``ts`` [s] [-].

    Form 1 ``g*(1 - exp(-ts/tau))``, form 2 ``b*ln(1 + ts/t0)``, form 3
    ``c*(ts/1 s)^n``; 0 without dwell-time stiction.

    Parameters
    ----------
    ts : float
        Duration of the current stick [s].
    P, Q : ndarray
        Parameters and form codes.

    Returns
    -------
    float
        Added static coefficient [-].
    """
    form = Q[Q_DWELL]
    if form == 0 or ts <= 0.0:
        return 0.0
    if form == 1:
        return float(P[P_DW_A] * (1.0 - math.exp(-ts / P[P_DW_B])))
    if form == 2:
        return float(P[P_DW_A] * math.log1p(ts / P[P_DW_B]))
    return float(P[P_DW_A] * ts ** P[P_DW_B])


@njit(cache=True)
def normal_force(t: float, P: FloatArray, Q: IntArray) -> float:
    """Return the normal force F_N(t) [N] (with its ripple, out of the library).

    Parameters
    ----------
    t : float
        Test time [s].
    P, Q : ndarray
        Parameters and form codes.

    Returns
    -------
    float
        F_N [N].
    """
    if Q[Q_FNRIP] == 0:
        return float(P[P_FN])
    return float(P[P_FN] * (1.0 + P[P_FNR_A] * math.sin(TWO_PI * P[P_FNR_F] * t + P[P_FNR_P])))


@njit(cache=True)
def stiffness1(t: float, P: FloatArray, Q: IntArray) -> float:
    """Return the torsion element's stiffness C1(t) [N m/rad] (drifting: out of the library).

    Form 1: ``C1*(1 + d*(t - t0))`` after t0 (d [1/s]); form 2:
    ``C1*(1 + d*(1 - exp(-(t - t0)/tau)))``.

    Parameters
    ----------
    t : float
        Test time [s].
    P, Q : ndarray
        Parameters and form codes.

    Returns
    -------
    float
        C1 [N m/rad].
    """
    form = Q[Q_C1DRIFT]
    if form == 0:
        return float(P[P_C1])
    x = max(t - P[P_C1D_T0], 0.0)
    if form == 1:
        return float(P[P_C1] * (1.0 + P[P_C1D_D] * x))
    return float(P[P_C1] * (1.0 + P[P_C1D_D] * (1.0 - math.exp(-x / P[P_C1D_TAU]))))


@njit(cache=True)
def belt_spring(d: float, P: FloatArray, Q: IntArray) -> float:
    """Return the belt's spring deflection function s(d) [rad] (C2*s is the moment).

    Paper: ``s = d``; form 1 a dead band of full width b (backlash); form 2
    ``d*(1 + beta*(d/d_ref)^2)`` (hardening).

    Parameters
    ----------
    d : float
        Belt deflection phi2 - phi0 [rad].
    P, Q : ndarray
        Parameters and form codes.

    Returns
    -------
    float
        Effective deflection [rad].
    """
    form = Q[Q_BELT]
    if form == 0:
        return d
    if form == 1:
        h = 0.5 * P[P_BL_B]
        if d > h:
            return float(d - h)
        if d < -h:
            return float(d + h)
        return 0.0
    x = d / P[P_BH_DREF]
    return float(d * (1.0 + P[P_BH_BETA] * x * x))


@njit(cache=True)
def bearing(w1: float, P: FloatArray, Q: IntArray) -> float:
    """Return the chamber bearing's friction moment [N m] (opposes w1).

    Form 1 ``M_b*w1/sqrt(w1^2 + 0.01^2)``, form 2 ``M_b*tanh(w1/w_r)``, form 3
    ``M_b*tanh(w1/w_r) + c_b*w1``.

    Parameters
    ----------
    w1 : float
        Chamber speed [rad/s].
    P, Q : ndarray
        Parameters and form codes.

    Returns
    -------
    float
        Bearing moment [N m].
    """
    form = Q[Q_BEARING]
    if form == 0:
        return 0.0
    if form == 1:
        return float(P[P_BR_M] * w1 / math.sqrt(w1 * w1 + P[P_BR_WR] * P[P_BR_WR]))
    m = P[P_BR_M] * math.tanh(w1 / P[P_BR_WR])
    if form == 3:
        m += P[P_BR_C] * w1
    return float(m)


@njit(cache=True)
def viscous(v: float, P: FloatArray, Q: IntArray) -> float:
    """Return the viscous friction moment [N m] at slip speed v [rad/s].

    Form 1 ``c*v``, form 2 ``c*sgn(v)*|v|^n``.

    Parameters
    ----------
    v : float
        Slip speed [rad/s].
    P, Q : ndarray
        Parameters and form codes.

    Returns
    -------
    float
        Moment on the chamber [N m].
    """
    form = Q[Q_VISC]
    if form == 0:
        return 0.0
    if form == 1:
        return float(P[P_VIS_C] * v)
    return float(P[P_VIS_C] * math.copysign(abs(v) ** P[P_VIS_N], v))


@njit(cache=True)
def delayed_coefficient(
    tq: float, H: FloatArray, nh: int, P: FloatArray, Q: IntArray, DR: FloatArray
) -> float:
    """Return the paper's friction coefficient (deceleration rule included) at a past time.

    The history ``H`` holds rows (t [s], v [rad/s], v' [rad/s^2], mode: 0 stick,
    1 sliding on the curve, 2 sliding after the peak) at every accepted step end and
    before and after every event; the stretch ending at row ``hi`` has that row's
    mode. v is interpolated by the cubic Hermite polynomial through its values and
    rates (4th order), so the delayed law is as accurate as the steps.

    Parameters
    ----------
    tq : float
        Query time [s].
    H : ndarray, shape (cap, 4)
        The history.
    nh : int
        Number of rows used.
    P, Q, DR : ndarray
        Parameters, form codes, drift components.

    Returns
    -------
    float
        mu [-] (mu0(tq) while sticking and before the history starts).
    """
    m0, mi = mu_pair(tq, P, Q, DR)
    if nh == 0 or tq <= H[0, 0]:
        return m0
    if tq >= H[nh - 1, 0]:
        lo = nh - 1
        hi = nh - 1
    else:
        lo, hi = 0, nh - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if H[mid, 0] <= tq:
                lo = mid
            else:
                hi = mid
    mode = H[hi, 3]
    if mode == 0.0:
        return m0
    if mode == 2.0:
        return mi
    h = H[hi, 0] - H[lo, 0]
    if h <= 0.0:
        v = H[hi, 1]
    else:
        s = (tq - H[lo, 0]) / h
        s2 = s * s
        s3 = s2 * s
        v = (
            (2.0 * s3 - 3.0 * s2 + 1.0) * H[lo, 1]
            + (s3 - 2.0 * s2 + s) * h * H[lo, 2]
            + (-2.0 * s3 + 3.0 * s2) * H[hi, 1]
            + (s3 - s2) * h * H[hi, 2]
        )
    return curve(abs(v), m0, mi, P, Q)


@njit(cache=True)
def forces(
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
) -> tuple[float, float, float, float, float, float, float, float]:
    """Evaluate the moments of the rig in its current mode.

    Parameters
    ----------
    t : float
        Test time [s].
    y : ndarray
        State (:mod:`.layout`).
    m : ndarray
        Mode (stuck, direction, peak passed, stick start time).
    P, Q : ndarray
        Parameters and form codes.
    TR, RIP, DR : ndarray
        Drive transitions, ripple and drift components.
    H : ndarray
        History of the slip (time-delay form, :func:`delayed_coefficient`).
    nh : int
        Rows of the history.

    Returns
    -------
    tuple of float
        ``(a1, a2, M, M_stick, threshold, c_now, w0, ripple)``: chamber and shaft
        angular accelerations [rad/s^2], friction moment on the chamber [N m], the
        moment that holds the discs together (Equ. 6) [N m], the static limit
        ``F_N R mu_s`` [N m], the undelayed coefficient [-], the drive speed [rad/s]
        and its ripple [rad/s].
    """
    I1, I2 = P[P_I1], P[P_I2]
    w0b, phi0b = drive_base(t, TR)
    r = ripple(t, w0b, phi0b, P, Q, RIP)
    w0 = w0b + r
    phi1 = y[PHI1]
    w1 = y[W1]
    w2 = y[W2]
    Q1 = -P[P_K1] * w1 - (stiffness1(t, P, Q) + P[P_CB]) * phi1 - bearing(w1, P, Q)
    Q2 = -P[P_K2] * (w2 - w0) - P[P_C2] * belt_spring(y[DEFL], P, Q)
    m_stick = (I1 * Q2 - I2 * Q1) / (I1 + I2)
    m0, mi = mu_pair(t, P, Q, DR)
    fnr = normal_force(t, P, Q) * P[P_R]
    thr = fnr * (m0 + dwell(t - m[TSTICK0], P, Q))
    if m[STUCK] > 0.5:
        a = (Q1 + Q2) / (I1 + I2)
        return a, a, m_stick, m_stick, thr, m0, w0, r
    v = w2 - w1
    av = abs(v)
    c = mi if m[PEAK] > 0.5 else curve(av, m0, mi, P, Q)
    lag = Q[Q_LAG]
    if lag == 1:
        mu = y[Z]
    elif lag == 2:
        mu = delayed_coefficient(t - P[P_LAG_T], H, nh, P, Q, DR)
    elif lag == 3:
        mu = c + P[P_LAG_B] * (math.log(av + P[P_LAG_VR]) + y[Z] - math.log(P[P_LAG_DC]))
    else:
        mu = c
    M = m[SDIR] * fnr * mu + viscous(v, P, Q)
    return (Q1 + M) / I1, (Q2 - M) / I2, M, m_stick, thr, c, w0, r


@njit(cache=True)
def _filter(
    order: int, w: float, zeta: float, x: float, f: float, fd: float
) -> tuple[float, float]:
    """Return the rates of a channel filter's two states (order 0: unused, 1, 2)."""
    if order == 1:
        return (x - f) * w, 0.0
    if order == 2:
        return fd, w * w * (x - f) - 2.0 * zeta * w * fd
    return 0.0, 0.0


@njit(cache=True)
def rhs(
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
    dy: FloatArray,
) -> None:
    """Write the time derivative of the state into ``dy`` (units of ``y`` per second).

    Parameters
    ----------
    t : float
        Test time [s].
    y, m : ndarray
        State and mode.
    P, Q : ndarray
        Parameters and form codes.
    TR, RIP, DR : ndarray
        Drive transitions, ripple and drift components.
    H : ndarray
        History of the slip (time-delay form).
    nh : int
        Rows of the history.
    dy : ndarray
        Output, length ``NY``.
    """
    a1, a2, _M, _ms, _thr, c, w0, r = forces(t, y, m, P, Q, TR, RIP, DR, H, nh)
    w1 = y[W1]
    w2 = y[W2]
    dy[PHI1] = w1
    dy[W1] = a1
    dy[DEFL] = w2 - w0
    dy[W2] = a2
    dy[RHO] = r
    lag = Q[Q_LAG]
    if lag == 1:
        dy[Z] = 0.0 if m[STUCK] > 0.5 else (c - y[Z]) / P[P_LAG_T]
    elif lag == 3:
        dy[Z] = math.exp(-y[Z]) - (abs(w2 - w1) + P[P_LAG_VR]) / P[P_LAG_DC]
    else:
        dy[Z] = 0.0
    dy[TF], dy[TFD] = _filter(Q[Q_TF], P[P_TF_W], P[P_TF_Z], P[P_C1CAL] * y[PHI1], y[TF], y[TFD])
    dy[AF], dy[AFD] = _filter(Q[Q_AF], P[P_AF_W], P[P_AF_Z], a1, y[AF], y[AFD])
    dy[SF], dy[SFD] = _filter(Q[Q_SF], P[P_SF_W], P[P_SF_Z], w2, y[SF], y[SFD])
