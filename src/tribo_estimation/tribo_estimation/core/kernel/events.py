"""Switching events of the stick/slip integrator and their location.

Events: slip end ``v = 0`` (:data:`EV_SLIP_END`), slip-speed peak for the paper's
deceleration rule (:data:`EV_PEAK`), breakaway ``|M_stick| = F_N*R*mu_s``
(:data:`EV_BREAKAWAY`). :func:`_locate` finds the instant inside a step by
Illinois (regula falsi) iteration on the RK4 solution restarted from the step
start, to a time tolerance of :data:`EVENT_TOL` times the step.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .equations import _derivatives_call, static_coefficient, stick_moment
from .layout import P_FN, P_R, Y_PHI1, Y_PHI2, Y_W1, Y_W2
from .state import FASTMATH, FloatTuple
from .step import _rk4

FloatArray = NDArray[np.float64]

#: Relative time tolerance of the event location (fraction of one step).
EVENT_TOL = 1e-9
_MAX_ITER = 60

EV_NONE = 0
EV_SLIP_END = 1
EV_PEAK = 2
EV_BREAKAWAY = 3


@njit(
    cache=True,
    error_model='numpy',
    fastmath=FASTMATH,
)
def _event_value(
    p: FloatArray,
    which: int,
    t: float,
    y: FloatTuple,
    stuck: bool,
    direction: float,
    peak: bool,
    t_stick: float,
) -> float:
    """Return the event function; its sign change from >0 to <=0 marks the event."""
    if which == EV_SLIP_END:
        return direction * (y[Y_W2] - y[Y_W1])
    if which == EV_PEAK:
        d = _derivatives_call(p, t, y, stuck, direction, peak)
        return direction * (d[Y_W2] - d[Y_W1])
    # breakaway: F_N*R*mu_s - |M_stick|
    ms = stick_moment(p, t, y[Y_PHI1], y[Y_W1], y[Y_PHI2])
    return float(p[P_FN] * p[P_R] * static_coefficient(p, t, t_stick) - abs(ms))


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def _locate(
    p: FloatArray,
    which: int,
    t: float,
    y: FloatTuple,
    k1: FloatTuple,
    h: float,
    g_a: float,
    g_b: float,
    stuck: bool,
    direction: float,
    peak: bool,
    t_stick: float,
) -> float:
    """Locate the event inside (0, h] by Illinois iteration on RK4 restarted from t.

    Returns
    -------
    float
        The smallest tau found with g(tau) <= 0 (the crossing is completed there).
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
        yc = _rk4(p, t, y, k1, c, stuck, direction, peak)
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
