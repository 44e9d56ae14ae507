"""The record's measured noise: the white level of each channel.

The decisions of the workflow compare a model's residual with what noise alone
leaves (:mod:`.null`). The noise is measured on the model's residual, whose signal
the model has removed: the robust second-difference level of each channel (torsion
moment [N m], chamber acceleration [rad/s^2], shaft speed [rad/s];
:func:`tribo_estimation.core.signal.noise_level`), which a mismatch, smooth or
sparse at the sample rate, does not move. Coloured sensor noise cannot be told from
a slow mismatch without a model of either: it is not measured (docs/physics.md,
section 8).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.signal import noise_level

FloatArray = npt.NDArray[np.float64]

#: The raw channels, in the order of :meth:`NoiseModel.draw`.
RAW_CHANNELS: tuple[str, str, str] = ('torsion_moment', 'angular_acceleration', 'speed')


@dataclass(frozen=True)
class ChannelNoise:
    """White noise of one channel.

    Parameters
    ----------
    white : float
        Its standard deviation [unit of the channel].
    """

    white: float

    @property
    def total(self) -> float:
        """Standard deviation of the noise [unit]."""
        return self.white

    def draw(self, rng: np.random.Generator, n: int, dt: float) -> FloatArray:
        """Draw ``n`` samples at interval ``dt`` [s] (white: ``dt`` does not matter).

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
        del dt
        if self.white > 0.0:
            return np.asarray(rng.normal(0.0, self.white, n), dtype=np.float64)
        return np.zeros(n)


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
    """

    torsion_moment: ChannelNoise
    angular_acceleration: ChannelNoise
    speed: ChannelNoise

    def channel(self, name: str) -> ChannelNoise:
        """Return the noise of a raw channel by name (one of :data:`RAW_CHANNELS`)."""
        out: ChannelNoise = getattr(self, name)
        return out

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form (per channel: its white noise [unit])."""
        return {c: {'white': self.channel(c).white} for c in RAW_CHANNELS}


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


__all__ = ['RAW_CHANNELS', 'ChannelNoise', 'NoiseModel', 'measure_noise']
