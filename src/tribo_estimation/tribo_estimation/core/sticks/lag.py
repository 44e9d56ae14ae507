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

from tribo_estimation.core.signal import first_order_lag, rig_half

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
    triangle-weighted mean ``K[n] = sum_j (h - |j|)/h^2 * a[n+j]`` over the same
    +-h samples: the second difference of ``phi1`` is exactly the triangle-weighted
    integral of ``phi1''``, so ``D = K`` sample by sample (trapezoid rule) with no
    integral carried across stick-slip cycles. Integrating a sampled acceleration
    over cycles instead adds the error of every switching jump (its instant falls
    between samples): at 2 kHz a random walk of a sizeable part of the chamber speed.

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
    k = np.convolve(a, w, mode='valid')
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
    dt = 1.0 / fs
    d, k_a = kinematic_pair(np.asarray(torsion, float), np.asarray(accel, float), fs, c1,
                            kinematic_half(fs, f_max))  # fmt: skip
    n = d.size
    m = max(8, min(n, round(_LAG_WIN * fs)))
    nw = n // m
    if nw < 1:
        return float('nan')
    k_slope = np.gradient(k_a, dt)

    def windows(x: np.ndarray) -> np.ndarray:
        xx = x[: nw * m].reshape(nw, m)
        return np.asarray(xx - xx.mean(axis=1, keepdims=True))

    y = windows(d)
    syy = float(np.sum(y * y))

    def rss(tau: float) -> float:
        x = windows(k_a + (-tau) * k_slope if tau < 0.0 else first_order_lag(k_a, dt, tau))
        sxx = np.sum(x * x, axis=1)
        sxy = np.sum(x * y, axis=1)
        ok = sxx > 0.0
        return syy - float(np.sum(sxy[ok] ** 2 / sxx[ok]))

    cache: dict[float, float] = {}

    def f(tau: float) -> float:
        tau = min(max(round(tau, 9), min_lag), max_lag)
        if tau not in cache:
            cache[tau] = rss(tau)
        return cache[tau]

    # coarse grid, then halving steps around the best point, then a parabola
    step = 5.0 * _LAG_STEP
    best = min(np.arange(min_lag, max_lag + 0.5 * step, step).tolist(), key=f)
    while step > 1.01 * _LAG_STEP:
        step = max(_LAG_STEP, 0.5 * step)
        best = min((best - step, best, best + step), key=f)
    best = min(max(round(best, 9), min_lag), max_lag)
    a, b, c = f(best - _LAG_STEP), f(best), f(best + _LAG_STEP)
    den = a - 2.0 * b + c
    if min_lag < best < max_lag and den > 0.0:
        return float(best + 0.5 * (a - c) / den * _LAG_STEP)
    return float(best)


def torsion_lag_compensated(
    torsion: np.ndarray, w: np.ndarray, dt: float, tau: float, c1: float
) -> np.ndarray:
    """Torsion moment [N m] before a first-order sensor lag of ``tau`` [s], up to a constant.

    With ``y = lag(M_t)``: ``M_t - y = tau*y' = tau*lag(M_t') = tau*C1*lag(w1)``
    (Equ. 1 kinematics, ``M_t' = C1*w1``), so ``M_t = y + tau*C1*lag(w)`` with ``w``
    the integrated acceleration (:func:`chamber_speed_integral`, the chamber speed
    up to a constant): exact, no differentiation of the noisy signal. The lag uses
    the first-order-hold discretisation (a zero-order hold's half-sample delay
    would move stick starts by ~0.5 ms at 10 rpm).
    """
    return torsion + tau * c1 * first_order_lag(w, dt, tau)
