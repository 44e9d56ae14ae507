"""Where do simulation and measurement disagree? Localising statistics of a residual.

Given a :class:`~.fitting.Problem` (record + segments) and a simulation of a
model on it, the torsion-moment residual r = measured - simulated (N m) is
summarised: by motion phase (stick / slip accelerating / slip decelerating,
from the simulated slip speed and stick flag; paper Equ. 3-8 with the
deceleration rule), around breakaway, against slip speed, the preceding stick
duration, test time, shaft angle and chamber speed, and in frequency
(spectral lines). Also used to build the localising variables of the plots.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tribo_estimation.core.signal import running_integral

from .fitting import Problem, SimulatedRecord
from .stats import (
    PHASE_NAMES,
    BinnedResidual,
    FloatArray,
    angle_dependence,
    binned,
    noise_floor,
    phase_labels,
    phase_rms,
    preceding_stick_duration,
    rms,
    spectral_lines,
    time_since_breakaway,
    trend,
)

#: Units of the localising variables.
VARIABLE_UNITS: dict[str, str] = {
    'preceding_stick_duration': 's',
    'phase': '-',
    'slip_speed': 'rad/s',
    'test_time': 's',
    'breakaway': 's',
    'chamber_speed': 'rad/s',
    'shaft_angle': 'rad',
    'spectrum': 'Hz',
}


def shaft_angle(problem: Problem) -> FloatArray:
    """Measured shaft angle modulo 2 pi [rad] (integral of the measured speed w2)."""
    rec = problem.record
    ang = running_integral(rec.speed, rec.dt)
    return np.mod(ang, 2.0 * math.pi)


def variable(name: str, problem: Problem, sim: SimulatedRecord) -> FloatArray:
    """Values of a localising variable at every sample (NaN where undefined).

    ``phase`` gives the phase code (0 stick, 1 slip accelerating, 2 slip
    decelerating); ``spectrum`` is not a per-sample variable (test time is
    returned instead).
    """
    fs = problem.record.fs
    stick = np.nan_to_num(sim.stick, nan=1.0) > 0.5
    if name == 'preceding_stick_duration':
        return preceding_stick_duration(stick, fs)
    if name == 'phase':
        return phase_labels(np.nan_to_num(sim.slip_speed), stick).astype(np.float64)
    if name == 'slip_speed':
        v = np.abs(sim.slip_speed).astype(np.float64)
        return np.where(stick, np.nan, v)
    if name == 'breakaway':
        return time_since_breakaway(stick, fs)
    if name == 'chamber_speed':
        return np.asarray(sim.chamber_speed, dtype=np.float64)
    if name == 'shaft_angle':
        return shaft_angle(problem)
    return np.asarray(problem.record.time, dtype=np.float64)


def torque_residual(problem: Problem, sim: SimulatedRecord) -> FloatArray:
    """Torsion-moment residual measured - simulated [N m] (NaN off the segments)."""
    return np.where(sim.covered, problem.record.torsion_moment - sim.torsion_moment, np.nan)


def binned_for(name: str, problem: Problem, sim: SimulatedRecord, r: FloatArray) -> BinnedResidual:
    """Residual ``r`` binned against the localising variable ``name``."""
    x = variable(name, problem, sim)
    unit = VARIABLE_UNITS.get(name, '-')
    if name == 'phase':
        return binned(x, r, name=name, unit=unit, bins=np.array([-0.5, 0.5, 1.5, 2.5]))
    if name == 'breakaway':
        edges = np.linspace(-0.01, 0.02, 16)
        return binned(x, r, name=name, unit=unit, bins=edges)
    if name == 'shaft_angle':
        return binned(x, r, name=name, unit=unit, bins=np.linspace(0, 2 * math.pi, 13))
    return binned(x, r, name=name, unit=unit, bins=12)


def localise(problem: Problem, sim: SimulatedRecord) -> dict[str, object]:
    """Localising statistics of the torsion-moment residual (JSON-ready, N m)."""
    rec = problem.record
    r_full = torque_residual(problem, sim)
    cov = sim.covered
    r = r_full[cov]
    t = rec.time[cov]
    stick = np.nan_to_num(sim.stick, nan=1.0) > 0.5
    labels = phase_labels(np.nan_to_num(sim.slip_speed), stick)
    tb = time_since_breakaway(stick, rec.fs)
    near = cov & np.isfinite(tb) & (np.abs(tb) <= 5e-3)
    far = cov & ~near
    sigma = noise_floor(r)
    lines = spectral_lines(t, r, rec.fs, max_lines=5)
    tr = trend(t, r)
    ang = angle_dependence(shaft_angle(problem)[cov], r)
    out: dict[str, Any] = {
        'rms': rms(r),
        'mean': float(np.mean(r)),
        'noise_floor': sigma,
        'channels_rms': {
            c: rms(problem.measured(c)[cov] - sim.channel(c)[cov])
            for c in ('torsion_moment', 'chamber_speed', 'speed')
        },
        'by_phase': phase_rms(r_full[cov], labels[cov]),
        'phase_fraction': {
            name: float(np.mean(labels[cov] == code)) for code, name in enumerate(PHASE_NAMES)
        },
        'breakaway': {'within_5ms_rms': rms(r_full[near]), 'elsewhere_rms': rms(r_full[far])},
        'trend': {'slope': tr.slope, 'change': tr.change, 't_stat': tr.t_stat},
        'shaft_angle': {'amplitude': ang.amplitude, 'order': ang.order, 'phase': ang.phase},
        'spectral_lines': [
            {'frequency': ln.frequency, 'amplitude': ln.amplitude, 'prominence': ln.prominence}
            for ln in lines
        ],
    }
    for name in ('slip_speed', 'preceding_stick_duration', 'test_time', 'chamber_speed'):
        out[f'vs_{name}'] = binned_for(name, problem, sim, r_full).as_dict()
    return out
