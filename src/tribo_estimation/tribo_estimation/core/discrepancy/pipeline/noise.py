"""The record's measured noise: a white and a coloured (AR(1)) part per channel.

The decisions of the workflow compare a model's residual with what noise alone
leaves (:mod:`.null`). The noise is measured where the model cannot be wrong
about friction: inside the stick phases that the record and the model share
(Equ. 4-6: while the discs stick, the motion does not depend on the friction law),
at least :data:`GUARD` from their ends. Per channel (torsion moment [N m], chamber
acceleration [rad/s^2], shaft speed [rad/s]) the residual there is modelled as

    e[n] = w[n] + c[n],   w white (variance s_w^2),
    c[n] = phi*c[n-1] + u[n]  (AR(1), variance s_c^2, phi = exp(-dt/tau_c)),

fitted to the pooled autocovariance of the phases (each phase demeaned; the
expectation of the demeaned autocovariance is used, so short phases do not bias
the fit). A record without stick phases gets the white part alone, from the
second differences of its residual (:func:`tribo_estimation.core.signal.noise_level`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.signal import noise_level, runs

FloatArray = npt.NDArray[np.float64]

#: Distance from a stick phase's ends to the samples that measure the noise [s].
GUARD = 1e-3
#: Shortest stick interior that measures the noise [samples].
MIN_WINDOW = 16
#: Largest autocovariance lag fitted [samples].
MAX_LAG = 30
#: Correlation times of the coloured part tried [samples] (log grid).
_TAU_GRID = np.geomspace(0.3, 200.0, 40)

#: The raw channels, in the order of :meth:`NoiseModel.draw`.
RAW_CHANNELS: tuple[str, str, str] = ('torsion_moment', 'angular_acceleration', 'speed')


@dataclass(frozen=True)
class ChannelNoise:
    """Noise of one channel (unit of the channel).

    Parameters
    ----------
    white : float
        Standard deviation of the white part [unit].
    coloured : float
        Standard deviation of the AR(1) part [unit].
    corr_time : float
        Its correlation time ``tau_c`` [s] (0 without a coloured part).
    """

    white: float
    coloured: float = 0.0
    corr_time: float = 0.0

    @property
    def total(self) -> float:
        """Standard deviation of the whole noise [unit]."""
        return math.hypot(self.white, self.coloured)

    def draw(self, rng: np.random.Generator, n: int, dt: float) -> FloatArray:
        """Draw ``n`` stationary samples at interval ``dt`` [s].

        Parameters
        ----------
        rng : numpy.random.Generator
            Random source.
        n : int
            Number of samples.
        dt : float
            Sample interval [s].

        Returns
        -------
        FloatArray
            The noise [unit].
        """
        out = rng.normal(0.0, self.white, n) if self.white > 0.0 else np.zeros(n)
        if self.coloured > 0.0 and self.corr_time > 0.0:
            from scipy.signal import lfilter

            phi = math.exp(-dt / self.corr_time)
            u = rng.normal(0.0, self.coloured * math.sqrt(1.0 - phi * phi), n)
            c0 = rng.normal(0.0, self.coloured)
            c, _ = lfilter([1.0], [1.0, -phi], u, zi=[phi * c0])
            out = out + c
        return np.asarray(out, dtype=np.float64)


@dataclass(frozen=True)
class NoiseModel:
    """The measured noise of the three raw channels.

    Parameters
    ----------
    torsion_moment : ChannelNoise
        Torsion moment [N m].
    angular_acceleration : ChannelNoise
        Chamber acceleration [rad/s^2].
    speed : ChannelNoise
        Shaft speed [rad/s].
    samples : int
        Stick-phase samples that measured it (0: second differences, white only).
    """

    torsion_moment: ChannelNoise
    angular_acceleration: ChannelNoise
    speed: ChannelNoise
    samples: int = 0

    def channel(self, name: str) -> ChannelNoise:
        """Return the noise of a raw channel by name (one of :data:`RAW_CHANNELS`)."""
        out: ChannelNoise = getattr(self, name)
        return out

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form (per channel: white, coloured [unit], corr_time [s])."""
        out: dict[str, object] = {
            c: {
                'white': self.channel(c).white,
                'coloured': self.channel(c).coloured,
                'corr_time': self.channel(c).corr_time,
            }
            for c in RAW_CHANNELS
        }
        out['stick_samples'] = self.samples
        return out


def _window_kernels(m: int, lags: int, tau: float) -> tuple[FloatArray, FloatArray]:
    """Return the expected lagged products of a demeaned window of ``m`` samples.

    For a unit white noise and a unit AR(1) process of correlation time ``tau``
    [samples]: ``E[sum_i x~_i x~_(i+k)]`` for k = 0..lags, x~ the window less its mean:
    ``(m - k)*(gamma(k) + gbar) - sum_(i < m-k) g_i - sum_(i >= k) g_i`` with
    ``g_i = mean_l gamma(i - l)`` and ``gbar = mean_i g_i``.

    Returns
    -------
    tuple of FloatArray
        The white and the AR(1) kernel, each of length ``lags + 1``.
    """
    k = np.arange(lags + 1)
    valid = k < m
    white = np.where(valid, (m - k) * ((k == 0).astype(np.float64) - 1.0 / m), 0.0)
    phi = math.exp(-1.0 / tau)
    i = np.arange(m, dtype=np.float64)
    # g_i = (1/m) sum_l phi^|i-l| in closed form (two geometric sums)
    left = (1.0 - phi ** (i + 1.0)) / (1.0 - phi)
    right = (1.0 - phi ** (m - i)) / (1.0 - phi)
    g = (left + right - 1.0) / m
    gbar = float(g.mean())
    cg = np.concatenate(([0.0], np.cumsum(g)))
    kk = np.minimum(k, m - 1)
    head = cg[m - kk]  # sum_(i < m-k) g_i
    tail = cg[m] - cg[kk]  # sum_(i >= k) g_i
    ar = np.where(valid, (m - k) * (phi**k + gbar) - head - tail, 0.0)
    return white, ar


