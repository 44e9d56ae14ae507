"""Signal helpers shared by every fit.

The one noise estimate, the one runs helper, the one smoothed derivative
(:func:`local_slope`), the one chamber-speed reconstruction, the one first-order
recursive filter (:func:`iir1`, compiled: scipy.signal takes longer to import than
a block fit takes) and the first-order sensor lag.

All values keep the unit of their input; ``fs`` in Hz, time constants in s.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import numpy.typing as npt
from numba import njit

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Half width of the local cubic that gives w1 = phi1' from the torsion moment [samples].
CHAMBER_HALF = 7
#: Longest span of a local fit to a rig's signal, in periods of its fastest mode [-]:
#: a cubic over a quarter period of a sinusoid gives its slope within about 1 %
#: (docs/physics.md, "Local fits at low sample rates").
RIG_FIT_SPAN = 0.25


def mad_sigma(x: FloatArray) -> float:
    """Return the robust standard deviation ``1.4826 * median(|x - median(x)|)`` [unit of x].

    NaN for an empty array.
    """
    if x.size == 0:
        return math.nan
    med = float(np.median(x))
    return 1.4826 * float(np.median(np.abs(x - med)))


def noise_level(x: FloatArray, order: int = 2) -> float:
    """Robust white-noise standard deviation of a sampled signal [unit of x].

    From the median absolute deviation of the ``order``-th difference (a smooth
    signal's differences are far below the noise at 10 kHz; a few sharp features
    such as breakaways or a spike do not move the median). White noise of standard
    deviation s gives a k-th difference of variance ``C(2k, k)*s^2`` (6 for k = 2,
    20 for k = 3): ``sigma = 1.4826*MAD(d_k)/sqrt(C(2k, k))``. The third difference
    also ignores a parabola (the stick detector's residual). NaN for fewer than 8
    samples; only the finite differences count.
    """
    a = np.asarray(x, dtype=np.float64)
    if a.shape[0] < 8:
        return math.nan
    d = np.diff(a, order)
    d = d[np.isfinite(d)]
    if d.size < 8 - order:
        return math.nan
    return mad_sigma(d) / math.sqrt(float(math.comb(2 * order, order)))


def runs(mask: npt.ArrayLike) -> tuple[IntArray, IntArray]:
    """Start and stop (exclusive) indices of the runs of True in ``mask``."""
    m = np.asarray(mask, dtype=np.int8).ravel()
    d = np.diff(np.concatenate(([0], m, [0])))
    return np.flatnonzero(d == 1).astype(np.int64), np.flatnonzero(d == -1).astype(np.int64)


def grouped_medians(values: npt.ArrayLike, counts: npt.ArrayLike) -> FloatArray:
    """Return the median of each consecutive group of ``values`` (``np.median``'s values).

    One sort for all the groups instead of one call per group.

    Parameters
    ----------
    values : array_like
        The groups' values, one group after the other.
    counts : array_like of int
        The groups' lengths (sum: ``len(values)``).

    Returns
    -------
    numpy.ndarray
        Per group its median (the mean of the two middle values of an even group);
        NaN for an empty group or one holding a NaN.

    Examples
    --------
    >>> grouped_medians([3.0, 1.0, 2.0, 5.0, 4.0], [3, 0, 2]).tolist()
    [2.0, nan, 4.5]
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    n = np.asarray(counts, dtype=np.int64).ravel()
    if n.size and (n.min() < 0 or int(n.sum()) != v.size):
        raise ValueError(f'group lengths {n.tolist()} do not add up to {v.size} values')
    out = np.full(n.size, np.nan)
    if v.size == 0:
        return out
    group = np.repeat(np.arange(n.size), n)
    sv = v[np.lexsort((v, group))]
    first = np.cumsum(n) - n
    ok = (n > 0) & (np.bincount(group, weights=np.isnan(v), minlength=n.size) == 0)
    lo = (first + (n - 1) // 2)[ok]
    hi = (first + n // 2)[ok]
    out[ok] = (sv[lo] + sv[hi]) / 2.0
    return out


def span_medians(x: npt.ArrayLike, starts: npt.ArrayLike, stops: npt.ArrayLike) -> FloatArray:
    """Return the median of ``x[a:b]`` for every span ``(a, b)`` (:func:`grouped_medians`).

    Examples
    --------
    >>> span_medians([1.0, 5.0, 2.0, 8.0], [0, 1], [3, 4]).tolist()
    [2.0, 5.0]
    """
    xa = np.asarray(x, dtype=np.float64).ravel()
    a = np.asarray(starts, dtype=np.int64).ravel()
    n = np.maximum(np.asarray(stops, dtype=np.int64).ravel() - a, 0)
    if n.size == 0:
        return np.zeros(0)
    idx = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n - a, n)
    return grouped_medians(xa[idx], n)


def longest_run(mask: npt.ArrayLike) -> tuple[int, int]:
    """``(start, stop)`` of the longest run of True (``(0, 0)`` if none)."""
    st, en = runs(mask)
    if st.size == 0:
        return 0, 0
    i = int(np.argmax(en - st))
    return int(st[i]), int(en[i])


def local_slope(x: FloatArray, dt: float, window: int, order: int = 1) -> FloatArray:
    """Return the slope x' of a local least-squares polynomial (Savitzky-Golay).

    The one smoothed derivative of the project: a polynomial of degree ``order`` fitted
    over a centred window of ``window`` samples gives x' at each sample; at the ends
    the polynomial of the first/last full window is used. For ``order`` 1 this is the
    least-squares line, ``x'_i = sum_k k*x_(i+k) / (dt*sum_k k^2)``.

    Parameters
    ----------
    x : FloatArray
        Samples [any unit].
    dt : float
        Sample interval [s].
    window : int
        Window length [samples], odd; shrunk to the longest odd length the record holds.
    order : int
        Polynomial degree (1: line, 3: cubic).

    Returns
    -------
    FloatArray
        x' [unit of x per s]; zeros when the record is shorter than ``order`` + 2 samples.
    """
    xx = np.asarray(x, dtype=np.float64)
    n = int(xx.shape[0])
    win = min(int(window), n - (1 - n % 2))
    if win < order + 2:
        return np.zeros(n)
    h = win // 2
    centre, edge = _slope_weights(win, order)
    out = np.empty(n)
    out[h : n - h] = np.correlate(xx, centre, 'valid')
    out[:h] = edge @ xx[:win]  # the first window's polynomial at its first h samples
    out[n - h :] = -(edge @ xx[n - win :][::-1])[::-1]  # mirrored: the last window's
    return out / dt


@functools.cache
def _slope_weights(win: int, order: int) -> tuple[FloatArray, FloatArray]:
    """Return the weights of the local polynomial's slope [1/sample].

    ``centre``: the slope at the middle of a window of ``win`` samples from its
    samples; ``edge``: rows for the slopes at the window's first ``win // 2``
    samples (the same polynomial, of degree ``order``).
    """
    pos = np.arange(win, dtype=np.float64) - win // 2
    pinv = np.linalg.pinv(np.vander(pos, order + 1, increasing=True))  # coefficients of x
    powers = np.arange(order + 1, dtype=np.float64)
    # d/dk of sum_j c_j k^j at k: sum_j j c_j k^(j-1)
    at = pos[: win // 2, None]
    deriv = powers[None, 1:] * at ** (powers[None, 1:] - 1.0)
    centre = pinv[1].copy()
    edge = deriv @ pinv[1:]
    centre.setflags(write=False)
    edge.setflags(write=False)
    return centre, edge


def rig_half(half: int, fs: float, f_max: float, least: int = 2) -> int:
    """Half width [samples] of a local fit to a rig's signal at sample rate ``fs``.

    ``half`` (the width chosen for fast sampling), shortened so that the window
    ``2*half + 1`` spans at most :data:`RIG_FIT_SPAN` periods of the rig's fastest
    mode ``f_max`` [Hz] (:attr:`tribo_estimation.core.model.RigParams.fastest_mode_hz`),
    and at least ``least``. At 10-20 kHz it is ``half`` for the rigs of Tab. 1; at
    2 kHz a 15-sample window would span most of a stick-slip cycle.

    Examples
    --------
    >>> rig_half(7, 20_000.0, 74.0), rig_half(7, 2_000.0, 94.0)
    (7, 2)
    """
    cap = int(RIG_FIT_SPAN * fs / f_max / 2.0) if f_max > 0.0 else half
    return max(least, min(half, cap))


def chamber_speed(torsion: FloatArray, fs: float, c1: float, window: int = 0) -> FloatArray:
    """Reconstruct the chamber speed from the torsion moment.

    w1 = phi1' = (dM_t/dt)/C1 [rad/s] from M_t = C1*phi1 [N m] (Equ. 4; local cubic
    over ``window`` samples, default 2*7+1, by :func:`local_slope`).

    Independent of the speed and acceleration channels (and so of their lags
    and offsets).

    Parameters
    ----------
    torsion : FloatArray
        Torsion moment M_t [N m].
    fs : float
        Sample rate [Hz].
    c1 : float
        Torsion stiffness C1 [N m/rad].
    window : int
        Window of the local cubic [samples] (0: ``2*CHAMBER_HALF + 1``).

    Returns
    -------
    FloatArray
        w1 [rad/s] (zeros for fewer than 5 samples).
    """
    win = window if window > 0 else 2 * CHAMBER_HALF + 1
    return local_slope(torsion, 1.0 / fs, win, order=3) / c1


@njit(cache=True)
def _iir1(b0: float, b1: float, a1: float, x: FloatArray, z: float) -> tuple[FloatArray, float]:
    y = np.empty_like(x)
    for i in range(x.size):
        y[i] = b0 * x[i] + z
        z = b1 * x[i] - a1 * y[i]
    return y, z


def iir1(b0: float, b1: float, a1: float, x: FloatArray, z: float) -> tuple[FloatArray, float]:
    """Filter ``x`` by ``y[n] = b0*x[n] + b1*x[n-1] - a1*y[n-1]`` from the state ``z``.

    The first-order case of ``scipy.signal.lfilter([b0, b1], [1, a1], x, zi=[z])``
    (direct form II transposed, same operations, same results).

    Parameters
    ----------
    b0, b1, a1 : float
        Filter coefficients [-].
    x : numpy.ndarray
        Input samples [unit of x].
    z : float
        Filter state before ``x[0]`` (``b1*x[-1] - a1*y[-1]``) [unit of x].

    Returns
    -------
    tuple of (numpy.ndarray, float)
        The output [unit of x] and the state after the last sample.
    """
    y, zf = _iir1(float(b0), float(b1), float(a1), np.ascontiguousarray(x, dtype=np.float64), z)
    return y, float(zf)


#: Ratio of the sample interval to a lag beyond which the lag is none [-]: the
#: discrete filter's pole exp(-dt/tau) is then below 1e-304 (a numerical bound).
_NO_LAG = 700.0


def first_order_lag(x: FloatArray, dt: float, tau: float, y0: float | None = None) -> FloatArray:
    """First-order sensor lag ``tau*y' = x - y`` of samples ``x`` at period ``dt`` [s].

    Exact for an input linear between samples (first-order hold; a zero-order hold
    would lag half a sample too little, which matters where the signal changes at
    thousands of units per second):
    ``y[n] = a*y[n-1] + (1 - c)*x[n] + (c - a)*x[n-1]``, ``a = exp(-dt/tau)``,
    ``c = (1 - a)*tau/dt``. ``y0``: output at the first sample (default ``x[0]``,
    settled). ``tau <= 0`` returns a copy of ``x``. (The independent record
    generator, :mod:`.reference_records`, has its own implementation on purpose:
    it shares no code with the fits.)
    """
    xx = np.asarray(x, dtype=np.float64)
    if tau <= 0.0 or xx.size == 0 or dt > _NO_LAG * tau:
        return xx.copy()  # (a lag of under 1/700 of a sample: exp(-dt/tau) is 0)
    a = math.exp(-dt / tau)
    c = (1.0 - a) * tau / dt
    y_first = float(xx[0]) if y0 is None else float(y0)
    # state with x[-1] = x[0] such that y[0] = y_first
    y_prev = (y_first - (1.0 - a) * xx[0]) / a
    y, _ = iir1(1.0 - c, c - a, -a, xx, a * y_prev + (c - a) * float(xx[0]))
    return y


def second_order_lag(a1: float, a2: float, dt: float) -> FloatArray:
    """Return the exact step of a second-order sensor for an input linear between samples.

    The sensor ``a2*y'' + a1*y' + y = x`` (``a1 = 2*zeta/omega`` [s], ``a2 = 1/omega^2``
    [s^2]) with state ``s = (y, y')``: over one sample interval, with ``x`` linear
    between samples, ``s[n] = Phi s[n-1] + g0*x[n-1] + g1*(x[n] - x[n-1])``, from the
    matrix exponential of the system augmented by the input and its slope.

    Parameters
    ----------
    a1 : float
        First-order coefficient [s] (> 0).
    a2 : float
        Second-order coefficient [s^2] (> 0).
    dt : float
        Sample interval [s].

    Returns
    -------
    FloatArray
        ``(Phi00, Phi01, Phi10, Phi11, g0_0, g0_1, g1_0, g1_1)``, the units of ``s``.

    Examples
    --------
    >>> c = second_order_lag(2e-3, 1e-6, 1e-4)
    >>> bool(abs(c[0] + c[4] - 1.0) < 1e-12)  # a constant input is kept
    True
    """
    from scipy.linalg import expm

    m = np.zeros((4, 4))
    m[0, 1] = 1.0
    m[1, 0] = -1.0 / a2
    m[1, 1] = -a1 / a2
    m[1, 2] = 1.0 / a2
    m[2, 3] = 1.0
    e = expm(m * dt)
    return np.array(
        [e[0, 0], e[0, 1], e[1, 0], e[1, 1], e[0, 2], e[1, 2], e[0, 3] / dt, e[1, 3] / dt]
    )


@njit(cache=True, nogil=True)
def lag_segments(
    x: np.ndarray,
    starts: np.ndarray,
    stops: np.ndarray,
    y_prev: np.ndarray,
    a: float,
    out: np.ndarray,
    c: float = -1.0,
) -> None:
    """Apply a first-order sensor lag per segment, each from its own filter state.

    ``c < 0``: ``y[n] = a*y[n-1] + (1 - a)*x[n]``; else the exact form of a
    continuous sensor for an input linear between samples,
    ``y[n] = a*y[n-1] + (1 - c)*x[n] + (c - a)*x[n-1]`` with
    ``c = (1 - a)*tau/dt`` (the other lags by dt/2 less).

    Parameters
    ----------
    x : numpy.ndarray
        Sensor input [unit].
    starts, stops : numpy.ndarray
        First and stop (exclusive) sample of each segment.
    y_prev : numpy.ndarray
        Filter state before each segment's first sample [unit].
    a : float
        ``exp(-dt/tau)`` [-].
    out : numpy.ndarray
        Sensor output [unit], written per segment.
    c : float
        ``(1 - a)*tau/dt`` for the exact form, negative for the simple one.
    """
    cc = a if c < 0.0 else c
    for k in range(starts.shape[0]):
        y = y_prev[k]
        x_prev = x[starts[k]] if stops[k] > starts[k] else 0.0
        for i in range(starts[k], stops[k]):
            y = a * y + (1.0 - cc) * x[i] + (cc - a) * x_prev
            x_prev = x[i]
            out[i] = y


@njit(cache=True, nogil=True)
def lag2_segments(
    x: np.ndarray,
    starts: np.ndarray,
    stops: np.ndarray,
    y_prev: np.ndarray,
    yd_prev: np.ndarray,
    c: np.ndarray,
    out: np.ndarray,
    out_d: np.ndarray,
) -> None:
    """Apply a second-order sensor per segment, each from its own filter state.

    ``s[n] = Phi s[n-1] + g0*x[n-1] + g1*(x[n] - x[n-1])`` with ``s = (y, y')`` and
    the coefficients of :func:`second_order_lag`; before a segment the input is held at
    its first sample (as :func:`tribo_estimation.core.signal.lag_segments`).

    Parameters
    ----------
    x : numpy.ndarray
        Sensor input [unit].
    starts, stops : numpy.ndarray
        First and stop (exclusive) sample of each segment.
    y_prev, yd_prev : numpy.ndarray
        Filter output [unit] and its slope [unit/s] before each segment's first sample.
    c : numpy.ndarray
        The eight coefficients of :func:`second_order_lag`.
    out, out_d : numpy.ndarray
        Sensor output [unit] and its slope [unit/s], written per segment.
    """
    for k in range(starts.shape[0]):
        y = y_prev[k]
        yd = yd_prev[k]
        x_prev = x[starts[k]] if stops[k] > starts[k] else 0.0
        for i in range(starts[k], stops[k]):
            dx = x[i] - x_prev
            y, yd = (
                c[0] * y + c[1] * yd + c[4] * x_prev + c[6] * dx,
                c[2] * y + c[3] * yd + c[5] * x_prev + c[7] * dx,
            )
            x_prev = x[i]
            out[i] = y
            out_d[i] = yd


def second_order_filter(x: FloatArray, dt: float, a1: float, a2: float) -> FloatArray:
    """Second-order sensor ``a2*y'' + a1*y' + y = x`` of samples ``x`` at period ``dt`` [s].

    Exact for an input linear between samples (:func:`second_order_lag`), from the
    settled state at the first sample (``y = x[0]``, ``y' = 0``). ``a2 <= 0`` is the
    first-order lag ``a1`` (:func:`first_order_lag`).

    Parameters
    ----------
    x : FloatArray
        Input samples [unit].
    dt : float
        Sample interval [s].
    a1 : float
        First-order coefficient [s] (``2*zeta/omega``).
    a2 : float
        Second-order coefficient [s^2] (``1/omega^2``).

    Returns
    -------
    FloatArray
        The sensor output [unit].

    Examples
    --------
    >>> y = second_order_filter(np.ones(5), 1e-4, 2e-3, 1e-6)
    >>> bool(np.allclose(y, 1.0))  # a settled constant stays
    True
    """
    xx = np.ascontiguousarray(x, dtype=np.float64)
    if a2 <= 0.0 or xx.size == 0 or dt * dt > _NO_LAG * a2:
        return first_order_lag(xx, dt, a1)
    y = np.empty_like(xx)
    first = xx[:1].copy()
    lag2_segments(
        xx, np.zeros(1, np.int64), np.full(1, xx.size, np.int64), first, np.zeros(1),
        second_order_lag(a1, a2, dt), y, np.empty_like(xx),
    )  # fmt: skip
    return y


def running_max(x: FloatArray, width: int) -> FloatArray:
    """Return the maximum over a centred window of ``width`` samples (edges held).

    ``scipy.ndimage.maximum_filter1d(x, width, mode='nearest')`` without importing
    scipy.ndimage (which costs more than the block fit that uses this).

    Parameters
    ----------
    x : FloatArray
        Samples [any unit].
    width : int
        Window length [samples] (>= 1).

    Returns
    -------
    FloatArray
        The running maximum [unit of x].
    """
    xx = np.asarray(x, dtype=np.float64)
    w = max(1, int(width))
    if xx.size == 0 or w == 1:
        return xx.copy()
    left = w // 2
    padded = np.concatenate((np.full(left, xx[0]), xx, np.full(w - 1 - left, xx[-1])))
    out: FloatArray = np.lib.stride_tricks.sliding_window_view(padded, w).max(axis=1)
    return out


def running_integral(x: FloatArray, dt: float) -> FloatArray:
    """Return the trapezoid integral of ``x`` from its first sample to each [unit*s].

    Parameters
    ----------
    x : FloatArray
        Samples [unit].
    dt : float
        Sample interval [s].

    Returns
    -------
    FloatArray
        Same length as ``x``, 0 at the first sample.
    """
    out: FloatArray = np.concatenate(([0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * dt)))
    return out


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
    out: FloatArray = (c[hi] - c[lo]) / (hi - lo)
    return out


__all__ = [
    'CHAMBER_HALF',
    'RIG_FIT_SPAN',
    'chamber_speed',
    'first_order_lag',
    'lag2_segments',
    'lag_segments',
    'longest_run',
    'moving_average',
    'noise_level',
    'rig_half',
    'running_integral',
    'runs',
]
