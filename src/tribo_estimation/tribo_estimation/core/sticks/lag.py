"""Torsion-amplifier lag of a record: estimate and exact compensation.

A first-order lag of the torsion amplifier (relative to the accelerometer) would
bend the stick lines of the detector; it is estimated from the record
(:func:`estimate_torsion_lag`, chamber kinematics ``M_t'' = C1*a``) or given, and
compensated exactly (:func:`torsion_lag_compensated`) before the stick residual is
formed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tribo_estimation.core.signal import rig_half, second_order_filter

FloatArray = NDArray[np.float64]


def chamber_speed_integral(accel: np.ndarray, dt: float) -> np.ndarray:
    """Return the trapezoid integral of the chamber acceleration [rad/s].

    From 0 at the first sample: the chamber speed w1 up to a constant (and a slow drift from an
    accelerometer offset), free of any speed-channel dynamics.
    """
    w = np.empty_like(accel)
    w[0] = 0.0
    np.cumsum(0.5 * (accel[1:] + accel[:-1]) * dt, out=w[1:])
    return w


#: Largest torsion-amplifier lag :func:`estimate_torsion_lag` considers [s], its grid
#: step [s] and the detrending window [s].
MAX_TORSION_LAG = 3e-3
_LAG_STEP = 1e-4
_LAG_WIN = 0.1


def kinematic_pair(
    torsion: FloatArray, accel: FloatArray, fs: float, c1: float, half: int
) -> tuple[FloatArray, FloatArray]:
    """Return the chamber kinematics ``M_t'' = C1*a`` as two sampled sides (Equ. 1, 4).

    ``D[n] = (M[n+h] - 2*M[n] + M[n-h])/(h*dt)^2/C1`` and the acceleration's
    triangle-weighted mean ``K[n] = sum_j (h - |j|)/h^2 * a_c[n+j]`` over the same
    +-h samples: the second difference of ``phi1`` is exactly the triangle-weighted
    integral of ``phi1''``, so ``D = K`` sample by sample with no integral carried
    across stick-slip cycles. Integrating a sampled acceleration over cycles instead
    adds the error of every switching jump (its instant falls between samples): at
    2 kHz a random walk of a sizeable part of the chamber speed.

    The sum stands for the integral through Numerov's correction
    ``a_c[n] = a[n] + (a[n+1] - 2*a[n] + a[n-1])/12``: at ``theta = 2*pi*f*dt``
    the plain sum (the trapezoid rule) weighs a component of frequency ``f`` by
    ``(theta/2)^2/sin(theta/2)^2 = 1 + theta^2/12`` against the second difference
    of the same band-limited signal, a gain error of 0.9 % at 105 Hz and 2 kHz;
    the correction leaves ``theta^4/90`` (1e-4 there).

    Parameters
    ----------
    torsion : FloatArray
        Torsion moment M_t [N m].
    accel : FloatArray
        Chamber acceleration [rad/s^2].
    fs : float
        Sample rate [Hz].
    c1 : float
        Torsion stiffness C1 [N m/rad].
    half : int
        h [samples] (>= 1).

    Returns
    -------
    tuple of FloatArray
        ``D`` and ``K`` [rad/s^2] at samples ``h .. n-h-1`` (empty for a short record).
    """
    h = max(1, int(half))
    m = np.asarray(torsion, dtype=np.float64)
    a = np.asarray(accel, dtype=np.float64)
    n = m.size
    if n <= 2 * h:
        return np.zeros(0), np.zeros(0)
    dt = 1.0 / fs
    d = (m[2 * h :] - 2.0 * m[h:-h] + m[: -2 * h]) / ((h * dt) ** 2 * c1)
    w = (h - np.abs(np.arange(-h, h + 1, dtype=np.float64))) / float(h * h)
    a_c = a.copy()  # the end samples have weight 0
    a_c[1:-1] += (a[2:] - 2.0 * a[1:-1] + a[:-2]) / 12.0
    k = np.convolve(a_c, w, mode='valid')
    return np.asarray(d, dtype=np.float64), np.asarray(k, dtype=np.float64)


def kinematic_half(fs: float, f_max: float) -> int:
    """Half width h [samples] of :func:`kinematic_pair`: a quarter period of ``f_max``.

    The widest span the rig's fastest mode ``f_max`` [Hz] allows
    (:func:`tribo_estimation.core.signal.rig_half`; the second difference's noise
    falls as h^-2), at least 1 and at most 0.1 s.
    """
    return rig_half(max(1, round(0.1 * fs)), fs, f_max, least=1)


def estimate_torsion_lag(
    torsion: np.ndarray,
    accel: np.ndarray,
    fs: float,
    c1: float,
    f_max: float,
    max_lag: float = MAX_TORSION_LAG,
    min_lag: float = 0.0,
) -> float:
    """First-order lag of the torsion channel relative to the accelerometer [s].

    Kinematics of the chamber (stick or slip): ``M_t'' = C1*a`` (Equ. 1, 4), seen as
    the pair ``D``, ``K`` of :func:`kinematic_pair` (h of :func:`kinematic_half`
    for the rig's fastest mode ``f_max`` [Hz]). A lag of the torsion channel
    lags ``D``: ``D = g*lag_tau(K) + b`` with ``g`` a gain ratio and ``b`` an
    accelerometer offset, both free per 0.1 s window; ``tau`` minimises the
    residual. A negative value (``min_lag`` < 0 allows it) is a lag of the
    accelerometer itself, ``a_meas = lag(a)``: then ``D = g*(K + |tau|*K') + b``
    (the inverse lag). Search on [``min_lag``, ``max_lag``]: a 0.5 ms grid, halving
    steps down to 0.1 ms, then a parabola. Within about 2 % (+-20 us) of lags up to
    2 ms at the noise of config/rig.yaml from 2 to 20 kHz.
    """
    return fit_torsion_lag(torsion, accel, fs, c1, f_max, max_lag, min_lag)[0]


#: Shapes ``q = a2/a1**2`` of a second-order torsion amplifier searched by
#: :func:`fit_torsion_lag` [-]: 0 is the first-order lag, 1 a damping ratio of 0.5
#: (``q = 1/(4*zeta**2)``; an amplifier's filter rings less: Bessel 0.87, Butterworth
#: 0.71, critically damped 1); a grid, refined by a parabola, not a threshold.
TORSION_LAG_SHAPES = (0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0)


def fit_torsion_lag(
    torsion: np.ndarray,
    accel: np.ndarray,
    fs: float,
    c1: float,
    f_max: float,
    max_lag: float = MAX_TORSION_LAG,
    min_lag: float = 0.0,
    shapes: tuple[float, ...] = (0.0,),
) -> tuple[float, float]:
    """Lag of the torsion channel relative to the accelerometer, first or second order.

    As :func:`estimate_torsion_lag`, with the torsion channel a second-order sensor
    ``a2*y'' + a1*y' + y = M_t`` of shape ``q = a2/a1**2``: ``a1`` is searched at
    every shape of ``shapes`` (0: first order), the least residual's shape refined by
    a parabola through its neighbours and ``a1`` searched again there. A negative
    lag (the accelerometer's) is first order.

    Parameters
    ----------
    torsion, accel : numpy.ndarray
        Torsion moment [N m] and chamber acceleration [rad/s^2].
    fs : float
        Sample rate [Hz].
    c1 : float
        Torsion stiffness [N m/rad].
    f_max : float
        The rig's fastest mode [Hz].
    max_lag, min_lag : float
        Range of ``a1`` [s] (below 0: the accelerometer's lag).
    shapes : tuple of float
        Shapes ``q`` to search [-] (ascending; :data:`TORSION_LAG_SHAPES`).

    Returns
    -------
    tuple of float
        ``a1`` [s] (NaN: too short a record) and ``q`` [-].
    """
    dt = 1.0 / fs
    d, k_a = kinematic_pair(np.asarray(torsion, float), np.asarray(accel, float), fs, c1,
                            kinematic_half(fs, f_max))  # fmt: skip
    n = d.size
    m = max(8, min(n, round(_LAG_WIN * fs)))
    nw = n // m
    if nw < 1:
        return float('nan'), 0.0
    k_slope = np.gradient(k_a, dt)

    def windows(x: np.ndarray) -> np.ndarray:
        xx = x[: nw * m].reshape(nw, m)
        return np.asarray(xx - xx.mean(axis=1, keepdims=True))

    y = windows(d)
    syy = float(np.sum(y * y))

    def rss(tau: float, q: float) -> float:
        if tau < 0.0:
            x = windows(k_a + (-tau) * k_slope)
        else:
            x = windows(second_order_filter(k_a, dt, tau, q * tau * tau))
        sxx = np.sum(x * x, axis=1)
        sxy = np.sum(x * y, axis=1)
        ok = sxx > 0.0
        return syy - float(np.sum(sxy[ok] ** 2 / sxx[ok]))

    cache: dict[tuple[float, float], float] = {}

    def f(tau: float, q: float) -> float:
        tau = min(max(round(tau, 9), min_lag), max_lag)
        key = (tau, 0.0 if tau <= 0.0 else q)
        if key not in cache:
            cache[key] = rss(*key)
        return cache[key]

    def search(q: float) -> tuple[float, float]:
        # coarse grid, then halving steps around the best point, then a parabola
        step = 5.0 * _LAG_STEP
        best = min(np.arange(min_lag, max_lag + 0.5 * step, step).tolist(), key=lambda t: f(t, q))
        while step > 1.01 * _LAG_STEP:
            step = max(_LAG_STEP, 0.5 * step)
            best = min((best - step, best, best + step), key=lambda t: f(t, q))
        best = min(max(round(best, 9), min_lag), max_lag)
        a, b, c = f(best - _LAG_STEP, q), f(best, q), f(best + _LAG_STEP, q)
        den = a - 2.0 * b + c
        if min_lag < best < max_lag and den > 0.0:
            best = best + 0.5 * (a - c) / den * _LAG_STEP
        return float(best), float(rss(best, q) if best > 0.0 else rss(best, 0.0))

    found = [search(q) for q in shapes]
    i = min(range(len(shapes)), key=lambda j: found[j][1])
    tau, q = found[i][0], shapes[i]
    if tau <= 0.0:
        return tau, 0.0
    if 0 < i < len(shapes) - 1:
        ra, rb, rc = found[i - 1][1], found[i][1], found[i + 1][1]
        den = ra - 2.0 * rb + rc
        h = shapes[i + 1] - shapes[i]
        if den > 0.0:
            q_v = shapes[i] + 0.5 * (ra - rc) / den * h
            t_v, r_v = search(q_v)
            if r_v < rb and t_v > 0.0:
                tau, q = t_v, q_v
    return float(tau), float(q)


def torsion_lag_compensated(
    torsion: np.ndarray,
    w: np.ndarray,
    dt: float,
    tau: float,
    c1: float,
    *,
    a2: float = 0.0,
    accel: np.ndarray | None = None,
) -> np.ndarray:
    """Torsion moment [N m] before a sensor lag of ``tau`` [s], up to a constant.

    With ``y = lag(M_t)``: ``M_t - y = tau*y' = tau*lag(M_t') = tau*C1*lag(w1)``
    (Equ. 1 kinematics, ``M_t' = C1*w1``), so ``M_t = y + tau*C1*lag(w)`` with ``w``
    the integrated acceleration (:func:`chamber_speed_integral`, the chamber speed
    up to a constant): exact, no differentiation of the noisy signal. The lag uses
    the first-order-hold discretisation (a zero-order hold's half-sample delay
    would move stick starts by ~0.5 ms at 10 rpm). A second-order sensor
    ``a2*y'' + tau*y' + y = M_t`` (``a2`` > 0 [s^2]) lags ``w`` by its own second
    order (:func:`~tribo_estimation.core.signal.second_order_filter`) and adds
    ``a2*y'' = a2*C1*lag(a)`` from ``accel``, the chamber acceleration [rad/s^2]
    (None: that term left to the caller).
    """
    out = torsion + tau * c1 * second_order_filter(w, dt, tau, a2)
    if a2 > 0.0 and accel is not None:
        out = out + a2 * c1 * second_order_filter(np.asarray(accel, float), dt, tau, a2)
    return np.asarray(out)
