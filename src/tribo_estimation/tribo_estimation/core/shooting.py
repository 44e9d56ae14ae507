"""The one multiple-shooting engine of the package.

States at segment starts come from the measured signals, and every segment is
integrated with the compiled kernel.

Used by the block fit (:mod:`.blockfit`) and the discrepancy fit
(:mod:`.discrepancy.fitting`).

**Drive.** The model is driven by the measured drive profile (:mod:`.drive`):
each linear piece ``w0(t) = w_j + rate_j*(t - t_j)`` goes to the kernel as
``P_W0``, ``P_W0_RATE``, ``P_T_DRIVE``, each raised-cosine piece (an S-shaped
transition from ``w_j`` to ``w_j+1``) as its mean speed, ``P_W0_COS`` and
``P_W0_OMEGA`` (the start-up ramp parameter is switched off); a segment crossing
a knot changes piece there.
The drive *angle* never comes from ``w0*t``: only the belt deflection
``phi2 - phi0`` enters Equ. 2, and it is reconstructed from the measured
state at the segment start.

**Stuck state** (Equ. 4, 6): ``w1 = w2 = w``; ``phi1 = M_t/C1`` and
``w = phi1' = (dM_t/dt)/C1`` from a local cubic through the torsion moment
``M_t`` (so neither the speed channel's lag nor its offset enters); the belt
deflection from the stuck system's moment balance with the measured
acceleration ``a``: ``Q1 = chamber moment (Equ. 1)``, ``Q2 = (I1 + I2)*a - Q1``,
``phi2 - phi0 = -(Q2 + K2*(w - w0))/C2`` (Equ. 2).

**Sliding state** (past the slip-speed peak): ``phi1``, ``w1`` as above;
``w2``, ``w2'`` from a local cubic through the shaft speed (corrected for the
speed sensor's first-order lag ``tau``: ``w2 = y + tau*y'``) and
``C2*(phi2 - phi0) = -M - I2*w2' - K2*(w2 - w0)`` (Equ. 2) with the friction
moment ``M`` of the observer.

Units: SI (N m, rad, rad/s, rad/s^2, s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numba import njit

from . import kernel as kn
from .drive import DriveEstimate
from .signal import (
    CHAMBER_HALF,
    lag2_segments,
    lag_segments,
    noise_level,
    running_integral,
    second_order_lag,
)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class DriveKnots:
    """Continuous drive speed through knots (constant beyond the ends; see :mod:`.drive`).

    Parameters
    ----------
    time : FloatArray
        Knot times [s], increasing.
    speed : FloatArray
        Drive speed at the knots [rad/s].
    shape : FloatArray
        Per knot, the shape of the piece it begins: 0 linear, 1 raised cosine
        (:data:`tribo_estimation.core.drive.COSINE`) [-].
    """

    time: FloatArray
    speed: FloatArray
    shape: FloatArray

    @staticmethod
    def from_estimate(drive: DriveEstimate) -> DriveKnots:
        """Return the knots of a measured drive profile.

        Parameters
        ----------
        drive : DriveEstimate
            The measured profile.

        Returns
        -------
        DriveKnots
            Its knots as contiguous arrays.
        """
        return DriveKnots(
            np.ascontiguousarray(drive.knot_time, dtype=np.float64),
            np.ascontiguousarray(drive.knot_speed, dtype=np.float64),
            np.ascontiguousarray(drive.shapes(), dtype=np.float64),
        )

    @staticmethod
    def constant(w0: float, t0: float = 0.0, t1: float = 1.0) -> DriveKnots:
        """Return a constant drive speed.

        Parameters
        ----------
        w0 : float
            Drive speed [rad/s].
        t0, t1 : float
            First and last knot time [s].

        Returns
        -------
        DriveKnots
            Two knots at the same speed.
        """
        return DriveKnots(
            np.array([t0, max(t1, t0 + 1e-9)]), np.array([w0, w0], dtype=float), np.zeros(2)
        )


@njit(cache=True, nogil=True)
def _piece(tk: np.ndarray, vk: np.ndarray, t: float) -> int:
    """Index j of the drive piece [tk[j], tk[j+1]) holding t (-1 before, K-1 after)."""
    k = tk.shape[0]
    if t < tk[0]:
        return -1
    j = 0
    while j < k - 1 and t >= tk[j + 1]:
        j += 1
    return j


@njit(cache=True, nogil=True)
def _piece_params(
    p: np.ndarray, tk: np.ndarray, vk: np.ndarray, sk: np.ndarray, j: int
) -> np.ndarray:
    """Kernel parameters driven by piece j.

    Linear: ``w0 = vk[j] + rate*(t - tk[j])``; raised cosine (``sk[j]`` = 1):
    ``w0 = vk[j] + (vk[j+1] - vk[j])*(1 - cos(pi*(t - tk[j])/h))/2``, ``h`` its length.
    """
    q = p.copy()
    q[kn.P_RAMP] = 0.0
    q[kn.P_W0_COS] = 0.0
    k = tk.shape[0]
    if j < 0:
        q[kn.P_W0] = vk[0]
        q[kn.P_W0_RATE] = 0.0
        q[kn.P_T_DRIVE] = tk[0]
    elif j >= k - 1:
        q[kn.P_W0] = vk[k - 1]
        q[kn.P_W0_RATE] = 0.0
        q[kn.P_T_DRIVE] = tk[k - 1]
    elif sk[j] > 0.5:
        half = 0.5 * (vk[j + 1] - vk[j])
        q[kn.P_W0] = vk[j] + half
        q[kn.P_W0_RATE] = 0.0
        q[kn.P_T_DRIVE] = tk[j]
        q[kn.P_W0_COS] = -half
        q[kn.P_W0_OMEGA] = math.pi / max(tk[j + 1] - tk[j], 1e-12)
    else:
        q[kn.P_W0] = vk[j]
        q[kn.P_W0_RATE] = (vk[j + 1] - vk[j]) / max(tk[j + 1] - tk[j], 1e-12)
        q[kn.P_T_DRIVE] = tk[j]
    if q[kn.P_RIPA_REL] != 0.0 or q[kn.P_RIPA2_REL] != 0.0:
        # the drive angle from the first knot at the piece's reference time (a raised
        # cosine's mean speed is its ends' mean, as a line's), less the piece's own
        theta = 0.0
        for i in range(min(max(j, 0), k - 1)):
            theta += 0.5 * (vk[i] + vk[i + 1]) * (tk[i + 1] - tk[i])
        q[kn.P_RIPA_ANGLE0] = theta - kn.piece_angle(q, q[kn.P_T_DRIVE])
    return q


@njit(cache=True, nogil=True)
def shoot(
    p: np.ndarray,
    states: np.ndarray,
    starts: np.ndarray,
    stops: np.ndarray,
    tk: np.ndarray,
    vk: np.ndarray,
    sk: np.ndarray,
    dt: float,
    n_sub: int,
    out: np.ndarray,
) -> int:
    """Integrate every segment from its start state with the kernel.

    The kernel is :func:`kernel.integrate` (Equ. 1-3, 6, 8), driven by the
    piecewise-linear drive; at a knot inside a segment the drive piece changes
    at the first sample at or after it (the state's time is taken as the knot's
    when it is one up to rounding) and the shaft angle is shifted so that the
    belt deflection ``phi2 - phi0`` (Equ. 2) stays continuous.

    Parameters
    ----------
    p : numpy.ndarray
        Packed kernel parameters.
    states : numpy.ndarray
        Kernel state per segment (``kernel.S_*``), not modified.
    starts, stops : numpy.ndarray
        First and stop (exclusive) sample of each segment.
    tk, vk, sk : numpy.ndarray
        Drive knot times [s], speeds [rad/s] and piece shapes (:class:`DriveKnots`).
    dt : float
        Sample interval [s].
    n_sub : int
        RK4 steps per sample.
    out : numpy.ndarray
        Output channels (``kernel.N_CH`` x record length), written per segment.

    Returns
    -------
    int
        Number of switching events.
    """
    max_len = 1
    for k in range(starts.shape[0]):
        max_len = max(max_len, stops[k] - starts[k])
    buf = np.empty((kn.N_CH, max_len))
    n_ev = 0
    for k in range(starts.shape[0]):
        s = states[k].copy()
        n_ev += shoot_on(p, s, starts[k], stops[k], tk, vk, sk, dt, n_sub, out, buf)
    return n_ev


@njit(cache=True, nogil=True)
def shoot_on(
    p: np.ndarray,
    s: np.ndarray,
    start: int,
    stop: int,
    tk: np.ndarray,
    vk: np.ndarray,
    sk: np.ndarray,
    dt: float,
    n_sub: int,
    out: np.ndarray,
    buf: np.ndarray,
) -> int:
    """Integrate one stretch from state ``s`` (advanced in place) over ``start:stop``.

    The body of :func:`shoot` for one segment: a caller that changes the parameters
    between stretches (friction levels that change with test time) carries the state
    from one to the next.

    Parameters
    ----------
    p : numpy.ndarray
        Packed kernel parameters.
    s : numpy.ndarray
        Kernel state at ``start`` (``kernel.S_*``); the state at ``stop`` on return.
    start, stop : int
        First and stop (exclusive) sample.
    tk, vk, sk : numpy.ndarray
        Drive knot times [s], speeds [rad/s] and piece shapes (:class:`DriveKnots`).
    dt : float
        Sample interval [s].
    n_sub : int
        RK4 steps per sample.
    out : numpy.ndarray
        Output channels (``kernel.N_CH`` x record length).
    buf : numpy.ndarray
        Work space (``kernel.N_CH`` x at least ``stop - start``).

    Returns
    -------
    int
        Number of switching events.
    """
    n_left = stop - start
    if n_left <= 0:
        return 0
    n_ev = 0
    nk = tk.shape[0]
    pos = start
    j = _piece(tk, vk, s[kn.S_T])
    while n_left > 0:
        q = _piece_params(p, tk, vk, sk, j)
        # samples until the next knot (the piece changes at the first sample after it)
        n = n_left
        t_next = math.inf
        if j < nk - 1:
            t_next = tk[j + 1] if j >= 0 else tk[0]
            m = math.ceil((t_next - s[kn.S_T]) / dt - 1e-9)
            if 1 <= m < n:
                n = m
        n_ev += kn.integrate(q, s, n, dt, n_sub, buf)
        for c in range(kn.N_CH):
            for i in range(n):
                out[c, pos + i] = buf[c, i]
        pos += n
        n_left -= n
        if n_left > 0:
            # the state's time is the knot's up to rounding (a knot on a sample
            # instant, e.g. the start-up ramp's end): it belongs to the new piece
            j_new = _piece(tk, vk, max(s[kn.S_T], t_next if t_next < math.inf else -math.inf))
            if j_new != j:
                q_new = _piece_params(p, tk, vk, sk, j_new)
                t = s[kn.S_T]
                s[kn.S_PHI2] += kn.drive_angle(q_new, t) - kn.drive_angle(q, t)
                j = j_new
    return n_ev


@njit(cache=True, nogil=True)
def stuck_states(
    p: np.ndarray,
    t: np.ndarray,
    torsion: np.ndarray,
    w: np.ndarray,
    accel: np.ndarray,
    t_stick: np.ndarray,
    tk: np.ndarray,
    vk: np.ndarray,
    sk: np.ndarray,
) -> np.ndarray:
    """Return the kernel states of stuck discs (module doc; the kernel's own Q1, Q2).

    Parameters
    ----------
    p : numpy.ndarray
        Packed kernel parameters.
    t : numpy.ndarray
        Times [s].
    torsion : numpy.ndarray
        True torsion moment C1*phi1 [N m].
    w : numpy.ndarray
        Common speed of the discs [rad/s].
    accel : numpy.ndarray
        Their acceleration [rad/s^2].
    t_stick : numpy.ndarray
        Time already stuck [s].
    tk, vk, sk : numpy.ndarray
        Drive knot times [s], speeds [rad/s] and piece shapes (:class:`DriveKnots`).

    Returns
    -------
    numpy.ndarray
        States (``kernel.S_*``), one row per time.
    """
    m = t.shape[0]
    out = np.zeros((m, kn.NS))
    for k in range(m):
        q = _piece_params(p, tk, vk, sk, _piece(tk, vk, t[k]))
        phi1 = torsion[k] / q[kn.P_C1]
        q1 = kn.chamber_moment(q, phi1, w[k])
        phi0 = kn.drive_angle(q, t[k])
        qa = kn.shaft_moment(q, t[k], phi0, w[k])
        target = (q[kn.P_I1] + q[kn.P_I2]) * accel[k] - q1
        # Q2 is affine in phi2 with slope -C2
        phi2 = phi0 - (target - qa) / q[kn.P_C2]
        out[k, kn.S_T] = t[k]
        out[k, kn.S_PHI1] = phi1
        out[k, kn.S_W1] = w[k]
        out[k, kn.S_PHI2] = phi2
        out[k, kn.S_W2] = w[k]
        out[k, kn.S_LAG] = q[kn.P_MU0]
        out[k, kn.S_STUCK] = 1.0
        out[k, kn.S_DIR] = 1.0
        out[k, kn.S_TSTICK] = t_stick[k]
        out[k, kn.S_SENSOR] = math.nan
    return out


#: Fewest window samples of :func:`stuck_states_averaged` that replace the one-sample
#: belt deflection [-].
_MIN_WINDOW = 8


@njit(cache=True, nogil=True)
def stuck_states_averaged(
    p: np.ndarray,
    t: np.ndarray,
    torsion: np.ndarray,
    w: np.ndarray,
    accel: np.ndarray,
    t_stick: np.ndarray,
    tk: np.ndarray,
    vk: np.ndarray,
    sk: np.ndarray,
    win_tau: np.ndarray,
    win_a: np.ndarray,
    win_a1: np.ndarray,
    win_a2: np.ndarray,
    win_n: np.ndarray,
) -> np.ndarray:
    """Return the stuck states of :func:`stuck_states`, the belt deflection averaged.

    :func:`stuck_states` takes the shaft angle from the stuck balance at one instant,
    ``(I1 + I2)*a = Q1 + Q2`` (Equ. 1 + 2), so the accelerometer's noise at that
    instant enters the belt deflection as ``(I1 + I2)*da/C2`` and makes the simulated
    stick drift off (a force error of 0.1 N m bends the torsion moment by
    ``C1*t^2/2*0.1/(I1 + I2)``). While stuck, the discs' angles follow from the state
    at the start and the measured acceleration: ``w(t) = w + A1``,
    ``phi1(t) = phi1 + w*tau + A2``, ``phi2(t) = phi2 + w*tau + A2`` (``A1``, ``A2``
    the single and double integrals of ``a`` from the start, ``tau = t - t_start``).
    The balance at every window sample in the start's drive piece then gives one
    estimate of ``phi2``; their mean is used (the noise drops by the square root of
    their number). An error ``dw`` of the start speed moves the estimate from a sample
    at ``tau`` by ``-dw*tau*(1 + C1/C2)``: the window is centred on the start
    (:func:`stuck_windows`), where these cancel.

    Parameters
    ----------
    p, t, torsion, w, accel, t_stick, tk, vk, sk : numpy.ndarray
        As :func:`stuck_states`.
    win_tau : numpy.ndarray
        Shape (m, W): times of the window samples relative to each start [s].
    win_a : numpy.ndarray
        Shape (m, W): their measured acceleration [rad/s^2].
    win_a1, win_a2 : numpy.ndarray
        Shape (m, W): single [rad/s] and double [rad] integrals of it from the start.
    win_n : numpy.ndarray
        Valid window samples of each start (the first ``win_n[k]`` of row k) [-].

    Returns
    -------
    numpy.ndarray
        States (``kernel.S_*``), one row per time.
    """
    out = stuck_states(p, t, torsion, w, accel, t_stick, tk, vk, sk)
    for k in range(t.shape[0]):
        if win_n[k] < _MIN_WINDOW:
            continue
        j0 = _piece(tk, vk, t[k])
        q = _piece_params(p, tk, vk, sk, j0)
        c1 = q[kn.P_C1]
        inertia = q[kn.P_I1] + q[kn.P_I2]
        phi1 = torsion[k] / c1
        total = 0.0
        used = 0
        for j in range(win_n[k]):
            tj = t[k] + win_tau[k, j]
            if _piece(tk, vk, tj) != j0:  # the drive angle is relative to its piece
                continue
            swept = w[k] * win_tau[k, j] + win_a2[k, j]
            wj = w[k] + win_a1[k, j]
            q1 = kn.chamber_moment(q, phi1 + swept, wj)
            phi0 = kn.drive_angle(q, tj)
            qa = kn.shaft_moment(q, tj, phi0, wj)
            total += phi0 - (inertia * win_a[k, j] - q1 - qa) / q[kn.P_C2] - swept
            used += 1
        if used >= _MIN_WINDOW:
            out[k, kn.S_PHI2] = total / used
    return out


@njit(cache=True, nogil=True)
def sliding_states(
    p: np.ndarray,
    t: np.ndarray,
    torsion: np.ndarray,
    w1: np.ndarray,
    w2: np.ndarray,
    w2_dot: np.ndarray,
    moment: np.ndarray,
    tk: np.ndarray,
    vk: np.ndarray,
    sk: np.ndarray,
) -> np.ndarray:
    """Return the kernel states while sliding past the slip-speed peak (module doc).

    Parameters
    ----------
    p : numpy.ndarray
        Packed kernel parameters.
    t : numpy.ndarray
        Times [s].
    torsion : numpy.ndarray
        True torsion moment C1*phi1 [N m].
    w1, w2 : numpy.ndarray
        Chamber and shaft speed [rad/s].
    w2_dot : numpy.ndarray
        Shaft acceleration [rad/s^2].
    moment : numpy.ndarray
        Friction moment M [N m].
    tk, vk, sk : numpy.ndarray
        Drive knot times [s], speeds [rad/s] and piece shapes (:class:`DriveKnots`).

    Returns
    -------
    numpy.ndarray
        States (``kernel.S_*``), one row per time.
    """
    m = t.shape[0]
    out = np.zeros((m, kn.NS))
    for k in range(m):
        q = _piece_params(p, tk, vk, sk, _piece(tk, vk, t[k]))
        phi0 = kn.drive_angle(q, t[k])
        w0t = kn.drive_speed(q, t[k])
        out[k, kn.S_T] = t[k]
        out[k, kn.S_PHI1] = torsion[k] / q[kn.P_C1]
        out[k, kn.S_W1] = w1[k]
        out[k, kn.S_W2] = w2[k]
        out[k, kn.S_PHI2] = (
            phi0 - (moment[k] + q[kn.P_I2] * w2_dot[k] + q[kn.P_K2] * (w2[k] - w0t)) / q[kn.P_C2]
        )
        v = w2[k] - w1[k]
        out[k, kn.S_DIR] = 1.0 if v >= 0.0 else -1.0
        out[k, kn.S_PEAK] = 1.0
        out[k, kn.S_VMAX] = abs(v)
        out[k, kn.S_LAG] = q[kn.P_MUINF]
        out[k, kn.S_SENSOR] = math.nan
    return out


# ------------------------------------------------------------- local polynomials
def _cubic_rows(lo_off: int, hi_off: int) -> FloatArray:
    """Return the rows (value, slope per sample) of the least-squares cubic.

    Parameters
    ----------
    lo_off, hi_off : int
        The cubic runs through the offsets ``lo_off .. hi_off - 1`` [samples].

    Returns
    -------
    FloatArray
        Two rows applied to the window's samples.
    """
    x = np.arange(lo_off, hi_off, dtype=float)
    A = np.vstack((np.ones_like(x), x, x * x, x * x * x)).T
    return np.asarray(np.linalg.pinv(A)[:2], dtype=np.float64)


_SYM_ROWS = _cubic_rows(-CHAMBER_HALF, CHAMBER_HALF + 1)


def local_cubic(
    y: FloatArray, idx: IntArray, lo: IntArray | None = None, hi: IntArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Return value and slope per sample of a local cubic through ``y`` at ``idx``.

    The cubic runs over +-7 samples, limited to ``[lo, hi)`` per index (e.g. one
    stick phase).

    Parameters
    ----------
    y : FloatArray
        The signal [unit].
    idx : IntArray
        Samples where the cubic is evaluated.
    lo, hi : IntArray, optional
        First and stop (exclusive) sample allowed per index.

    Returns
    -------
    tuple of FloatArray
        Value [unit] and slope [unit per sample]; a window of fewer than 6
        samples gives the sample value and a NaN slope.
    """
    n = y.shape[0]
    j = np.asarray(idx, dtype=np.int64)
    lo_a = np.zeros(j.size, np.int64) if lo is None else np.asarray(lo, dtype=np.int64)
    hi_a = np.full(j.size, n, np.int64) if hi is None else np.asarray(hi, dtype=np.int64)
    a = np.maximum(lo_a, j - CHAMBER_HALF)
    b = np.minimum(hi_a, j + CHAMBER_HALF + 1)
    val = np.empty(j.size)
    slope = np.empty(j.size)
    sym = (a == j - CHAMBER_HALF) & (b == j + CHAMBER_HALF + 1)
    if sym.any():
        win = j[sym][:, None] + np.arange(-CHAMBER_HALF, CHAMBER_HALF + 1)[None, :]
        seg = y[win]
        val[sym] = seg @ _SYM_ROWS[0]
        slope[sym] = seg @ _SYM_ROWS[1]
    for i in np.flatnonzero(~sym).tolist():
        jj, aa, bb = int(j[i]), int(a[i]), int(b[i])
        if bb - aa < 6:
            val[i], slope[i] = float(y[jj]), math.nan
            continue
        c = _cubic_rows(aa - jj, bb - jj) @ y[aa:bb]
        val[i], slope[i] = float(c[0]), float(c[1])
    return val, slope


def window_mean(
    y: FloatArray, idx: IntArray, half: int, lo: IntArray | None = None, hi: IntArray | None = None
) -> FloatArray:
    """Return the mean of ``y`` over +-``half`` samples around ``idx``.

    Parameters
    ----------
    y : FloatArray
        The signal [unit].
    idx : IntArray
        Centre samples.
    half : int
        Half width [samples].
    lo, hi : IntArray, optional
        First and stop (exclusive) sample allowed per index.

    Returns
    -------
    FloatArray
        The window means [unit].
    """
    n = y.shape[0]
    j = np.asarray(idx, dtype=np.int64)
    lo_a = np.zeros(j.size, np.int64) if lo is None else np.asarray(lo, dtype=np.int64)
    hi_a = np.full(j.size, n, np.int64) if hi is None else np.asarray(hi, dtype=np.int64)
    c = np.concatenate(([0.0], np.cumsum(y)))
    a = np.maximum(lo_a, j - half)
    b = np.maximum(np.minimum(hi_a, j + half + 1), a + 1)
    return np.asarray((c[b] - c[a]) / (b - a), dtype=np.float64)


#: Half width of the stick-phase regression of :func:`stuck_kinematics` [samples].
STUCK_HALF = 60


def _integrals(
    accel: FloatArray, a_lo: int, a_hi: int, i: int, dt: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return ``tau``, ``a``, ``A1`` and ``A2`` over ``[a_lo, a_hi)`` from sample ``i``.

    Times relative to sample ``i`` [s], the acceleration [rad/s^2] and its single
    [rad/s] and double [rad] trapezoid integrals from ``i``.
    """
    a = accel[a_lo:a_hi]
    a1 = running_integral(a, dt)
    a1 -= a1[i - a_lo]
    a2 = running_integral(a1, dt)
    a2 -= a2[i - a_lo]
    tau = np.asarray((np.arange(a_lo, a_hi) - i) * dt, dtype=np.float64)
    return tau, np.asarray(a, dtype=np.float64), a1, a2


def stuck_windows(
    accel: FloatArray,
    idx: IntArray,
    lo: IntArray,
    hi: IntArray,
    dt: float,
    half: int = STUCK_HALF,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, IntArray]:
    """Return the stick-phase windows of :func:`stuck_states_averaged`.

    Parameters
    ----------
    accel : FloatArray
        Angular acceleration [rad/s^2].
    idx : IntArray
        The start samples.
    lo, hi : IntArray
        First and stop (exclusive) sample of the stick phase holding each start
        (``hi <= lo``: none, an empty window).
    dt : float
        Sample interval [s].
    half : int
        Half width of the window [samples].

    Returns
    -------
    tuple
        ``tau`` [s], ``a`` [rad/s^2], ``A1`` [rad/s], ``A2`` [rad], each of shape
        ``(idx.size, 2*half + 1)``, and the valid samples per row [-]: the window is
        centred on the start, as wide as the phase allows on both sides.
    """
    m, width = idx.shape[0], 2 * half + 1
    tau, acc, a1, a2 = (np.zeros((m, width)) for _ in range(4))
    n = np.zeros(m, dtype=np.int64)
    for k in range(m):
        i = int(idx[k])
        # centred on the start: the shaft angle's estimate from a window sample moves
        # with the start speed's error times the sample's time from the start, which
        # a symmetric window averages out
        h = min(half, i - int(lo[k]), int(hi[k]) - 1 - i)
        if h < 1:
            continue
        a_lo, a_hi = i - h, i + h + 1
        size = a_hi - a_lo
        tau[k, :size], acc[k, :size], a1[k, :size], a2[k, :size] = _integrals(
            accel, a_lo, a_hi, i, dt
        )
        n[k] = size
    return tau, acc, a1, a2, n


@njit(cache=True, nogil=True)
def torsion_smoother(
    torsion: np.ndarray, accel: np.ndarray, dt: float, c1: float, var_m: float, var_a: float
) -> tuple[np.ndarray, np.ndarray]:
    """Return the torsion moment and its rate by a Kalman smoother of the chamber kinematics.

    Stick or slip, ``M_t = C1*phi1`` and ``phi1'' = a`` (Equ. 1, 4): the state
    ``(M, v = M')`` advances from sample to sample by the trapezoid integrals of
    the measured acceleration, ``v += C1*h*(a[k-1] + a[k])/2``,
    ``M += h*v + C1*h^2*(a[k-1] + a[k])/4`` (those of :func:`stuck_kinematics`'s
    regression), with the accelerometer's white noise (variance ``var_a``) as the
    process noise, a random walk of ``v`` of variance ``(C1*h)^2*var_a`` per step;
    the torsion channel measures ``M`` with white noise of variance ``var_m``. The
    forward filter (diffuse start) and the Rauch-Tung-Striebel backward pass give
    the least-squares state at every sample from the whole stretch: the measured
    acceleration is trusted over a few samples, the torsion channel's mean over many,
    in the ratio of their noises (a regression on ``M - C1*A2`` trusts the double
    integral ``A2`` over the whole window: at 2 kHz its random walk exceeds the
    torsion channel's noise within 30 ms).

    Parameters
    ----------
    torsion : numpy.ndarray
        Torsion moment [N m] over a stretch.
    accel : numpy.ndarray
        Chamber acceleration [rad/s^2] over the same samples.
    dt : float
        Sample interval [s].
    c1 : float
        Measuring-spring stiffness C1 [N m/rad].
    var_m : float
        Variance of the torsion channel's white noise [(N m)^2], > 0.
    var_a : float
        Variance of the accelerometer's white noise [(rad/s^2)^2], >= 0.

    Returns
    -------
    tuple of numpy.ndarray
        The smoothed torsion moment [N m] and its rate [N m/s] per sample.
    """
    n = torsion.shape[0]
    xm = np.empty(n)
    xv = np.empty(n)
    # filtered (f) and predicted (p) means and covariances (p00, p01, p11)
    fm, fv = np.empty(n), np.empty(n)
    f00, f01, f11 = np.empty(n), np.empty(n), np.empty(n)
    pm, pv = np.empty(n), np.empty(n)
    p00, p01, p11 = np.empty(n), np.empty(n), np.empty(n)
    q = (c1 * dt) ** 2 * var_a
    big = 1e6 * (var_m + (c1 * dt) ** 2 * var_a)
    m, v = torsion[0], 0.0
    c00, c01, c11 = big, 0.0, big / (dt * dt)
    for k in range(n):
        if k > 0:
            s = accel[k - 1] + accel[k]
            m = m + dt * v + c1 * dt * dt * s / 4.0
            v = v + c1 * dt * s / 2.0
            c00, c01, c11 = (
                c00 + 2.0 * dt * c01 + dt * dt * c11 + q * dt * dt / 4.0,
                c01 + dt * c11 + q * dt / 2.0,
                c11 + q,
            )
        pm[k], pv[k], p00[k], p01[k], p11[k] = m, v, c00, c01, c11
        s_inn = c00 + var_m
        g0, g1 = c00 / s_inn, c01 / s_inn
        r = torsion[k] - m
        m, v = m + g0 * r, v + g1 * r
        c00, c01, c11 = c00 - g0 * c00, c01 - g0 * c01, c11 - g1 * c01
        fm[k], fv[k], f00[k], f01[k], f11[k] = m, v, c00, c01, c11
    xm[n - 1], xv[n - 1] = fm[n - 1], fv[n - 1]
    for k in range(n - 2, -1, -1):
        # gain C = Pf F' Pp^-1 (F = [[1, h], [0, 1]])
        a00 = f00[k] + dt * f01[k]
        a01 = f01[k]
        a10 = f01[k] + dt * f11[k]
        a11 = f11[k]
        det = p00[k + 1] * p11[k + 1] - p01[k + 1] * p01[k + 1]
        i00, i01, i11 = p11[k + 1] / det, -p01[k + 1] / det, p00[k + 1] / det
        dm, dv = xm[k + 1] - pm[k + 1], xv[k + 1] - pv[k + 1]
        xm[k] = fm[k] + (a00 * i00 + a01 * i01) * dm + (a00 * i01 + a01 * i11) * dv
        xv[k] = fv[k] + (a10 * i00 + a11 * i01) * dm + (a10 * i01 + a11 * i11) * dv
    return xm, xv


def stuck_kinematics(
    torsion: FloatArray,
    accel: FloatArray,
    speed: FloatArray,
    idx: IntArray,
    lo: IntArray,
    hi: IntArray,
    dt: float,
    c1: float,
    half: int = STUCK_HALF,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Estimate the torsion moment, its slope and the common speed at stick samples.

    While the discs stick, ``M_t = C1*phi1`` with ``phi1' = w`` and ``w' = a``
    (Equ. 4, the chamber kinematics). The torsion moment and its slope ``C1*w``
    come from :func:`torsion_smoother` over the stick phase (the white noise of
    both channels from :func:`.signal.noise_level`; a noise-free torsion channel
    leaves the measured value). Relative to a sample ``i`` the speed channel
    (without lag) shows ``y(t) = w_i + A1(t)``, ``A1`` the trapezoid integral of
    the measured acceleration ``a`` from ``t_i``: the mean of ``y - A1`` within
    ``+-half`` samples gives ``w_i``.

    Parameters
    ----------
    torsion : FloatArray
        Torsion moment [N m] (amplifier lag already compensated).
    accel : FloatArray
        Angular acceleration [rad/s^2].
    speed : FloatArray
        Shaft speed channel [rad/s].
    idx : IntArray
        Samples inside stick phases where the state is wanted.
    lo, hi : IntArray
        First and stop (exclusive) sample of the stick phase holding each index.
    dt : float
        Sample interval [s].
    c1 : float
        Measuring-spring stiffness C1 [N m/rad].
    half : int
        Half width of the speed channel's window [samples].

    Returns
    -------
    tuple of FloatArray
        Torsion moment at each index [N m], its slope [N m/s] and the common
        speed from the speed channel [rad/s]; NaN where the phase holds fewer
        than 8 samples around the index.
    """
    m = idx.shape[0]
    val = np.full(m, math.nan)
    slope = np.full(m, math.nan)
    w = np.full(m, math.nan)
    var_m = noise_level(torsion) ** 2
    var_a = noise_level(accel) ** 2
    if not math.isfinite(var_a):
        var_a = 0.0
    smoothed: dict[tuple[int, int], tuple[FloatArray, FloatArray]] = {}
    for k in range(m):
        i = int(idx[k])
        a_lo = max(int(lo[k]), i - half)
        a_hi = min(int(hi[k]), i + half + 1)
        if a_hi - a_lo < 8 or not a_lo <= i < a_hi:
            continue
        _, _, a1, _ = _integrals(accel, a_lo, a_hi, i, dt)
        w[k] = float(np.mean(speed[a_lo:a_hi] - a1))
        if not var_m > 0.0:
            val[k], slope[k] = float(torsion[i]), c1 * w[k]
            continue
        phase = (int(lo[k]), int(hi[k]))
        if phase not in smoothed:
            smoothed[phase] = torsion_smoother(
                np.ascontiguousarray(torsion[phase[0] : phase[1]]),
                np.ascontiguousarray(accel[phase[0] : phase[1]]),
                dt, c1, var_m, var_a,
            )  # fmt: skip
        xm, xv = smoothed[phase]
        val[k] = float(xm[i - phase[0]])
        slope[k] = float(xv[i - phase[0]])
    return val, slope, w


__all__ = [
    'STUCK_HALF',
    'DriveKnots',
    'lag2_segments',
    'lag_segments',
    'local_cubic',
    'second_order_lag',
    'shoot',
    'shoot_on',
    'sliding_states',
    'stuck_kinematics',
    'stuck_states',
    'stuck_states_averaged',
    'stuck_windows',
    'torsion_smoother',
    'window_mean',
]
