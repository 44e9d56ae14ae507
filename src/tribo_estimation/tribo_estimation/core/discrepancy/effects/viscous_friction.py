"""Candidate ``viscous_friction``: ``M += c_v*v`` with ``viscous`` = c_v [N m s/rad]."""

from __future__ import annotations

from ..candidates import SUGGEST_SPEED, Candidate, ParamSpec, register

CANDIDATE = register(
    Candidate(
        'viscous_friction',
        'a friction moment proportional to the slip speed: M += c_v*v',
        (ParamSpec('viscous', 'N m s/rad', 0.0, 100.0, 1.0, 0.0),),
        'slip_speed',
        equation=('`M = F_N*R*sgn(v)*mu + c_v*v` (Equ. 3 plus c_v = `viscous`)'),
        suggest=SUGGEST_SPEED,
    )
)