def _lagged_products(x: FloatArray, lags: int) -> FloatArray:
    """Return ``sum_i x_i x_(i+k)`` for k = 0..lags (0 beyond the window)."""
    out = np.zeros(lags + 1)
    m = x.size
    for k in range(min(lags, m - 1) + 1):
        out[k] = float(np.dot(x[k:], x[: m - k]))
    return out


#: Longest window the autocovariance is pooled over [samples] (longer interiors are split).
WINDOW = 128


def fit_channel(windows: Iterable[FloatArray], dt: float, fallback: float) -> ChannelNoise:
    """Fit white + AR(1) noise to the residual in stick interiors.

    Each interior is cut into windows of at most :data:`WINDOW` samples, each
    demeaned; the pooled lagged products are fitted by their expectation
    (:func:`_window_kernels`) with non-negative variances, the correlation time on
    a log grid.

    Parameters
    ----------
    windows : iterable of FloatArray
        The residual inside each stick interior [unit].
    dt : float
        Sample interval [s].
    fallback : float
        White level to use without usable windows [unit].

    Returns
    -------
    ChannelNoise
        The fitted noise.
    """
    from scipy.optimize import nnls

    lags = MAX_LAG
    sums = np.zeros(lags + 1)
    lengths: dict[int, int] = {}
    for w in windows:
        x_all = np.asarray(w, dtype=np.float64)
        if not np.all(np.isfinite(x_all)):
            continue
        for a in range(0, x_all.size, WINDOW):
            x = x_all[a : a + WINDOW]
            if x.size < MIN_WINDOW:
                continue
            sums += _lagged_products(x - float(np.mean(x)), lags)
            lengths[x.size] = lengths.get(x.size, 0) + 1
    if not lengths:
        return ChannelNoise(max(fallback, 0.0))
    counts = np.zeros(lags + 1)
    for m, c in lengths.items():
        counts += c * np.maximum(m - np.arange(lags + 1), 0)
    sw = 1.0 / np.sqrt(np.maximum(counts, 1.0))
    best: tuple[float, float, float, float] | None = None
    for tau in _TAU_GRID:
        kw = np.zeros(lags + 1)
        ka = np.zeros(lags + 1)
        for m, c in lengths.items():
            wk, ak = _window_kernels(m, lags, float(tau))
            kw += c * wk
            ka += c * ak
        coef, res = nnls(np.column_stack([kw, ka]) * sw[:, None], sums * sw)
        if best is None or res < best[0]:
            best = (float(res), float(coef[0]), float(coef[1]), float(tau))
    assert best is not None
    _, vw, vc, tau = best
    if vc <= 0.0:
        return ChannelNoise(math.sqrt(max(vw, 0.0)))
    return ChannelNoise(math.sqrt(max(vw, 0.0)), math.sqrt(vc), tau * dt)


def stick_interiors(stick: npt.NDArray[np.bool_], fs: float) -> list[tuple[int, int]]:
    """Return the interiors of the stick runs of ``stick`` (:data:`GUARD` from the ends).

    Parameters
    ----------
    stick : numpy.ndarray of bool
        True where the discs stick (in the record and in the model).
    fs : float
        Sample rate [Hz].

    Returns
    -------
    list of (int, int)
        First and stop sample of each interior of at least :data:`MIN_WINDOW` samples.
    """
    guard = max(1, math.ceil(GUARD * fs))
    a, b = runs(stick)
    return [
        (int(x) + guard, int(y) - guard)
        for x, y in zip(a, b, strict=True)
        if int(y) - int(x) - 2 * guard >= MIN_WINDOW
    ]


def measure_noise(residuals: dict[str, FloatArray], covered: npt.NDArray[np.bool_]) -> NoiseModel:
    """Measure the white noise of the raw channels from a model's residuals.

    The robust second-difference level of each residual
    (:func:`tribo_estimation.core.signal.noise_level`): the model removes the
    signal, a mismatch is smooth or sparse at the sample rate, so the level is the
    sensor's white noise.

    Parameters
    ----------
    residuals : dict of str to FloatArray
        Measured minus simulated, per raw channel (:data:`RAW_CHANNELS`) [unit].
    covered : numpy.ndarray of bool
        The samples the model covers.

    Returns
    -------
    NoiseModel
        The white noise per channel.
    """
    out = {}
    for c in RAW_CHANNELS:
        lvl = noise_level(residuals[c][covered]) if np.any(covered) else math.nan
        out[c] = ChannelNoise(lvl if math.isfinite(lvl) else 0.0)
    return NoiseModel(out['torsion_moment'], out['angular_acceleration'], out['speed'])


__all__ = [
    'GUARD',
    'RAW_CHANNELS',
    'ChannelNoise',
    'NoiseModel',
    'fit_channel',
    'measure_noise',
    'stick_interiors',
]
