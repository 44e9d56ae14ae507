"""Candidate ``torque_offset`` (measurement side): ``M_t += offset + drift*t``.

Offset [N m] and drift [N m/s] of the torsion-moment channel's zero; the dynamics
are unchanged (:func:`tribo_estimation.core.measurement.sensor_offset`).
"""

from __future__ import annotations

import numpy as np

from tribo_estimation.core.measurement import (
    FloatArray,
    MeasurementTransform,
    Segments,
    sensor_offset,
)
from tribo_estimation.core.model import Extensions

from ..candidates import SUGGEST_LONGER, Candidate, ParamSpec, register


class SensorOffset(MeasurementTransform):
    """Zero offset and drift (linear or thermal) of the torsion-moment channel (after the lag)."""

    order = 10
    fields = ('torque_offset', 'torque_offset_drift', 'torque_thermal', 'torque_thermal_tau')

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
        """Add ``offset + drift*t`` to every sample.

        Parameters
        ----------
        ext : Extensions
            Its ``torque_offset`` [N m] and ``torque_offset_drift`` [N m/s].
        time : FloatArray
            Test time per sample [s].
        x : FloatArray
            Torsion moment [N m].
        dt : float
            Sample period [s] (unused).
        segments : Segments
            Contiguous segments (unused: the offset acts on every sample).
        first : FloatArray or None
            Unused (the offset has no state).
        state : float
            Unused.

        Returns
        -------
        FloatArray
            ``x + offset + drift*t`` [N m].
        """
        return sensor_offset(x, time, ext)

    def inverse(
        self, ext: Extensions, t0: FloatArray, value: FloatArray, slope: FloatArray, dt: float
    ) -> tuple[FloatArray, FloatArray]:
        """Subtract the offset and its drift at segment starts.

        Parameters
        ----------
        ext : Extensions
            Its ``torque_offset`` [N m] and ``torque_offset_drift`` [N m/s].
        t0 : FloatArray
            Test time of each start [s].
        value : FloatArray
            Measured torsion moment at each start [N m].
        slope : FloatArray
            Its slope [N m/s].
        dt : float
            Sample period [s] (unused).

        Returns
        -------
        tuple of FloatArray
            Value [N m] and slope [N m/s] without the offset.
        """
        v = value - ext.torque_offset - ext.torque_offset_drift * t0
        s = slope - ext.torque_offset_drift
        if ext.torque_thermal != 0.0 and ext.torque_thermal_tau > 0.0:
            e = np.exp(-np.maximum(t0, 0.0) / ext.torque_thermal_tau)
            v = v - ext.torque_thermal * (1.0 - e)
            s = s - ext.torque_thermal / ext.torque_thermal_tau * e
        return np.asarray(v), np.asarray(s)


CANDIDATE = register(
    Candidate(
        'torque_offset',
        'zero drift of the torsion-moment channel (measurement side): M_t += offset + '
        'drift*t. A constant offset is indistinguishable from a common shift of mu0 and '
        'mu_inf by offset/(F_N*R) (the stick-slip dynamics and the acceleration are the '
        'same), so the baseline absorbs it; only the drift is fitted',
        (ParamSpec('torque_offset_drift', 'N m/s', -1e3, 1e3, 0.01, 0.0),),
        'test_time',
        measurement=SensorOffset(),
        equation=(
            "`M_t,meas = M_t + b + b'*t` (b = `torque_offset` [N m] is not fitted: it cannot be "
            'told apart from a common shift of mu0 and mu_inf by b/(F_N*R))'
        ),
        suggest=SUGGEST_LONGER,
    )
)
