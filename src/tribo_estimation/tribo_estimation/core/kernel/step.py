"""The RK4 step of the rig kernel and its step-size control.

Classical RK4 at a fixed step ``h = dt/n_sub`` aligned to the output instants
(:func:`substeps_for`), shortened locally where the falling friction curve makes
the slip dynamics fast (:func:`slip_rate`, :data:`STEP_RATE`). The integrated state
``y`` is the tuple of :data:`.layout.NY` floats (indices ``Y_*``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .equations import derivatives, friction_levels
from .layout import (
    P_BEARING,
    P_BEARING_REG,
    P_C1,
    P_C2,
    P_FN,
    P_I1,
    P_I2,
    P_K,
    P_K1,
    P_K2,
    P_LAG_TAU,
    P_R,
    P_SHAPE,
    P_VISC,
)
from .state import FASTMATH, FloatTuple, axpy, rk4_combine

FloatArray = NDArray[np.float64]


#: Largest allowed product of step and the local slip-dynamics rate (see :func:`slip_rate`).
STEP_RATE = 0.15


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
    inline='always',
)
def slip_rate(p: FloatArray, t: float, v_abs: float, peak_passed: bool) -> float:
    """Return the rate of the slip dynamics due to the friction-curve slope [1/s].

    ``|dM/dv|*(1/I1 + 1/I2)`` with ``dM/dv`` from Equ. 8 (and viscous friction);
    used to shorten the RK4 step right after breakaway, where the falling
    friction curve acts as a negative damper.

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    t : float
        Test time [s].
    v_abs : float
        Slip speed magnitude [rad/s].
    peak_passed : bool
        Whether the slip-speed peak has passed.

    Returns
    -------
    float
        Rate [1/s].
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
    return float(slope * (1.0 / p[P_I1] + 1.0 / p[P_I2]))


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
)
def _rk4(
    p: FloatArray,
    t: float,
    y: FloatTuple,
    k1: FloatTuple,
    h: float,
    stuck: bool,
    direction: float,
    peak: bool,
) -> FloatTuple:
    """Take one classical RK4 step of length h from (t, y) with the first stage k1 given."""
    hh = 0.5 * h
    k2 = derivatives(p, t + hh, axpy(y, hh, k1), stuck, direction, peak)
    k3 = derivatives(p, t + hh, axpy(y, hh, k2), stuck, direction, peak)
    k4 = derivatives(p, t + h, axpy(y, h, k3), stuck, direction, peak)
    return rk4_combine(y, h / 6.0, k1, k2, k3, k4)


def substeps_for(p: FloatArray, dt: float) -> int:
    """Return the RK4 steps per output interval so that omega_max*h <= 0.1 and h <= lag_tau/2.

    omega_max is the largest undamped frequency (chamber, shaft, stuck system) or
    damping rate (K/I, bearing regularisation slope / I1) of the rig [rad/s].

    Parameters
    ----------
    p : FloatArray
        Parameter vector (length ``NP``, indices ``P_*``).
    dt : float
        Output sample interval [s].

    Returns
    -------
    int
        Steps per interval (>= 1).
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
    return int(max(1, math.ceil(dt / h_max - 1e-9)))
