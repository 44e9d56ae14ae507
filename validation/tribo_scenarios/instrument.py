"""The instrument chain after the channel filters: gain, offset and the noises of a channel.

The channel's lag (first or second order) acts on the continuous signal and is
integrated with the rig (:mod:`.dynamics`); this module applies the rest of
:class:`.spec.ChannelSpec` to the sampled, filtered value::

    measured = gain*filtered + offset + white + coloured + hum + spikes
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from .spec import ChannelSpec

FloatArray = NDArray[np.float64]


def coloured_noise(ch: ChannelSpec, n: int, fs: float, rng: np.random.Generator) -> FloatArray:
    """Return the channel's coloured noise (std ``ch.coloured_level``), zeros if none.

    'ar1': white noise through a first-order low-pass of corner ``ch.coloured_corner``
    [Hz], started in its stationary state; 'pink': power proportional to 1/f above
    0.1 Hz (flat below), mean removed.

    Parameters
    ----------
    ch : ChannelSpec
        The channel.
    n : int
        Number of samples.
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        Random source.

    Returns
    -------
    ndarray
        The noise [unit of the channel].
    """
    if ch.coloured == 'ar1':
        a = math.exp(-2.0 * math.pi * ch.coloured_corner / fs)
        e = rng.normal(size=n)
        zi = np.array([a * float(rng.normal())])
        x, _ = lfilter([math.sqrt(1.0 - a * a)], [1.0, -a], e, zi=zi)
        return np.asarray(x, dtype=np.float64) * ch.coloured_level
    if ch.coloured == 'pink':
        spec = np.fft.rfft(rng.normal(size=n))
        f = np.fft.rfftfreq(n, 1.0 / fs)
        spec /= np.sqrt(np.maximum(f, ch.coloured_corner))
        spec[0] = 0.0
        x = np.fft.irfft(spec, n)
        s = float(np.std(x))
        return np.asarray(x / s * ch.coloured_level if s > 0 else x, dtype=np.float64)
    return np.zeros(n)


def hum(ch: ChannelSpec, t: FloatArray) -> FloatArray:
    """Return the mains hum of the channel at times ``t`` [s] (zeros if none).

    Parameters
    ----------
    ch : ChannelSpec
        The channel (``hum_freq`` [Hz], ``hum_amps``, ``hum_phases`` [rad]).
    t : ndarray
        Sample times [s].

    Returns
    -------
    ndarray
        Hum [unit of the channel].
    """
    out = np.zeros_like(t)
    if ch.hum_freq <= 0.0:
        return out
    for h, (a, p) in enumerate(zip(ch.hum_amps, ch.hum_phases, strict=True), start=1):
        if a > 0.0:
            out += a * np.sin(2.0 * math.pi * h * ch.hum_freq * t + p)
    return out


def spikes(ch: ChannelSpec, n: int, rng: np.random.Generator) -> FloatArray:
    """Return the channel's isolated spikes (zeros elsewhere).

    Each of ``ch.spikes`` spikes is 1-3 samples of +-``spike_scale`` x the white noise
    times U(0.5, 1) at a random place.

    Parameters
    ----------
    ch : ChannelSpec
        The channel.
    n : int
        Number of samples.
    rng : numpy.random.Generator
        Random source.

    Returns
    -------
    ndarray
        Spikes [unit of the channel].
    """
    out = np.zeros(n)
    for _ in range(ch.spikes):
        i = int(rng.integers(0, max(n - 3, 1)))
        w = int(rng.integers(1, 4))
        sign = 1.0 if rng.random() < 0.5 else -1.0
        out[i : i + w] = sign * ch.spike_scale * ch.noise * float(rng.uniform(0.5, 1.0))
    return out


def measure(
    filtered: FloatArray, ch: ChannelSpec, t: FloatArray, fs: float, rng: np.random.Generator
) -> tuple[FloatArray, float]:
    """Apply gain, offset and noises to a filtered channel.

    Parameters
    ----------
    filtered : ndarray
        The channel's true value after its lag [unit of the channel].
    ch : ChannelSpec
        The chain.
    t : ndarray
        Sample times (test time) [s].
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        Random source (white, coloured, spikes drawn in this order).

    Returns
    -------
    tuple
        ``(measured, noise_rms)``: the measured channel and the rms of the added
        white + coloured noise + hum (the noise a perfect model leaves) [unit].
    """
    n = filtered.size
    noise = rng.normal(0.0, ch.noise, n)
    noise += coloured_noise(ch, n, fs, rng)
    noise += hum(ch, t)
    out = ch.gain * filtered + ch.offset + noise + spikes(ch, n, rng)
    return out, float(np.sqrt(np.mean(noise * noise)))
