"""Compiled boundary stage of the stick detector: stick lines, band growth, breakaway."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Significance (standard errors) a stick parabola's curvature needs to be kept.
_CURVATURE_Z = 5.0

#: Samples of the local stick line that places the ends of a long stick (2 ms at 10 kHz:
#: a drive acceleration of 40 rad/s^2 bends r by C2*40/2*(1 ms)^2 = 0.12 N m over it).
_LOCAL = 20


@njit(cache=True, nogil=True)
def _fit_poly(t: np.ndarray, r: np.ndarray, a0: int, a1: int, deg: int, poly: np.ndarray) -> float:
    """Least-squares polynomial (degree 1 or 2) through ``r[a0..a1]`` over ``t``.

    Stored as ``poly = [tc, h, c0, c1, c2]``: ``p(t) = c0 + c1*x + c2*x^2`` with the
    centred, scaled ``x = (t - tc)/h`` (well conditioned normal equations). Returns
    var(c2)/sigma^2 for white noise of std sigma on r (0 for a line).
    """
    tc = 0.5 * (t[a0] + t[a1])
    h = 0.5 * (t[a1] - t[a0])
    if h <= 0.0:
        h = 1.0
    s0 = s1 = s2 = s3 = s4 = 0.0
    q0 = q1 = q2 = 0.0
    for i in range(a0, a1 + 1):
        x = (t[i] - tc) / h
        x2 = x * x
        y = r[i]
        s0 += 1.0
        s1 += x
        s2 += x2
        s3 += x2 * x
        s4 += x2 * x2
        q0 += y
        q1 += y * x
        q2 += y * x2
    poly[0] = tc
    poly[1] = h
    if deg == 1:
        det = s0 * s2 - s1 * s1
        poly[2] = (q0 * s2 - q1 * s1) / det
        poly[3] = (s0 * q1 - s1 * q0) / det
        poly[4] = 0.0
        return 0.0
    # 3x3 symmetric system [[s0 s1 s2] [s1 s2 s3] [s2 s3 s4]] c = q by Cramer's rule
    m00 = s2 * s4 - s3 * s3
    m01 = s1 * s4 - s3 * s2
    m02 = s1 * s3 - s2 * s2
    det = s0 * m00 - s1 * m01 + s2 * m02
    poly[2] = (q0 * m00 - s1 * (q1 * s4 - s3 * q2) + s2 * (q1 * s3 - s2 * q2)) / det
    poly[3] = (s0 * (q1 * s4 - s3 * q2) - q0 * m01 + s2 * (s1 * q2 - q1 * s2)) / det
    poly[4] = (s0 * (s2 * q2 - q1 * s3) - s1 * (s1 * q2 - q1 * s2) + q0 * m02) / det
    return (s0 * s2 - s1 * s1) / det


@njit(cache=True, nogil=True, inline='always')
def _poly_at(poly: np.ndarray, t: float) -> float:
    """Evaluate the stored polynomial at t."""
    x = (t - poly[0]) / poly[1]
    return float(poly[2] + x * (poly[3] + x * poly[4]))


@njit(cache=True, nogil=True, inline='always')
def _in_band(t: np.ndarray, r: np.ndarray, poly: np.ndarray, i: int, band: float) -> bool:
    """Tell whether sample i of r lies within band of the polynomial."""
    return bool(abs(r[i] - _poly_at(poly, t[i])) <= band)


@njit(cache=True, nogil=True)
def _stick_bounds(
    t: np.ndarray,
    r: np.ndarray,
    c_lo: np.ndarray,
    c_hi: np.ndarray,
    sig: float,
    band: float,
    dt: float,
    starts: np.ndarray,
    ends: np.ndarray,
    slopes: np.ndarray,
) -> int:
    """Boundary stage of :func:`detect_sticks` for the candidate runs ``[c_lo, c_hi]``.

    Per candidate: fit the stick line (a parabola from 12 samples on when its
    curvature is significant against the noise level ``sig`` [N m] of ``r``) to its
    inside, grow/shrink it to the samples within ``band`` [N m] of the line (up to
    four refits), start half a sample before the first in-band sample, end by
    :func:`_breakaway`. Writes ``starts``/``ends`` [s] and the stick line's slope
    at its middle ``slopes`` [N m/s]; returns how many.
    """
    n = t.shape[0]
    poly = np.zeros(5)
    loc = np.zeros(5)
    m = 0
    last_end = -1
    for k in range(c_lo.shape[0]):
        i0 = c_lo[k]
        i1 = c_hi[k]
        if i1 - i0 + 1 < 2 or i1 <= last_end:
            continue
        # first fit on the inside: the candidate run (from the windowed slope) falls
        # short of the stick start (the jump of r there spreads over the window) but
        # overshoots the breakaway by a few samples (v grows smoothly from 0); a short
        # run (a stick of about one window) is centred on its stick: widen it
        if i1 - i0 + 1 < 6:
            a0 = max(0, i0 - 2)
            a1 = min(n - 1, i1)
        else:
            a0 = i0 + 1
            a1 = i1 - min(3, max(0, i1 - i0 - 3))
        lo = a0
        hi = a1
        ok = True
        for _ in range(4):
            if a1 - a0 + 1 < 3:
                ok = False
                break
            # line at constant drive speed; a parabola absorbs a changing drive speed
            # (start-up ramp, ripple) on longer sticks, where its curvature stands out
            # of the noise (an insignificant curvature only bends the extrapolation
            # to the stick's ends)
            var_c2 = _fit_poly(t, r, a0, a1, 2, poly) if a1 - a0 + 1 >= 12 else -1.0
            if var_c2 < 0.0 or abs(poly[4]) < _CURVATURE_Z * sig * math.sqrt(var_c2):
                _fit_poly(t, r, a0, a1, 1, poly)
            # grow from an in-band sample near the middle; one sample out of the band
            # with its next neighbour back in is noise (a 4-sigma sample turns up
            # every few hundred samples), two in a row end the stick
            mid = (a0 + a1) // 2
            if not _in_band(t, r, poly, mid, band):
                if _in_band(t, r, poly, mid + 1, band):
                    mid += 1
                elif _in_band(t, r, poly, mid - 1, band):
                    mid -= 1
                else:
                    ok = False
                    break
            lo = mid
            while lo > 0 and (
                _in_band(t, r, poly, lo - 1, band)
                or (lo > 1 and _in_band(t, r, poly, lo - 2, band))
            ):
                lo -= 1
            hi = mid
            while hi < n - 1 and (
                _in_band(t, r, poly, hi + 1, band)
                or (hi < n - 2 and _in_band(t, r, poly, hi + 2, band))
            ):
                hi += 1
            if lo + 1 == a0 and hi - 1 == a1:
                break
            a0 = lo + 1
            a1 = hi - 1
        if not ok:
            continue
        slopes[m] = poly[3] / poly[1]
        # the drive may accelerate during a long stick (a speed step or a ramp's corner
        # inside it): r is then a line up to the corner and bends after it, which no
        # single line or parabola follows to both ends; the ends are placed with a line
        # fitted to the stick's first (last) _LOCAL samples only
        if hi - lo + 1 >= 2 * _LOCAL:
            lo = _local_start(t, r, lo, hi, band, loc)
            hi = _local_end(t, r, lo, hi, band, loc)
            ends[m] = _breakaway(t, r, loc, lo, hi, dt)
        else:
            ends[m] = _breakaway(t, r, poly, lo, hi, dt)
        starts[m] = t[lo] - 0.5 * dt if lo > 0 else t[0]
        last_end = hi
        m += 1
    return m


@njit(cache=True, nogil=True)
def _breakaway(
    t: np.ndarray, r: np.ndarray, poly: np.ndarray, lo: int, hi: int, dt: float
) -> float:
    """End of the stick [s]: hinge fit of the residual's departure from the stick line.

    After breakaway the residual leaves the line as a ramp ``c*(t - t_e)`` (friction
    falls behind the growing stick moment); t_e is found by least squares (41 trial
    instants from 4 samples before the last in-band sample ``hi`` to the first one
    outside) over the last in-band samples and the first few outside the band.
    """
    n = t.shape[0]
    if hi >= n - 1:
        return float(t[n - 1])
    j1 = min(n - 1, hi + 4)
    j0 = max(lo, hi - 12)
    m = j1 - j0 + 1
    d = np.empty(m)
    for j in range(m):
        d[j] = r[j0 + j] - _poly_at(poly, t[j0 + j])
    best_te = t[hi] + 0.5 * dt
    best_cost = np.inf
    ta = t[max(j0, hi - 4)]
    tb = t[hi + 1]
    step = (tb - ta) / 40.0
    for i in range(41):
        te = tb if i == 40 else ta + i * step
        xx = 0.0
        xd = 0.0
        for j in range(m):
            x = max(t[j0 + j] - te, 0.0)
            xx += x * x
            xd += x * d[j]
        if xx <= 0.0:
            continue
        c = xd / xx
        cost = 0.0
        for j in range(m):
            e = d[j] - c * max(t[j0 + j] - te, 0.0)
            cost += e * e
        if cost < best_cost:
            best_cost = cost
            best_te = te
    return float(best_te)


@njit(cache=True, nogil=True)
def _local_start(
    t: np.ndarray, r: np.ndarray, lo: int, hi: int, band: float, loc: np.ndarray
) -> int:
    """First in-band sample of a stick from a line through its first samples.

    The line is fitted to the ``_LOCAL`` samples after the current first in-band sample
    ``lo`` (the boundary sample itself left out) and the stick grown backwards from
    the middle of that window by the band rule of :func:`_stick_bounds`; repeated
    (up to three times) until the first sample stays. ``hi`` bounds the window.
    """
    for _ in range(3):
        a0 = lo + 1
        a1 = min(hi - 1, a0 + _LOCAL - 1)
        if a1 - a0 + 1 < 3:
            return lo
        _fit_poly(t, r, a0, a1, 1, loc)
        new = (a0 + a1) // 2
        if not _in_band(t, r, loc, new, band):
            return lo
        while new > 0 and (
            _in_band(t, r, loc, new - 1, band) or (new > 1 and _in_band(t, r, loc, new - 2, band))
        ):
            new -= 1
        if new == lo:
            break
        lo = new
    return lo


@njit(cache=True, nogil=True)
def _local_end(t: np.ndarray, r: np.ndarray, lo: int, hi: int, band: float, loc: np.ndarray) -> int:
    """Last in-band sample of a stick from a line through its last samples.

    Mirror of :func:`_local_start`; leaves the last window's line in ``loc`` (the
    stick line :func:`_breakaway` measures the departure from).
    """
    n = t.shape[0]
    for _ in range(3):
        a1 = hi - 1
        a0 = max(lo + 1, a1 - _LOCAL + 1)
        if a1 - a0 + 1 < 3:
            break
        _fit_poly(t, r, a0, a1, 1, loc)
        new = (a0 + a1) // 2
        if not _in_band(t, r, loc, new, band):
            break
        while new < n - 1 and (
            _in_band(t, r, loc, new + 1, band)
            or (new < n - 2 and _in_band(t, r, loc, new + 2, band))
        ):
            new += 1
        if new == hi:
            break
        hi = new
    a1 = hi - 1
    a0 = max(lo + 1, a1 - _LOCAL + 1)
    if a1 - a0 + 1 >= 3:
        _fit_poly(t, r, a0, a1, 1, loc)
    return hi
