"""Compiled (numba) equations of motion and event-accurate stick/slip integrator.

This module is the ONE place where the rig's equations of motion are written
(paper Equ. 1-3, 6, 8 as corrected in ``docs/physics.md``). Everything else
(:mod:`.model` Python wrappers, :mod:`.simulate`, :mod:`.reference`, the block fits,
the simulated rig driver, the discrepancy workflow) calls these functions.

Symbols (paper naming: K = viscous damping, C = torsional stiffness):

- body 1 = test chamber (angle ``phi1`` [rad], speed ``w1`` [rad/s]),
- body 2 = drive shaft (``phi2``, ``w2``), driven through the belt by ``phi0(t)``, ``w0(t)``,
- slip speed ``v = w2 - w1`` [rad/s]; friction moment ``+M`` on the chamber, ``-M`` on the shaft.

Equations::

    I1*w1' = -K1*w1 - C1*phi1 - M_b(w1) + M                      (1)
    I2*w2' = -K2*(w2 - w0) - C2*(phi2 - phi0) - M                (2)
    sliding:  M = F_N*R*dir*mu + viscous*v                       (3), (8)
    sticking: w1 = w2 = w, M = M_stick                           (6)

with ``M_b`` the (regularised) bearing Coulomb moment of the extension set
(zero in the paper's model). ``M_stick`` generalises Equ. 6 to any external
moments ``Q1`` (chamber) and ``Q2`` (shaft): ``M_stick = (I1*Q2 - I2*Q1)/(I1 + I2)``.

Flat-array interface (no Python objects, callable from other ``@njit`` code):

- parameter vector ``p`` (length :data:`NP`, indices ``P_*``),
- state vector ``s`` (length :data:`NS`, indices ``S_*``), updated in place,
- :func:`integrate` ``(p, s, n_out, dt, n_sub, out) -> n_events`` writes
  :data:`N_CH` output channels (indices ``OUT_*``) for ``n_out`` samples.

Integration: classical RK4 at a fixed step ``h = dt/n_sub`` aligned to the
output instants. Switching events (slip end ``v = 0``, slip-speed peak for the
paper's deceleration rule, breakaway ``|M_stick| = F_N*R*mu_s``) are detected
per step and located by Illinois (regula falsi) iteration on the RK4 solution
restarted from the step start, to a time tolerance of ``EVENT_TOL`` times the
step; the step is then restarted from the event. Outputs are therefore sampled
at the exact instants ``t_base + i*dt``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# ---------------------------------------------------------------- parameter vector
P_I1 = 0  # chamber inertia [kg m^2]
P_K1 = 1  # chamber viscous damping [N m s/rad]
P_C1 = 2  # torsion element stiffness [N m/rad]
P_I2 = 3  # drive shaft inertia [kg m^2]
P_K2 = 4  # drive damping [N m s/rad]
P_C2 = 5  # drive stiffness [N m/rad]
P_FN = 6  # total normal force [N]
P_R = 7  # effective friction radius [m]
P_MU0 = 8  # static / zero-speed friction coefficient [-]
P_MUINF = 9  # high-speed friction coefficient [-]
P_K = 10  # Stribeck decay constant k [s/rad]
P_W0 = 11  # nominal drive speed [rad/s]
P_RAMP = 12  # start-up ramp time of the drive [s] (0 = step)
P_ST_GAIN = 13  # dwell-time stiction gain [-]
P_ST_TAU = 14  # dwell-time stiction time constant [s]
P_LAG_TAU = 15  # frictional lag time constant [s]
P_VISC = 16  # viscous friction in the contact [N m s/rad]
P_DRIFT_MU0 = 17  # drift of mu0 with test time [1/s]
P_DRIFT_MUINF = 18  # drift of mu_inf with test time [1/s]
P_RIP_AMP = 19  # drive speed ripple amplitude [rad/s]
P_RIP_FREQ = 20  # drive speed ripple frequency [Hz]
P_RIP_PHASE = 21  # drive speed ripple phase [rad]
P_BEARING = 22  # bearing Coulomb moment on the chamber [N m]
P_BEARING_REG = 23  # regularisation speed of the bearing moment [rad/s]
P_W0_RATE = 24  # drive acceleration of a linear drive piece [rad/s^2] (ramp time 0 only)
P_T_DRIVE = 25  # reference time of the linear drive piece [s]: w0(t) = w0 + rate*(t - t_ref)
#: Generic friction-law shape hook: offset of the Stribeck shape exponent from 1 [-],
#: ``mu = (mu0 - mu_inf)*exp(-(k*|v|)**(1 + shape)) + mu_inf``; 0 gives Equ. 8 exactly.
P_SHAPE = 26
NP = 27

#: Default regularisation speed of the bearing Coulomb moment [rad/s]:
#: ``M_b(w1) = bearing_moment * w1 / sqrt(w1^2 + w_reg^2)``. With ``w_reg = 0.01 rad/s``
#: the equivalent viscous slope ``bearing_moment/w_reg`` stays RK4-stable at
#: 10 kHz for bearing moments up to about 1 N m on the Tab. 1 chamber.
BEARING_REG_SPEED = 0.01

# ---------------------------------------------------------------- state vector
S_T = 0  # time [s]
S_PHI1 = 1  # chamber angle [rad]
S_W1 = 2  # chamber speed [rad/s]
S_PHI2 = 3  # shaft angle [rad]
S_W2 = 4  # shaft speed [rad/s]
S_LAG = 5  # lagged friction coefficient (frictional-lag extension) [-]
S_STUCK = 6  # 1.0 while sticking, else 0.0
S_DIR = 7  # slip direction sgn(v) of the current sliding phase (+1/-1)
S_PEAK = 8  # 1.0 once |v| passed its maximum in this sliding phase (deceleration rule)
S_VMAX = 9  # max |v| in the current sliding phase [rad/s]
S_TSTICK = 10  # duration of the current stick phase [s]
S_SENSOR = 11  # state of the torque-sensor lag filter [N m] (NaN = not started)
NS = 12

# ---------------------------------------------------------------- output channels
OUT_TORSION = 0  # C1*phi1 [N m]
OUT_ACCEL = 1  # w1' [rad/s^2]
OUT_SPEED = 2  # w2 [rad/s]
OUT_FRICTION = 3  # friction moment M [N m]
OUT_SLIP = 4  # v = w2 - w1 [rad/s]
OUT_STICK = 5  # 1.0 when sticking
OUT_W1 = 6  # chamber speed w1 [rad/s]
N_CH = 7

#: Relative time tolerance of the event location (fraction of one step).
EVENT_TOL = 1e-9
_MAX_ITER = 60
_MAX_ZERO_EVENTS = 8

EV_NONE = 0
EV_SLIP_END = 1
EV_PEAK = 2
EV_BREAKAWAY = 3


# ================================================================ drive and friction law
@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def drive_speed(p: np.ndarray, t: float) -> float:
    """Drive speed w0(t) [rad/s]: linear start-up ramp to the nominal speed (``P_RAMP`` > 0),
    else one linear piece ``w0 + rate*(t - t_ref)`` of a measured drive profile; plus ripple."""
    w0n = p[P_W0]
    tr = p[P_RAMP]
    if tr > 0.0:
        w = w0n * (t / tr if t < tr else 1.0)
        if t < 0.0:
            w = 0.0
    else:  # one linear piece of a measured drive profile (rate 0: constant)
        w = w0n + p[P_W0_RATE] * (t - p[P_T_DRIVE])
    amp = p[P_RIP_AMP]
    if amp != 0.0:
        w += amp * math.sin(2.0 * math.pi * p[P_RIP_FREQ] * t + p[P_RIP_PHASE])
    return w


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def drive_angle(p: np.ndarray, t: float) -> float:
    """Drive angle phi0(t) = integral_0^t w0 dt' [rad] (closed form of :func:`drive_speed`)."""
    w0n = p[P_W0]
    tr = p[P_RAMP]
    if tr > 0.0:
        if t <= 0.0:
            a = 0.0
        elif t < tr:
            a = 0.5 * w0n * t * t / tr
        else:
            a = w0n * (t - 0.5 * tr)
    else:
        rate = p[P_W0_RATE]
        tref = p[P_T_DRIVE]
        a = w0n * t + 0.5 * rate * ((t - tref) * (t - tref) - tref * tref)
    amp = p[P_RIP_AMP]
    f = p[P_RIP_FREQ]
    if amp != 0.0 and f > 0.0:
        om = 2.0 * math.pi * f
        ph = p[P_RIP_PHASE]
        a += amp / om * (math.cos(ph) - math.cos(om * t + ph))
    return a


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def friction_levels(p: np.ndarray, t: float) -> tuple[float, float]:
    """(mu0(t), mu_inf(t)) including the linear drift with test time t [s]."""
    return p[P_MU0] + p[P_DRIFT_MU0] * t, p[P_MUINF] + p[P_DRIFT_MUINF] * t


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def friction_coefficient(p: np.ndarray, t: float, v_abs: float, peak_passed: bool) -> float:
    """Friction coefficient of Equ. 8 with the paper's deceleration rule.

    ``mu = (mu0 - mu_inf)*exp(-k*|v|) + mu_inf`` while |v| rises within a sliding
    phase; ``mu = mu_inf`` once the slip-speed peak has passed. With the shape hook
    ``P_SHAPE`` = delta - 1 != 0 the exponent is ``(k*|v|)**delta`` (generalised Stribeck).
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
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def static_coefficient(p: np.ndarray, t: float, t_stick: float) -> float:
    """Static friction coefficient mu_s = mu0(t) + gain*(1 - exp(-t_stick/tau)) [-].

    The dwell-time stiction term is zero for the paper's model (gain = 0).
    """
    mu0, _ = friction_levels(p, t)
    g = p[P_ST_GAIN]
    if g != 0.0:
        tau = p[P_ST_TAU]
        if tau > 0.0:
            mu0 += g * (1.0 - math.exp(-t_stick / tau))
        else:
            mu0 += g
    return mu0


# ================================================================ equations of motion
@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def bearing_moment(p: np.ndarray, w1: float) -> float:
    """Regularised Coulomb moment of the chamber bearing, opposing w1 [N m]."""
    mb = p[P_BEARING]
    if mb == 0.0:
        return 0.0
    reg = p[P_BEARING_REG]
    return mb * w1 / math.sqrt(w1 * w1 + reg * reg)


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def chamber_moment(p: np.ndarray, phi1: float, w1: float) -> float:
    """External moment on the chamber except friction, Q1 = -K1*w1 - C1*phi1 - M_b [N m]."""
    return -p[P_K1] * w1 - p[P_C1] * phi1 - bearing_moment(p, w1)


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def shaft_moment(p: np.ndarray, t: float, phi2: float, w2: float) -> float:
    """External moment on the shaft except friction, Q2 = -K2*(w2-w0) - C2*(phi2-phi0) [N m]."""
    if p[P_RIP_AMP] != 0.0:
        w0 = drive_speed(p, t)
        phi0 = drive_angle(p, t)
    else:  # fast path without the ripple: same formulas as drive_speed/drive_angle
        w0n = p[P_W0]
        tr = p[P_RAMP]
        if tr > 0.0:
            if t >= tr:
                w0 = w0n
                phi0 = w0n * (t - 0.5 * tr)
            elif t > 0.0:
                w0 = w0n * (t / tr)
                phi0 = 0.5 * w0n * t * t / tr
            else:
                w0 = 0.0
                phi0 = 0.0
        else:
            rate = p[P_W0_RATE]
            dtr = t - p[P_T_DRIVE]
            w0 = w0n + rate * dtr
            phi0 = w0n * t + 0.5 * rate * (dtr * dtr - p[P_T_DRIVE] * p[P_T_DRIVE])
    return -p[P_K2] * (w2 - w0) - p[P_C2] * (phi2 - phi0)


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def stick_moment(p: np.ndarray, t: float, phi1: float, w: float, phi2: float) -> float:
    """Moment that keeps the discs together while sticking (Equ. 6, corrected) [N m].

    ``M_stick = [I2*(K1*w + C1*phi1) - I1*(K2*(w - w0) + C2*(phi2 - phi0))]/(I1 + I2)``
    (plus the bearing term inside Q1 when that extension is active).
    """
    i1 = p[P_I1]
    i2 = p[P_I2]
    q1 = chamber_moment(p, phi1, w)
    q2 = shaft_moment(p, t, phi2, w)
    return (i1 * q2 - i2 * q1) / (i1 + i2)


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def slip_friction_moment(
    p: np.ndarray, t: float, v: float, direction: float, peak_passed: bool, lag: float
) -> float:
    """Sliding friction moment on the chamber (Equ. 3 with Equ. 8) [N m].

    ``M = F_N*R*dir*mu + viscous*v``; with the frictional-lag extension
    (lag_tau > 0) ``mu`` is the lagged coefficient carried in the state.
    """
    if p[P_LAG_TAU] > 0.0:
        mu = lag
    else:
        mu = friction_coefficient(p, t, abs(v), peak_passed)
    return p[P_FN] * p[P_R] * direction * mu + p[P_VISC] * v


@njit(
    cache=True,
    inline='always',
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
)
def derivatives(
    p: np.ndarray,
    t: float,
    phi1: float,
    w1: float,
    phi2: float,
    w2: float,
    lag: float,
    stuck: bool,
    direction: float,
    peak_passed: bool,
) -> tuple[float, float, float, float, float, float]:
    """Right-hand side of Equ. 1-3 (sliding) or the stuck system (Equ. 6).

    Returns ``(phi1', w1', phi2', w2', lag', M)``; units rad/s, rad/s^2, rad/s,
    rad/s^2, 1/s, N m.
    """
    i1 = p[P_I1]
    i2 = p[P_I2]
    q1 = chamber_moment(p, phi1, w1)
    if stuck:
        q2 = shaft_moment(p, t, phi2, w1)
        wd = (q1 + q2) / (i1 + i2)
        m = (i1 * q2 - i2 * q1) / (i1 + i2)
        return w1, wd, w1, wd, 0.0, m
    q2 = shaft_moment(p, t, phi2, w2)
    v = w2 - w1
    m = slip_friction_moment(p, t, v, direction, peak_passed, lag)
    dlag = 0.0
    tau = p[P_LAG_TAU]
    if tau > 0.0:
        dlag = (friction_coefficient(p, t, abs(v), peak_passed) - lag) / tau
    return w1, (q1 + m) / i1, w2, (q2 - m) / i2, dlag, m


@njit(cache=True, error_model='numpy', fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'})
def _derivatives_call(
    p: np.ndarray,
    t: float,
    phi1: float,
    w1: float,
    phi2: float,
    w2: float,
    lag: float,
    stuck: bool,
    direction: float,
    peak_passed: bool,
) -> tuple[float, float, float, float, float, float]:
    """Non-inlined :func:`derivatives` for the rare call sites (keeps compile time low)."""
    return derivatives(p, t, phi1, w1, phi2, w2, lag, stuck, direction, peak_passed)


# ================================================================ integrator
#: Largest allowed product of step and the local slip-dynamics rate (see :func:`slip_rate`).
STEP_RATE = 0.15


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
    inline='always',
)
def slip_rate(p: np.ndarray, t: float, v_abs: float, peak_passed: bool) -> float:
    """Rate of the slip dynamics due to the friction-curve slope [1/s].

    ``|dM/dv|*(1/I1 + 1/I2)`` with ``dM/dv`` from Equ. 8 (and viscous friction);
    used to shorten the RK4 step right after breakaway, where the falling
    friction curve acts as a negative damper.
    """
    slope = p[P_VISC]
    if not peak_passed and p[P_LAG_TAU] <= 0.0:
        mu0, muinf = friction_levels(p, t)
        if p[P_SHAPE] == 0.0:
            d = p[P_K] * math.exp(-p[P_K] * v_abs)
        else:
            # |d/dv exp(-(k v)^delta)|, with k*v floored so that delta < 1 stays finite at v = 0
            delta = 1.0 + p[P_SHAPE]
            kv = max(p[P_K] * v_abs, 1e-3)
            d = delta * p[P_K] * kv ** (delta - 1.0) * math.exp(-(kv**delta))
        slope += p[P_FN] * p[P_R] * abs(mu0 - muinf) * d
    return slope * (1.0 / p[P_I1] + 1.0 / p[P_I2])


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
)
def _rk4(
    p: np.ndarray,
    t: float,
    y0: float,
    y1: float,
    y2: float,
    y3: float,
    y4: float,
    k1: tuple[float, float, float, float, float, float],
    h: float,
    stuck: bool,
    direction: float,
    peak: bool,
) -> tuple[float, float, float, float, float]:
    """One classical RK4 step of length h from (t, y) with the first stage k1 given."""
    hh = 0.5 * h
    k2 = derivatives(
        p,
        t + hh,
        y0 + hh * k1[0],
        y1 + hh * k1[1],
        y2 + hh * k1[2],
        y3 + hh * k1[3],
        y4 + hh * k1[4],
        stuck,
        direction,
        peak,
    )
    k3 = derivatives(
        p,
        t + hh,
        y0 + hh * k2[0],
        y1 + hh * k2[1],
        y2 + hh * k2[2],
        y3 + hh * k2[3],
        y4 + hh * k2[4],
        stuck,
        direction,
        peak,
    )
    k4 = derivatives(
        p,
        t + h,
        y0 + h * k3[0],
        y1 + h * k3[1],
        y2 + h * k3[2],
        y3 + h * k3[3],
        y4 + h * k3[4],
        stuck,
        direction,
        peak,
    )
    h6 = h / 6.0
    return (
        y0 + h6 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
        y1 + h6 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
        y2 + h6 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
        y3 + h6 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
        y4 + h6 * (k1[4] + 2.0 * k2[4] + 2.0 * k3[4] + k4[4]),
    )


@njit(
    cache=True,
    error_model='numpy',
    fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'},
)
def _event_value(
    p: np.ndarray,
    which: int,
    t: float,
    y: tuple[float, float, float, float, float],
    stuck: bool,
    direction: float,
    peak: bool,
    t_stick: float,
) -> float:
    """Event function; its sign change from >0 to <=0 marks the event."""
    if which == EV_SLIP_END:
        return direction * (y[3] - y[1])
    if which == EV_PEAK:
        d = _derivatives_call(p, t, y[0], y[1], y[2], y[3], y[4], stuck, direction, peak)
        return direction * (d[3] - d[1])
    # breakaway: F_N*R*mu_s - |M_stick|
    ms = stick_moment(p, t, y[0], y[1], y[2])
    return p[P_FN] * p[P_R] * static_coefficient(p, t, t_stick) - abs(ms)


@njit(cache=True, error_model='numpy', fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'})
def _locate(
    p: np.ndarray,
    which: int,
    t: float,
    y: tuple[float, float, float, float, float],
    k1: tuple[float, float, float, float, float, float],
    h: float,
    g_a: float,
    g_b: float,
    stuck: bool,
    direction: float,
    peak: bool,
    t_stick: float,
) -> float:
    """Locate the event inside (0, h] by Illinois iteration on RK4 restarted from t.

    Returns the smallest tau found with g(tau) <= 0 (the crossing is completed there).
    """
    a = 0.0
    b = h
    fa = g_a
    fb = g_b
    if fa <= 0.0:
        return 0.0
    side = 0
    tol = EVENT_TOL * h
    for _ in range(_MAX_ITER):
        if b - a <= tol:
            break
        c = b - fb * (b - a) / (fb - fa)
        if not (c > a and c < b):
            c = 0.5 * (a + b)
        yc = _rk4(p, t, y[0], y[1], y[2], y[3], y[4], k1, c, stuck, direction, peak)
        fc = _event_value(p, which, t + c, yc, stuck, direction, peak, t_stick + c)
        if fc <= 0.0:
            b = c
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            a = c
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
    return b


@njit(cache=True, error_model='numpy', fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'})
def integrate(
    p: np.ndarray, s: np.ndarray, n_out: int, dt: float, n_sub: int, out: np.ndarray
) -> int:
    """Simulate ``n_out`` output samples of the rig; the kernel behind :func:`simulate`.

    Parameters
    ----------
    p : float64[NP] parameter vector (indices ``P_*``).
    s : float64[NS] state vector (indices ``S_*``), advanced in place to
        ``s[S_T] + n_out*dt``.
    n_out : number of output samples; sample i is the state at ``t_start + i*dt``.
    dt : output sample interval [s].
    n_sub : RK4 steps per output interval (>= 1; see :func:`substeps_for`).
    out : float64[N_CH, >= n_out] output channels (``OUT_*``).

    Returns the number of located stick/slip/peak events.
    """
    return integrate_logged(p, s, n_out, dt, n_sub, out, np.empty(0), np.empty(0, dtype=np.int64))


@njit(cache=True, error_model='numpy', fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'})
def integrate_logged(
    p: np.ndarray,
    s: np.ndarray,
    n_out: int,
    dt: float,
    n_sub: int,
    out: np.ndarray,
    ev_time: np.ndarray,
    ev_kind: np.ndarray,
) -> int:
    """:func:`integrate` that also logs the located events.

    ``ev_time[k]`` [s] and ``ev_kind[k]`` receive the k-th event (kinds: ``EV_SLIP_END``
    = slip ended and the discs stick, ``-EV_SLIP_END`` = slip ended and sliding
    reverses, ``EV_PEAK``, ``EV_BREAKAWAY``) while k < len(ev_time); the count is
    returned either way.
    """
    t_base = s[S_T]
    t = t_base
    y = (s[S_PHI1], s[S_W1], s[S_PHI2], s[S_W2], s[S_LAG])
    stuck = s[S_STUCK] > 0.5
    direction = 1.0 if s[S_DIR] >= 0.0 else -1.0
    peak = s[S_PEAK] > 0.5
    vmax = s[S_VMAX]
    t_stick = s[S_TSTICK]
    fnr = p[P_FN] * p[P_R]
    h = dt / n_sub
    n_events = 0
    if stuck:
        w = (p[P_I1] * y[1] + p[P_I2] * y[3]) / (p[P_I1] + p[P_I2])
        y = (y[0], w, y[2], w, y[4])
    k1 = _derivatives_call(p, t, y[0], y[1], y[2], y[3], y[4], stuck, direction, peak)
    for i in range(n_out):
        out[OUT_TORSION, i] = p[P_C1] * y[0]
        out[OUT_ACCEL, i] = k1[1]
        out[OUT_SPEED, i] = y[3]
        out[OUT_FRICTION, i] = k1[5]
        out[OUT_SLIP, i] = y[3] - y[1]
        out[OUT_STICK, i] = 1.0 if stuck else 0.0
        out[OUT_W1, i] = y[1]
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
                    lam = slip_rate(p, t, abs(y[3] - y[1]), peak)
                    if lam * hh > STEP_RATE:
                        hh = STEP_RATE / lam
                        t_step = t + hh
                y1 = _rk4(p, t, y[0], y[1], y[2], y[3], y[4], k1, hh, stuck, direction, peak)
                k1n = derivatives(
                    p, t_step, y1[0], y1[1], y1[2], y1[3], y1[4], stuck, direction, peak
                )
                ev = EV_NONE
                tau = hh
                if stuck:
                    ms = k1n[5]
                    g_b = fnr * static_coefficient(p, t_step, t_stick + hh) - abs(ms)
                    if g_b < 0.0:
                        g_a = fnr * static_coefficient(p, t, t_stick) - abs(k1[5])
                        tau = _locate(
                            p, EV_BREAKAWAY, t, y, k1, hh, g_a, g_b, stuck, direction, peak, t_stick
                        )
                        ev = EV_BREAKAWAY
                else:
                    g_b = direction * (y1[3] - y1[1])
                    if g_b < 0.0:
                        g_a = direction * (y[3] - y[1])
                        tau = _locate(
                            p, EV_SLIP_END, t, y, k1, hh, g_a, g_b, stuck, direction, peak, t_stick
                        )
                        ev = EV_SLIP_END
                    if not peak:
                        gp_b = direction * (k1n[3] - k1n[1])
                        gp_a = direction * (k1[3] - k1[1])
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
                        va = abs(y[3] - y[1])
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
                    y = _rk4(p, t, y[0], y[1], y[2], y[3], y[4], k1, tau, stuck, direction, peak)
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
                    i1 = p[P_I1]
                    i2 = p[P_I2]
                    w = (i1 * y[1] + i2 * y[3]) / (i1 + i2)
                    y = (y[0], w, y[2], w, y[4])
                    ms = stick_moment(p, t, y[0], w, y[2])
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
                    ms = stick_moment(p, t, y[0], y[1], y[2])
                    mus = static_coefficient(p, t, t_stick)
                    stuck = False
                    direction = 1.0 if ms >= 0.0 else -1.0
                    peak = False
                    vmax = 0.0
                    y = (y[0], y[1], y[2], y[3], mus)
                k1 = _derivatives_call(p, t, y[0], y[1], y[2], y[3], y[4], stuck, direction, peak)
    s[S_T] = t
    s[S_PHI1] = y[0]
    s[S_W1] = y[1]
    s[S_PHI2] = y[2]
    s[S_W2] = y[3]
    s[S_LAG] = y[4]
    s[S_STUCK] = 1.0 if stuck else 0.0
    s[S_DIR] = direction
    s[S_PEAK] = 1.0 if peak else 0.0
    s[S_VMAX] = vmax
    s[S_TSTICK] = t_stick
    return n_events


@njit(cache=True, error_model='numpy', fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'})
def drive_speed_array(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Vectorised :func:`drive_speed` [rad/s]."""
    out = np.empty(t.shape[0])
    for i in range(t.shape[0]):
        out[i] = drive_speed(p, t[i])
    return out


@njit(cache=True, error_model='numpy', fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'})
def drive_angle_array(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Vectorised :func:`drive_angle` [rad]."""
    out = np.empty(t.shape[0])
    for i in range(t.shape[0]):
        out[i] = drive_angle(p, t[i])
    return out


@njit(cache=True, error_model='numpy', fastmath={'contract', 'arcp', 'afn', 'reassoc', 'nsz'})
def friction_coefficient_array(
    p: np.ndarray, t: float, v_abs: np.ndarray, peak_passed: bool
) -> np.ndarray:
    """Vectorised :func:`friction_coefficient` at test time t [-]."""
    out = np.empty(v_abs.shape[0])
    for i in range(v_abs.shape[0]):
        out[i] = friction_coefficient(p, t, v_abs[i], peak_passed)
    return out


def substeps_for(p: np.ndarray, dt: float) -> int:
    """RK4 steps per output interval so that omega_max*h <= 0.1 and h <= lag_tau/2.

    omega_max is the largest undamped frequency (chamber, shaft, stuck system) or
    damping rate (K/I, bearing regularisation slope / I1) of the rig [rad/s].
    """
    i1, k1, c1, i2, k2, c2 = p[P_I1], p[P_K1], p[P_C1], p[P_I2], p[P_K2], p[P_C2]
    rates = [
        math.sqrt(c1 / i1),
        math.sqrt(c2 / i2),
        math.sqrt((c1 + c2) / (i1 + i2)),
        k1 / i1,
        k2 / i2,
    ]
    if p[P_BEARING] > 0.0 and p[P_BEARING_REG] > 0.0:
        rates.append(p[P_BEARING] / p[P_BEARING_REG] / i1 / 4.0)
    if p[P_VISC] > 0.0:
        rates.append(p[P_VISC] * (1.0 / i1 + 1.0 / i2))
    h_max = 0.1 / max(rates)
    if p[P_LAG_TAU] > 0.0:
        h_max = min(h_max, 0.5 * p[P_LAG_TAU])
    return max(1, math.ceil(dt / h_max - 1e-9))
