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

from tribo_estimation.core.signal import first_order_lag

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


def estimate_torsion_lag(
    torsion: np.ndarray,
    accel: np.ndarray,
    fs: float,
    c1: float,
    max_lag: float = MAX_TORSION_LAG,
    min_lag: float = 0.0,
) -> float:
    """First-order lag of the torsion channel relative to the accelerometer [s].

    Kinematics of the chamber (stick or slip): ``M_t = C1*phi1`` with
    ``phi1'' = a``, so the measured ``y = lag(M_t) = g*C1*(P - tau*lag(W))`` plus a
    slowly varying term, ``W``, ``P`` the single and double integrals of the
    acceleration and ``g`` a gain ratio. ``tau`` minimises the residual of that
    model over 0.1 s windows (each with its own ``g`` and quadratic trend, which
    absorb the integration constants, an accelerometer offset and gain errors);
    search on [``min_lag``, ``max_lag``]: a 0.5 ms grid, halving steps down to 0.1 ms, then a
    parabola. A few ms per second of 10 kHz data; within about 2 % (+-20 us) of
    lags up to 2 ms at the noise of config/rig.yaml (the trapezoid integral of the
    acceleration's jumps at stick boundaries biases it slightly low). A negative
    value (``min_lag`` < 0 allows it) is a lag of the accelerometer itself,
    ``a_meas = lag(a)``: then ``P = P_meas + |tau|*W_meas`` exactly (the inverse lag of
    the double integral), and the model is ``y = g*C1*(P + |tau|*W)``.
    """
    dt = 1.0 / fs
    w = chamber_speed_integral(accel, dt)
    phi = chamber_speed_integral(w, dt)
    n = torsion.size
    m = max(8, min(n, round(_LAG_WIN * fs)))
    k = n // m
    x0 = np.linspace(-1.0, 1.0, m)
    q, _ = np.linalg.qr(np.stack([np.ones(m), x0, x0 * x0], axis=1))

    def detrended(x: np.ndarray) -> np.ndarray:
        xx = x[: k * m].reshape(k, m)
        return np.asarray(xx - (xx @ q) @ q.T)

    y = detrended(torsion)
    syy = float(np.sum(y * y))

    def rss(tau: float) -> float:
        if tau < 0.0:
            x = detrended(c1 * (phi - tau * w))
        else:
            x = detrended(c1 * (phi - tau * first_order_lag(w, dt, tau)))
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
