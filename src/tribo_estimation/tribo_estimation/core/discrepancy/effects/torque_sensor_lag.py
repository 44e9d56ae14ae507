"""Candidate ``torque_sensor_lag`` (measurement side): first-order lag tau_s [s]."""

from __future__ import annotations

from ..candidates import Candidate, ParamSpec, register

CANDIDATE = register(
    Candidate(
        'torque_sensor_lag',
        'first-order lag of the torsion-moment amplifier (measurement side)',
        (ParamSpec('torque_lag_tau', 's', 1e-6, 0.05, 1.0, 1e-4, log=True),),
        'breakaway',
        lambda ctx: [{'torque_lag_tau': v} for v in (1e-5, 1e-3)],
    )
)
