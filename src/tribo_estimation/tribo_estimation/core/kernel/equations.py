"""Right-hand side of the rig's equations of motion (Equ. 1-3, 6, 8), compiled with numba.

The drive (w0(t), phi0(t)), the friction law (Equ. 8 with the paper's deceleration
rule and the extension slots: drift, dwell-time stiction, frictional lag, viscous
friction, shape exponent), the external moments on chamber and shaft, the stick
moment (Equ. 6, corrected) and the derivatives used by the RK4 step, with the
rates of the effects' own state variables (:func:`effect_rates`) and their values at
the start of a sliding phase (:func:`breakaway_state`). Flat-array interface: the
parameter vector ``p`` and the integrated state ``y`` (a tuple, indices ``Y_*``) of
:mod:`.layout`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .layout import (
    D_M,
    D_ZERO,
    P_BEARING,
    P_BEARING_REG,
    P_C1,
    P_C2,
    P_DRIFT_MU0,
    P_DRIFT_MUINF,
    P_FN,
    P_I1,
    P_I2,
    P_K,
    P_K1,
    P_K2,
    P_LAG_TAU,
    P_MU0,
    P_MUINF,
    P_R,
    P_RAMP,
    P_RIP2_AMP,
    P_RIP2_PHASE,
    P_RIP_AMP,
    P_RIP_FREQ,
    P_RIP_PHASE,
    P_RIPA2_PHASE,
    P_RIPA2_REL,
    P_RIPA_ANGLE0,
    P_RIPA_ORDER,
    P_RIPA_PHASE,
    P_RIPA_REL,
    P_SHAPE,
    P_ST_GAIN,
    P_ST_LOG,
    P_ST_TAU,
    P_T_DRIVE,
    P_VISC,
    P_W0,
    P_W0_COS,
    P_W0_OMEGA,
    P_W0_RATE,
    Y_LAG,
    Y_PHI1,
    Y_PHI2,
    Y_W1,
    Y_W2,
)
from .state import FASTMATH, FloatTuple, with_entry

FloatArray = NDArray[np.float64]


# ================================================================ drive and friction law
@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def drive_speed(p: FloatArray, t: float) -> float:
    """Return the drive speed w0(t) [rad/s].

    A linear start-up ramp to the nominal speed (``P_RAMP`` > 0), else one piece
    ``w0 + rate*(t - t_ref) + c*cos(om*(t - t_ref))`` of a measured drive profile
    (``c`` = ``P_W0_COS``, 0 for a linear piece; a raised-cosine piece has rate 0);
    plus the ripple in time (``P_RIP_*``) and the ripple locked to the drive angle
    (``P_RIPA_*``, :mod:`.layout`).

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].

    Returns
    -------
    float
        w0(t) [rad/s].
    """
    wn, an = piece_drive(p, t)
    return with_speed_ripple(p, t, wn, an)


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def with_speed_ripple(p: FloatArray, t: float, wn: float, an: float) -> float:
    """Return the drive speed [rad/s] from the piece's speed ``wn`` and angle ``an``.

    Adds the ripple locked to the drive angle and the ripple in time to the ramp's or
    the piece's own speed (:func:`piece_drive`), as :func:`drive_speed` describes.
    """
    w = wn
    rel = p[P_RIPA_REL]
    rel2 = p[P_RIPA2_REL]
    if rel != 0.0 or rel2 != 0.0:
        n_theta = p[P_RIPA_ORDER] * (an + p[P_RIPA_ANGLE0])
        w += rel * wn * math.sin(n_theta + p[P_RIPA_PHASE])
        w += rel2 * wn * math.sin(2.0 * n_theta + p[P_RIPA2_PHASE])
    amp = p[P_RIP_AMP]
    if amp != 0.0:
        w += amp * math.sin(2.0 * math.pi * p[P_RIP_FREQ] * t + p[P_RIP_PHASE])
    amp2 = p[P_RIP2_AMP]
    if amp2 != 0.0:
        w += amp2 * math.sin(4.0 * math.pi * p[P_RIP_FREQ] * t + p[P_RIP2_PHASE])
    return float(w)


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def piece_drive(p: FloatArray, t: float) -> tuple[float, float]:
    """Return the ripple-free drive speed [rad/s] and angle [rad] of the ramp or the piece.

    A linear start-up ramp to ``P_W0`` over ``P_RAMP`` (> 0), else one piece
    ``w0 + rate*(t - t_ref) + c*cos(om*(t - t_ref))`` of a measured drive profile; the
    angle is the speed's integral from 0 to t (the piece's own angle:
    :data:`.layout.P_RIPA_ANGLE0` added makes it the drive angle from the profile's
    first knot). Speed and angle share their terms: the kernel needs both at every
    stage (:func:`shaft_moment`).
    """
    w0n = p[P_W0]
    tr = p[P_RAMP]
    if tr > 0.0:
        if t >= tr:
            return w0n, w0n * (t - 0.5 * tr)
        if t > 0.0:
            return w0n * (t / tr), 0.5 * w0n * t * t / tr
        return 0.0, 0.0
    # one piece of a measured drive profile (rate 0: constant)
    rate = p[P_W0_RATE]
    tref = p[P_T_DRIVE]
    dtr = t - tref
    w = w0n + rate * dtr
    a = w0n * t + 0.5 * rate * (dtr * dtr - tref * tref)
    c = p[P_W0_COS]
    if c != 0.0:
        om0 = p[P_W0_OMEGA]
        w += c * math.cos(om0 * dtr)
        a += c / om0 * (math.sin(om0 * dtr) + math.sin(om0 * tref))
    return w, a


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def piece_angle(p: FloatArray, t: float) -> float:
    """Return the ripple-free drive angle of the ramp or the piece [rad] (:func:`piece_drive`)."""
    return float(piece_drive(p, t)[1])


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def drive_angle(p: FloatArray, t: float) -> float:
    """Return the drive angle phi0(t) = integral_0^t w0 dt' [rad].

    Closed form of :func:`drive_speed`; the ripple locked to the drive angle adds
    ``r/n*(cos p - cos(n*theta + p))`` (its integral over ``d theta = w_n dt``), its
    second harmonic ``r2/(2n)*(cos p2 - cos(2n*theta + p2))``.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].

    Returns
    -------
    float
        phi0(t) [rad].
    """
    return with_angle_ripple(p, t, piece_angle(p, t))


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def with_angle_ripple(p: FloatArray, t: float, an: float) -> float:
    """Return the drive angle [rad] from the piece's own angle ``an``.

    Adds the integrals of both ripples to the ramp's or the piece's angle
    (:func:`piece_drive`), as :func:`drive_angle` describes.
    """
    a = an
    rel = p[P_RIPA_REL]
    rel2 = p[P_RIPA2_REL]
    n = p[P_RIPA_ORDER]
    if (rel != 0.0 or rel2 != 0.0) and n > 0.0:
        n_theta = n * (a + p[P_RIPA_ANGLE0])
        ph = p[P_RIPA_PHASE]
        ph2 = p[P_RIPA2_PHASE]
        a += rel / n * (math.cos(ph) - math.cos(n_theta + ph))
        a += rel2 / (2.0 * n) * (math.cos(ph2) - math.cos(2.0 * n_theta + ph2))
    amp = p[P_RIP_AMP]
    f = p[P_RIP_FREQ]
    if amp != 0.0 and f > 0.0:
        om = 2.0 * math.pi * f
        ph = p[P_RIP_PHASE]
        a += amp / om * (math.cos(ph) - math.cos(om * t + ph))
    amp2 = p[P_RIP2_AMP]
    if amp2 != 0.0 and f > 0.0:
        om2 = 4.0 * math.pi * f
        ph2 = p[P_RIP2_PHASE]
        a += amp2 / om2 * (math.cos(ph2) - math.cos(om2 * t + ph2))
    return a


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def friction_levels(p: FloatArray, t: float) -> tuple[float, float]:
    """Return (mu0(t), mu_inf(t)) including the linear drift with test time.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].

    Returns
    -------
    tuple of float
        mu0(t), mu_inf(t) [-].
    """
    return p[P_MU0] + p[P_DRIFT_MU0] * t, p[P_MUINF] + p[P_DRIFT_MUINF] * t


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def friction_coefficient(p: FloatArray, t: float, v_abs: float, peak_passed: bool) -> float:
    """Return the friction coefficient of Equ. 8 with the paper's deceleration rule.

    ``mu = (mu0 - mu_inf)*exp(-k*|v|) + mu_inf`` while |v| rises within a sliding
    phase; ``mu = mu_inf`` once the slip-speed peak has passed. With the shape hook
    ``P_SHAPE`` = delta - 1 != 0 the exponent is ``(k*|v|)**delta`` (generalised Stribeck).

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    v_abs : float
        Slip speed magnitude |v| [rad/s].
    peak_passed : bool
        Whether |v| passed its maximum in this sliding phase.

    Returns
    -------
    float
        mu [-].
    """
    mu0, muinf = friction_levels(p, t)
    if peak_passed:
        return muinf
    if p[P_SHAPE] == 0.0:
        return (mu0 - muinf) * math.exp(-p[P_K] * v_abs) + muinf
    return (mu0 - muinf) * math.exp(-((p[P_K] * v_abs) ** (1.0 + p[P_SHAPE]))) + muinf


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def static_coefficient(p: FloatArray, t: float, t_stick: float) -> float:
    """Return the static friction coefficient mu_s(t, t_stick).

    ``mu_s = mu0(t) + gain*(1 - exp(-t_stick/tau)) + b*ln(1 + t_stick/tau)``: the
    dwell-time stiction terms (saturating and logarithmic forms) are zero for the
    paper's model (gain = b = 0).

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    t_stick : float
        Duration of the current stick phase [s].

    Returns
    -------
    float
        mu_s [-].
    """
    mu0, _ = friction_levels(p, t)
    g = p[P_ST_GAIN]
    if g != 0.0:
        tau = p[P_ST_TAU]
        if tau > 0.0:
            mu0 += g * (1.0 - math.exp(-t_stick / tau))
        else:
            mu0 += g
    b = p[P_ST_LOG]
    if b != 0.0 and p[P_ST_TAU] > 0.0:
        mu0 += b * math.log1p(max(t_stick, 0.0) / p[P_ST_TAU])
    return mu0


# ================================================================ equations of motion
@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def bearing_moment(p: FloatArray, w1: float) -> float:
    """Return the regularised Coulomb moment of the chamber bearing, opposing w1.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    w1 : float
        Chamber speed [rad/s].

    Returns
    -------
    float
        M_b [N m].
    """
    mb = p[P_BEARING]
    if mb == 0.0:
        return 0.0
    reg = p[P_BEARING_REG]
    return float(mb * w1 / math.sqrt(w1 * w1 + reg * reg))


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def chamber_moment(p: FloatArray, phi1: float, w1: float) -> float:
    """Return the external moment on the chamber except friction.

    ``Q1 = -K1*w1 - C1*phi1 - M_b`` (Equ. 1).

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    phi1 : float
        Chamber angle [rad].
    w1 : float
        Chamber speed [rad/s].

    Returns
    -------
    float
        Q1 [N m].
    """
    return float(-p[P_K1] * w1 - p[P_C1] * phi1 - bearing_moment(p, w1))


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def shaft_moment(p: FloatArray, t: float, phi2: float, w2: float) -> float:
    """Return the external moment on the shaft except friction.

    ``Q2 = -K2*(w2 - w0) - C2*(phi2 - phi0)`` (Equ. 2).

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    phi2 : float
        Shaft angle [rad].
    w2 : float
        Shaft speed [rad/s].

    Returns
    -------
    float
        Q2 [N m].
    """
    # the piece computed once for both (the kernel's every stage), its ripples added
    wn, an = piece_drive(p, t)
    w0 = with_speed_ripple(p, t, wn, an)
    phi0 = with_angle_ripple(p, t, an)
    return float(-p[P_K2] * (w2 - w0) - p[P_C2] * (phi2 - phi0))


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def stick_moment(p: FloatArray, t: float, phi1: float, w: float, phi2: float) -> float:
    """Return the moment that keeps the discs together while sticking (Equ. 6, corrected).

    ``M_stick = [I2*(K1*w + C1*phi1) - I1*(K2*(w - w0) + C2*(phi2 - phi0))]/(I1 + I2)``
    (plus the bearing term inside Q1 when that extension is active).

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    phi1 : float
        Chamber angle [rad].
    w : float
        Common speed of the stuck discs [rad/s].
    phi2 : float
        Shaft angle [rad].

    Returns
    -------
    float
        M_stick [N m].
    """
    i1 = p[P_I1]
    i2 = p[P_I2]
    q1 = chamber_moment(p, phi1, w)
    q2 = shaft_moment(p, t, phi2, w)
    return float((i1 * q2 - i2 * q1) / (i1 + i2))


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def slip_friction_moment(
    p: FloatArray, t: float, v: float, direction: float, peak_passed: bool, lag: float
) -> float:
    """Return the sliding friction moment on the chamber (Equ. 3 with Equ. 8).

    ``M = F_N*R*dir*mu + viscous*v``; with the frictional-lag extension
    (lag_tau > 0) ``mu`` is the lagged coefficient carried in the state.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    v : float
        Slip speed w2 - w1 [rad/s].
    direction : float
        Slip direction of the sliding phase (+1/-1).
    peak_passed : bool
        Whether |v| passed its maximum in this sliding phase.
    lag : float
        Lagged friction coefficient [-].

    Returns
    -------
    float
        M [N m].
    """
    if p[P_LAG_TAU] > 0.0:
        mu = lag
    else:
        mu = friction_coefficient(p, t, abs(v), peak_passed)
    return float(p[P_FN] * p[P_R] * direction * mu + p[P_VISC] * v)


@njit(
    cache=True,
    inline='always',
    error_model='numpy',
    fastmath=FASTMATH,
)
def effect_rates(
    p: FloatArray,
    t: float,
    y: FloatTuple,
    stuck: bool,
    direction: float,
    peak_passed: bool,
    d: FloatTuple,
) -> FloatTuple:
    """Return ``d`` with the derivatives of the effects' own integrated states filled in.

    The one place where an effect's state variable gets its rate: the frictional
    lag ``lag' = (mu(|v|) - lag)/lag_tau`` while sliding (0 while sticking or with
    the extension off). ``d`` arrives with every effect rate 0.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    y : tuple of float
        Integrated state (length ``NY``, indices ``Y_*``).
    stuck : bool
        Whether the discs stick.
    direction : float
        Slip direction (+1/-1).
    peak_passed : bool
        Whether |v| passed its maximum in this sliding phase.
    d : tuple of float
        Right-hand side with the mechanical entries set (length ``ND``).

    Returns
    -------
    tuple of float
        ``d`` with the entries ``Y_LAG`` (and any further effect state) set [unit/s].
    """
    if stuck:
        return d
    dlag = 0.0
    tau = p[P_LAG_TAU]
    if tau > 0.0:
        v_abs = abs(y[Y_W2] - y[Y_W1])
        dlag = (friction_coefficient(p, t, v_abs, peak_passed) - y[Y_LAG]) / tau
    return with_entry(d, Y_LAG, dlag)


@njit(
    cache=True,
    inline='always',
    error_model='numpy',
    fastmath=FASTMATH,
)
def breakaway_state(p: FloatArray, t: float, y: FloatTuple, mu_s: float) -> FloatTuple:
    """Return ``y`` with the effects' states re-initialised at a breakaway.

    The frictional lag starts the sliding phase at the static coefficient ``mu_s``.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Time of the breakaway [s].
    y : tuple of float
        Integrated state at the breakaway (length ``NY``, indices ``Y_*``).
    mu_s : float
        Static friction coefficient at the breakaway [-].

    Returns
    -------
    tuple of float
        The state the sliding phase starts from.
    """
    return with_entry(y, Y_LAG, mu_s)


@njit(
    cache=True,
    inline='always',
    error_model='numpy',
    fastmath=FASTMATH,
)
def derivatives(
    p: FloatArray,
    t: float,
    y: FloatTuple,
    stuck: bool,
    direction: float,
    peak_passed: bool,
) -> FloatTuple:
    """Return the right-hand side of Equ. 1-3 (sliding) or of the stuck system (Equ. 6).

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    y : tuple of float
        Integrated state (length ``NY``, indices ``Y_*``: phi1 [rad], w1 [rad/s],
        phi2 [rad], w2 [rad/s], lag [-], ...).
    stuck : bool
        Whether the discs stick.
    direction : float
        Slip direction (+1/-1).
    peak_passed : bool
        Whether |v| passed its maximum in this sliding phase.

    Returns
    -------
    tuple of float
        Length ``ND``: the derivative of each entry of ``y`` at the same index
        (phi1' [rad/s], w1' [rad/s^2], phi2' [rad/s], w2' [rad/s^2], lag' [1/s], ...;
        the effects' rates from :func:`effect_rates`), then the friction moment M [N m]
        at ``D_M``.
    """
    i1 = p[P_I1]
    i2 = p[P_I2]
    phi1 = y[Y_PHI1]
    w1 = y[Y_W1]
    q1 = chamber_moment(p, phi1, w1)
    if stuck:  # w2 = w1: one body of inertia I1 + I2 (Equ. 6)
        w2 = w1
        q2 = shaft_moment(p, t, y[Y_PHI2], w1)
        a1 = (q1 + q2) / (i1 + i2)
        a2 = a1
        m = (i1 * q2 - i2 * q1) / (i1 + i2)
    else:
        w2 = y[Y_W2]
        q2 = shaft_moment(p, t, y[Y_PHI2], w2)
        m = slip_friction_moment(p, t, w2 - w1, direction, peak_passed, y[Y_LAG])
        a1 = (q1 + m) / i1
        a2 = (q2 - m) / i2
    d = with_entry(D_ZERO, Y_PHI1, w1)
    d = with_entry(d, Y_W1, a1)
    d = with_entry(d, Y_PHI2, w2)
    d = with_entry(d, Y_W2, a2)
    d = with_entry(d, D_M, m)
    return effect_rates(p, t, y, stuck, direction, peak_passed, d)


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def _derivatives_call(
    p: FloatArray,
    t: float,
    y: FloatTuple,
    stuck: bool,
    direction: float,
    peak_passed: bool,
) -> FloatTuple:
    """Call :func:`derivatives` without inlining (rare call sites; low compile time)."""
    return derivatives(p, t, y, stuck, direction, peak_passed)


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def drive_speed_array(p: FloatArray, t: FloatArray) -> FloatArray:
    """Return :func:`drive_speed` at every time of ``t``.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : FloatArray
        Test times [s].

    Returns
    -------
    FloatArray
        w0 [rad/s].
    """
    out = np.empty(t.shape[0])
    for i in range(t.shape[0]):
        out[i] = drive_speed(p, t[i])
    return out


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def drive_angle_array(p: FloatArray, t: FloatArray) -> FloatArray:
    """Return :func:`drive_angle` at every time of ``t``.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : FloatArray
        Test times [s].

    Returns
    -------
    FloatArray
        phi0 [rad].
    """
    out = np.empty(t.shape[0])
    for i in range(t.shape[0]):
        out[i] = drive_angle(p, t[i])
    return out


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def friction_coefficient_array(
    p: FloatArray, t: float, v_abs: FloatArray, peak_passed: bool
) -> FloatArray:
    """Return :func:`friction_coefficient` at every slip speed of ``v_abs``.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    v_abs : FloatArray
        Slip speed magnitudes [rad/s].
    peak_passed : bool
        Whether the slip-speed peak has passed.

    Returns
    -------
    FloatArray
        mu [-].
    """
    out = np.empty(v_abs.shape[0])
    for i in range(v_abs.shape[0]):
        out[i] = friction_coefficient(p, t, v_abs[i], peak_passed)
    return out
