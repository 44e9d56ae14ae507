"""Oil-circuit transport model: why early nVCT readings oscillate (paper 3.3/3.5).

Wear particles leave the contact, travel with the oil (about 60-70 ml, no
filter, no deposits in the paper's circuit) and pass the detector once per
circulation. Until the oil is mixed, a released batch passes the detector as a
slug, so the reading over- and undershoots with the circulation period.

Model (closed loop, plug flow with axial dispersion): a unit activity released
at time 0 reaches the detector first after ``transit = transit_fraction * T_c``
and again every circulation time T_c; pass n (n = 0, 1, ...) is a Gaussian
pulse of width sigma_n^2 = sigma_0^2 + n*s^2 (s = dispersion_fraction*T_c).
k_DET is calibrated for the activity of the *mixed* circuit, so the reading
relative to the mixed state is

    R(t) = exp(-k_dep t) * sum_n T_c * N(t; transit + n T_c, sigma_n)

(R -> exp(-k_dep t) once mixed; each pulse carries area T_c since the whole
batch passes the detector once per circulation). The detector reading is the
release history convolved with R. Deposition (first order, rate k_dep [1/s])
is optional; the paper found none.

Corrections offered: readings before ``mixing_time`` (|R - 1| above the
tolerance) are flagged ``not_mixed`` and excluded from fits; the mean delay
``lag`` of the mixed reading behind the release is subtracted from the time
axis in the evaluation; with deposition the released activity is rebuilt as
A_rel(t) = A_det(t) + k_dep * integral_0^t A_det.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tribo_nvct.errors import NvctConfigError

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class OilCircuit:
    """Transport parameters of the oil circuit.

    circulation_time: T_c = V_oil / Q [s] (> 0);
    transit_fraction: contact-to-detector delay / T_c [-] in (0, 1];
    first_width_fraction: width of the first pass / T_c [-] (>= 0);
    dispersion_fraction: width added per pass (std) / T_c [-] (> 0);
    deposition_rate: first-order loss of particles to walls [1/s] (>= 0);
    mixing_tolerance: |R - 1| below which the oil counts as mixed [-].
    """

    circulation_time: float
    transit_fraction: float = 0.3
    first_width_fraction: float = 0.05
    dispersion_fraction: float = 0.2
    deposition_rate: float = 0.0
    mixing_tolerance: float = 0.05

    def __post_init__(self) -> None:
        """Refuse a circulation time [s] or a fraction outside its range."""
        checks = (
            ('circulation_time_s', self.circulation_time, 0.0, math.inf, False),
            ('transit_fraction', self.transit_fraction, 0.0, 1.0, False),
            ('first_width_fraction', self.first_width_fraction, 0.0, 10.0, True),
            ('dispersion_fraction', self.dispersion_fraction, 0.0, 10.0, False),
            ('deposition_rate_per_s', self.deposition_rate, 0.0, 1.0, True),
            ('mixing_tolerance', self.mixing_tolerance, 0.0, 1.0, False),
        )
        for name, v, lo, hi, closed in checks:
            ok = math.isfinite(v) and (v >= lo if closed else v > lo) and v <= hi
            if not ok:
                raise NvctConfigError(f'oil circuit: {name} out of range: {v!r}')

    @property
    def transit(self) -> float:
        """Delay contact -> detector [s]."""
        return self.transit_fraction * self.circulation_time

    def _widths(self, n: FloatArray) -> FloatArray:
        T = self.circulation_time
        return np.sqrt(
            (self.first_width_fraction * T) ** 2 + n * (self.dispersion_fraction * T) ** 2
        )

    def response(self, t: FloatArray) -> FloatArray:
        """R(t): detector reading per unit released activity relative to mixed [-]."""
        t = np.asarray(t, dtype=float)
        T = self.circulation_time
        n_max = int(np.max(t, initial=0.0) / T) + 8
        n = np.arange(n_max + 1, dtype=float)
        mu = self.transit + n * T
        sig = self._widths(n)
        # Far out, the pulses overlap into the mixed level 1: sum them exactly
        # while they matter and continue with 1 beyond the last one summed.
        z = (t[..., None] - mu) / sig
        pulses = T * np.exp(-0.5 * z * z) / (math.sqrt(2.0 * math.pi) * sig)
        R = pulses.sum(axis=-1)
        # Mass not yet reached by the summed pulses (t beyond mu_max) -> mixed level.
        tail = t > mu[-1] - 3.0 * sig[-1]
        R = np.where(tail, 1.0, R)
        R = np.where(t < 0.0, 0.0, R)
        return R * np.exp(-self.deposition_rate * np.clip(t, 0.0, None))

    @property
    def mixing_time(self) -> float:
        """First time after which |R/exp(-k_dep t) - 1| stays below the tolerance [s]."""
        T = self.circulation_time
        # Ripple of the pulse train: 2*exp(-2 pi^2 sigma_n^2 / T^2) <= tol (Poisson summation).
        tol = self.mixing_tolerance
        s1 = self.first_width_fraction
        s = self.dispersion_fraction
        need = math.log(2.0 / tol) / (2.0 * math.pi**2)  # required (sigma/T)^2
        n = max(0.0, (need - s1 * s1) / (s * s))
        # After pass n the deviation of the mixed reading is within tol; add the first
        # pass delay and one circulation for the pulse to go by.
        return self.transit + (math.ceil(n) + 1.0) * T

    @property
    def lag(self) -> float:
        """Mean delay of the mixed reading behind the release [s]: t - integral_0^t R."""
        # Each pulse (area T) arrives at transit + n T: the integral of the pulse
        # train trails the unit ramp by transit - T/2 on average; the growing width
        # (d sigma^2/dn = s^2) shifts the running sum of the Gaussian CDFs by a further
        # -s^2/(2T) (Euler-Maclaurin). May be negative (the first slug arrives early).
        T = self.circulation_time
        return self.transit - 0.5 * T - 0.5 * self.dispersion_fraction**2 * T

    def detector_activity(self, t: FloatArray, released: FloatArray) -> FloatArray:
        """Compute the reading A_det(t) [Bq] of a released-activity history on a grid ``t`` [s].

        ``released`` is the cumulative released activity A_rel(t) [Bq] with A_rel(0) = 0.
        Convolution A_det = dA_rel * R (discrete, exact for piecewise-constant release rate).
        """
        t = np.asarray(t, dtype=float)
        dt = float(t[1] - t[0])
        if not np.allclose(np.diff(t), dt, rtol=1e-9, atol=1e-12):
            raise NvctConfigError('detector_activity needs a uniform time grid')
        dA = np.diff(np.concatenate([[0.0], np.asarray(released, dtype=float)]))
        R = self.response(t - t[0] + 0.5 * dt)
        from scipy.signal import fftconvolve

        return np.asarray(fftconvolve(dA, R)[: t.size])


def rebuild_released(activity: FloatArray, dt: FloatArray, deposition_rate: float) -> FloatArray:
    """Released activity from mixed readings with first-order deposition [Bq].

    A_rel(t_i) = A_det(t_i) + k_dep * sum_{j<=i} A_det(t_j) dt_j (dt: dwell lengths [s]).
    """
    if deposition_rate == 0.0:
        return np.asarray(activity, dtype=float)
    return np.asarray(activity) + deposition_rate * np.cumsum(np.asarray(activity) * dt)
