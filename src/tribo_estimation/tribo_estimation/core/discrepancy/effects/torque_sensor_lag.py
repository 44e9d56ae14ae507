"""Candidate ``torque_sensor_lag`` (measurement side): first-order lag tau_s [s].

The torque sensor's output follows the true torsion moment ``C1*phi1`` through
``tau_s*y' = C1*phi1 - y`` (exact discretisation
:func:`tribo_estimation.core.measurement.sensor_lag`); the dynamics are unchanged.
"""

from __future__ import annotations

import math

import numpy as np

from tribo_estimation.core.measurement import (
    FloatArray,
    MeasurementTransform,
    Segments,
    sensor_lag,
)
from tribo_estimation.core.model import Extensions

from ..candidates import SUGGEST_MORE, Candidate, ParamSpec, register


class SensorLag(MeasurementTransform):
    """First-order lag of the torsion-moment amplifier (``torque_lag_tau`` [s])."""

    order = 0
    fields = ('torque_lag_tau',)
    carries_state = True

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
        """Lag every segment; start it from ``first`` (output there) or the state.

        Parameters
        ----------
        ext : Extensions
            Its ``torque_lag_tau`` [s] (0: no lag).
        time : FloatArray
            Test time per sample [s] (unused).
        x : FloatArray
            True torsion moment [N m].
        dt : float
            Sample period [s].
        segments : Segments
            Contiguous segments.
        first : FloatArray or None
            Wanted output at each segment's first sample [N m], or None.
        state : float
            Sensor output before the first sample [N m] (NaN: start at ``x[0]``).

        Returns
        -------
        FloatArray
            The lagged torsion moment [N m].
        """
        tau = ext.torque_lag_tau
        if not tau > 0.0:
            return x
        y = x.copy()
        a = math.exp(-dt / tau)
        for k, (i0, i1) in enumerate(zip(segments.start, segments.stop, strict=True)):
            if first is not None:
                # filter state chosen so that the first output equals the wanted value:
                # y0 = a*y_prev + (1 - a)*x0
                y_prev = (first[k] - (1.0 - a) * x[i0]) / a
            else:
                y_prev = float(x[i0]) if not math.isfinite(state) else state
            y[i0:i1] = sensor_lag(x[i0:i1], dt, tau, y_prev)
        return y

    def inverse(
        self, ext: Extensions, t0: FloatArray, value: FloatArray, slope: FloatArray, dt: float
    ) -> tuple[FloatArray, FloatArray]:
        """Undo the lag at segment starts from the measured value and slope.

        The discrete filter lags a ramp of slope S by ``S*dt*a/(1 - a)``
        (-> S*tau for dt << tau), ``a = exp(-dt/tau)``.

        Parameters
        ----------
        ext : Extensions
            Its ``torque_lag_tau`` [s].
        t0 : FloatArray
            Test time of each start [s] (unused).
        value : FloatArray
            Lagged torsion moment at each start [N m].
        slope : FloatArray
            Its slope [N m/s].
        dt : float
            Sample period [s].

        Returns
        -------
        tuple of FloatArray
            True torsion moment [N m] and slope [N m/s] at each start.
        """
        lag_eff = 0.0
        if ext.torque_lag_tau > 0.0:
            a_l = math.exp(-dt / ext.torque_lag_tau)
            lag_eff = dt * a_l / (1.0 - a_l)
        return np.asarray(value + lag_eff * slope), slope


CANDIDATE = register(
    Candidate(
        'torque_sensor_lag',
        'first-order lag of the torsion-moment amplifier (measurement side)',
        (ParamSpec('torque_lag_tau', 's', 1e-6, 0.05, 1.0, 1e-4, log=True),),
        'breakaway',
        lambda ctx: [{'torque_lag_tau': v} for v in (1e-5, 1e-3)],
        measurement=SensorLag(),
        equation=(
            "`tau_s*y' + y = M_t`, exact discretisation "
            '`y[n] = e^(-dt/tau_s)*y[n-1] + (1 - e^(-dt/tau_s))*M_t[n]`'
        ),
        suggest=SUGGEST_MORE,
    )
)
