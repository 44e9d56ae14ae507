"""Signal helpers shared by every fit: the one noise estimate, the one runs helper,
the one chamber-speed reconstruction and the first-order sensor lag.

All values keep the unit of their input; ``fs`` in Hz, time constants in s.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Half width of the local cubic that gives w1 = phi1' from the torsion moment [samples].
CHAMBER_HALF = 7


def noise_level(x: FloatArray) -> float:
    """Robust white-noise standard deviation of a sampled signal [unit of x].

    From the median absolute deviation of the second difference (a smooth
    signal's second difference is far below the noise at 10 kHz; a few sharp
    features such as breakaways or a spike do not move the median):
    ``sigma = 1.4826*MAD(d2)/sqrt(6)``. NaN for fewer than 8 samples; only the
    finite second differences count.
    """
    a = np.asarray(x, dtype=np.float64)
    if a.shape[0] < 8:
        return math.nan
    d2 = a[2:] - 2.0 * a[1:-1] + a[:-2]
    d2 = d2[np.isfinite(d2)]
    if d2.size < 6:
        return math.nan
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return 1.4826 * mad / math.sqrt(6.0)


def runs(mask: npt.ArrayLike) -> tuple[IntArray, IntArray]:
    """Start and stop (exclusive) indices of the runs of True in ``mask``."""
    m = np.asarray(mask, dtype=np.int8).ravel()
    d = np.diff(np.concatenate(([0], m, [0])))
    return np.flatnonzero(d == 1).astype(np.int64), np.flatnonzero(d == -1).astype(np.int64)


def longest_run(mask: npt.ArrayLike) -> tuple[int, int]:
    """``(start, stop)`` of the longest run of True (``(0, 0)`` if none)."""
    st, en = runs(mask)
    if st.size == 0:
        return 0, 0
    i = int(np.argmax(en - st))
    return int(st[i]), int(en[i])


def chamber_speed(torsion: FloatArray, fs: float, c1: float) -> FloatArray:
    """Chamber speed w1 = phi1' = (dM_t/dt)/C1 [rad/s] from the torsion moment
    M_t = C1*phi1 [N m] (local cubic over 2*7+1 samples, one-sided at the ends).

    Independent of the speed and acceleration channels (and so of their lags
    and offsets); ``fs`` [Hz], ``c1`` [N m/rad]."""
    from scipy.signal import savgol_filter

    n = torsion.shape[0]
    win = min(2 * CHAMBER_HALF + 1, n - (1 - n % 2))
    if win < 5:
        return np.zeros(n)
    return np.asarray(savgol_filter(torsion, win, 3, deriv=1, delta=1.0 / fs)) / c1


def first_order_lag(x: FloatArray, dt: float, tau: float, y0: float | None = None) -> FloatArray:
    """A first-order sensor lag of time constant ``tau`` [s] applied to ``x``:
    ``y[n] = a*y[n-1] + (1 - a)*x[n]``, ``a = exp(-dt/tau)`` (``tau <= 0``: no lag).
    ``y0`` is the filter state before the first sample (default ``x[0]``)."""
    from scipy.signal import lfilter

    xx = np.asarray(x, dtype=np.float64)
    if tau <= 0.0 or xx.size == 0:
        return xx.copy()
    a = math.exp(-dt / tau)
    prev = float(xx[0]) if y0 is None else float(y0)
    y, _ = lfilter([1.0 - a], [1.0, -a], xx, zi=[a * prev])
    return np.asarray(y, dtype=np.float64)


def moving_average(x: FloatArray, width: int) -> FloatArray:
    """Centred moving average over ``width`` samples (shorter windows at the ends)."""
    xx = np.asarray(x, dtype=np.float64)
    n = xx.size
    h = max(0, int(width) // 2)
    if n == 0 or h == 0:
        return xx.copy()
    c = np.concatenate(([0.0], np.cumsum(xx)))
    i = np.arange(n)
    lo = np.maximum(i - h, 0)
    hi = np.minimum(i + h + 1, n)
    return (c[hi] - c[lo]) / (hi - lo)


__all__ = [
    'CHAMBER_HALF',
    'chamber_speed',
    'first_order_lag',
    'longest_run',
    'moving_average',
    'noise_level',
    'runs',
]
