"""Measurement side of the rig model: the transforms of the simulated torsion moment.

The kernel simulates the torsion moment ``C1*phi1`` [N m] as the shaft sees it; an
instrument effect (an offset of the amplifier, a lag of the torque sensor) acts on
the *measured* value only. Each such effect is a :class:`MeasurementTransform`, the
measurement hook of a candidate effect: it is defined in the effect's own module
under :mod:`tribo_estimation.core.discrepancy.effects` and registered with the
effect (``Candidate(..., measurement=...)``). The simulator
(:func:`tribo_estimation.core.simulate.simulate`) and the discrepancy fits call the
two functions here, which apply every registered transform in ``order``:

- :func:`apply_measurement_transforms`: true torsion moment -> measured, per
  contiguous segment (the simulator: one segment carrying the filter state
  ``RigState.sensor_lag`` from chunk to chunk; the segment-wise fits: each segment
  started so that its first output equals the measured value).
- :func:`true_torsion_at_starts`: measured value and slope at segment starts -> the
  true ``C1*phi1`` there (the start states of the segment-wise fits).

Every transform is applied even when its parameters are zero (it then returns its
input unchanged), so an inactive transform costs nothing and the results equal
those of the paper's model.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tribo_estimation.core.model import Extensions
from tribo_estimation.core.signal import iir1

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def sensor_lag(x: FloatArray, dt: float, tau: float, y_prev: float) -> FloatArray:
    """Filter a signal by the first-order lag of the torque sensor (exact discretisation).

    ``y[n] = a*y[n-1] + (1 - a)*x[n]``, ``a = exp(-dt/tau)`` (extension
    ``torque_lag_tau``).

    Parameters
    ----------
    x : FloatArray
        True torsion moment C1*phi1 per sample [N m].
    dt : float
        Sample period [s].
    tau : float
        Lag time constant [s] (> 0).
    y_prev : float
        Sensor output before ``x[0]`` [N m].

    Returns
    -------
    FloatArray
        The sensor output [N m].
    """
    a = math.exp(-dt / tau)
    y, _ = iir1(1.0 - a, 0.0, -a, x, a * y_prev)
    return y


def sensor_offset(x: FloatArray, time: FloatArray, ext: Extensions) -> FloatArray:
    """Add the torque sensor's zero offset and its drift to the torsion output.

    Parameters
    ----------
    x : FloatArray
        Torsion moment [N m].
    time : FloatArray
        Test time of each sample [s].
    ext : Extensions
        Its ``torque_offset`` [N m] and ``torque_offset_drift`` [N m/s] are added, and
        the thermal drift ``torque_thermal*(1 - exp(-t/torque_thermal_tau))`` [N m].

    Returns
    -------
    FloatArray
        ``x`` plus the offsets [N m] (``x`` itself when they are all zero).
    """
    out = x
    if ext.torque_offset != 0.0 or ext.torque_offset_drift != 0.0:
        out = out + ext.torque_offset + ext.torque_offset_drift * time
    if ext.torque_thermal != 0.0 and ext.torque_thermal_tau > 0.0:
        out = out + ext.torque_thermal * -np.expm1(-np.maximum(time, 0.0) / ext.torque_thermal_tau)
    return out


@dataclass(frozen=True)
class Segments:
    """Contiguous stretches of a record a transform works on (sample indices).

    Attributes
    ----------
    start : IntArray
        First sample of each segment.
    stop : IntArray
        One past the last sample of each segment.
    """

    start: IntArray
    stop: IntArray


class MeasurementTransform(ABC):
    """The measurement hook of a candidate effect: it turns true into measured torsion.

    Subclasses set :attr:`order` (application order, lower first: a sensor lag
    before the amplifier offset), :attr:`fields` (the ``Extensions`` fields they
    read) and :attr:`carries_state` (True for the one transform whose output at a
    record's last sample is carried to the next chunk, ``RigState.sensor_lag``).
    """

    #: Application order (lower first).
    order: int = 0
    #: ``Extensions`` fields the transform reads (documentation and discovery).
    fields: tuple[str, ...] = ()
    #: Whether the transform's output at the last sample is the carried sensor state.
    carries_state: bool = False

    @abstractmethod
    def forward(
        self,
        ext: Extensions,
        time: FloatArray,
        x: FloatArray,
        dt: float,
        segments: Segments,
        first: FloatArray | None,
        state: float,
    ) -> FloatArray:
        """Transform the torsion moment of every segment (true -> measured).

        Parameters
        ----------
        ext : Extensions
            Model extension values.
        time : FloatArray
            Test time of every sample [s].
        x : FloatArray
            Input of this transform per sample [N m] (NaN outside the segments).
        dt : float
            Sample period [s].
        segments : Segments
            Contiguous segments to transform.
        first : FloatArray or None
            Wanted output at each segment's first sample [N m] (the measured value
            with the later transforms inverted), or None to start from ``state``.
        state : float
            Carried sensor state [N m] (NaN: not started).

        Returns
        -------
        FloatArray
            The output [N m] (``x`` itself when the transform is inactive).
        """

    @abstractmethod
    def inverse(
        self, ext: Extensions, t0: FloatArray, value: FloatArray, slope: FloatArray, dt: float
    ) -> tuple[FloatArray, FloatArray]:
        """Invert the transform at segment starts (measured -> true).

        Parameters
        ----------
        ext : Extensions
            Model extension values.
        t0 : FloatArray
            Test time of each start [s].
        value : FloatArray
            Output of this transform at each start [N m].
        slope : FloatArray
            Its time derivative there [N m/s].
        dt : float
            Sample period [s].

        Returns
        -------
        tuple of FloatArray
            Input value [N m] and slope [N m/s] at each start.
        """


_TRANSFORMS: dict[str, MeasurementTransform] = {}


def register_transform(name: str, transform: MeasurementTransform | None) -> None:
    """Register (or, with None, drop) the measurement hook of the candidate effect ``name``.

    Parameters
    ----------
    name : str
        The candidate's name.
    transform : MeasurementTransform or None
        Its measurement transform; None for an effect on the dynamics only.
    """
    if transform is None:
        _TRANSFORMS.pop(name, None)
    else:
        _TRANSFORMS[name] = transform


def measurement_transforms() -> tuple[MeasurementTransform, ...]:
    """Return every registered measurement transform, in application order.

    Importing the candidate library registers the effects' transforms; it is
    imported here on first use (not at module level: the library imports the
    simulator, which imports this module).

    Returns
    -------
    tuple of MeasurementTransform
        Sorted by :attr:`MeasurementTransform.order`.
    """
    from tribo_estimation.core.discrepancy import candidates  # noqa: F401  (registers)

    return tuple(sorted(_TRANSFORMS.values(), key=lambda tr: tr.order))


def measurement_fields() -> frozenset[str]:
    """Return the ``Extensions`` fields that act on the measurement, not the dynamics.

    Returns
    -------
    frozenset of str
        Union of the registered transforms' :attr:`MeasurementTransform.fields`.
    """
    return frozenset(f for tr in measurement_transforms() for f in tr.fields)


def apply_measurement_transforms(
    ext: Extensions,
    time: FloatArray,
    torsion: FloatArray,
    dt: float,
    *,
    segments: tuple[IntArray, IntArray] | None = None,
    measured_first: FloatArray | None = None,
    state: float = math.nan,
) -> tuple[FloatArray, float]:
    """Turn the simulated (true) torsion moment into the measured one.

    Parameters
    ----------
    ext : Extensions
        Model extension values.
    time : FloatArray
        Test time of every sample [s].
    torsion : FloatArray
        True torsion moment C1*phi1 per sample [N m] (NaN outside the segments).
    dt : float
        Sample period [s].
    segments : tuple of IntArray, optional
        (start, stop) sample indices of the contiguous segments; default: the
        whole record as one segment.
    measured_first : FloatArray, optional
        Measured torsion moment at each segment's first sample [N m]: each segment
        is started so that its first output equals it. Default: start from
        ``state``.
    state : float
        Carried sensor state [N m] (``RigState.sensor_lag``; NaN: not started).

    Returns
    -------
    tuple
        Measured torsion moment [N m] and the new sensor state [N m].
    """
    if segments is None:
        seg = Segments(np.zeros(1, dtype=np.int64), np.full(1, torsion.size, dtype=np.int64))
    else:
        seg = Segments(np.asarray(segments[0]), np.asarray(segments[1]))
    chain = measurement_transforms()
    # wanted output of each transform at the segment starts: the measured value with
    # the later transforms inverted
    firsts: list[FloatArray | None] = [None] * len(chain)
    if measured_first is not None:
        t0 = time[seg.start]
        value = measured_first
        slope = np.zeros_like(value)
        for i in range(len(chain) - 1, -1, -1):
            firsts[i] = value
            value, slope = chain[i].inverse(ext, t0, value, slope, dt)
    y = torsion
    for tr, first in zip(chain, firsts, strict=True):
        y = tr.forward(ext, time, y, dt, seg, first, state)
        if tr.carries_state:
            state = float(y[-1])
    return y, state


def true_torsion_at_starts(
    ext: Extensions, t0: FloatArray, measured: FloatArray, slope: FloatArray, dt: float
) -> FloatArray:
    """Return the true torsion moment C1*phi1 at segment starts from the measured one.

    Parameters
    ----------
    ext : Extensions
        Model extension values.
    t0 : FloatArray
        Test time of each start [s].
    measured : FloatArray
        Measured torsion moment there [N m].
    slope : FloatArray
        Its time derivative there [N m/s].
    dt : float
        Sample period [s].

    Returns
    -------
    FloatArray
        C1*phi1 at each start [N m].
    """
    value = measured
    for tr in reversed(measurement_transforms()):
        value, slope = tr.inverse(ext, t0, value, slope, dt)
    return value
