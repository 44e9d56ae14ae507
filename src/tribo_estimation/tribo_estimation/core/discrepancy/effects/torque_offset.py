"""Candidate ``torque_offset`` (measurement side): ``M_t += offset + drift*t``."""

from __future__ import annotations

from ..candidates import Candidate, ParamSpec, register

CANDIDATE = register(
    Candidate(
        'torque_offset',
        'zero drift of the torsion-moment channel (measurement side): M_t += offset + '
        'drift*t. A constant offset is indistinguishable from a common shift of mu0 and '
        'mu_inf by offset/(F_N*R) (the stick-slip dynamics and the acceleration are the '
        'same), so the baseline absorbs it; only the drift is fitted',
        (ParamSpec('torque_offset_drift', 'N m/s', -1e3, 1e3, 0.01, 0.0),),
        'test_time',
    )
)
