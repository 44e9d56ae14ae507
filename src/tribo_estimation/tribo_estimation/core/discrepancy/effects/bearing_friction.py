"""Candidate ``bearing_friction``: Coulomb moment M_b [N m] on the chamber support (Equ. 1)."""

from __future__ import annotations

from ..candidates import SUGGEST_SPEED, Candidate, ParamSpec, StartContext, register


def _starts(ctx: StartContext) -> list[dict[str, float]]:
    """Bearing moments as fractions of the friction moment scale F_N*R*mu [N m]."""
    return [{'bearing_moment': v * ctx.friction_moment_scale} for v in (0.02, 0.1)]


CANDIDATE = register(
    Candidate(
        'bearing_friction',
        'Coulomb friction moment on the test-chamber support: -M_b*sgn(w1) in Equ. 1',
        (ParamSpec('bearing_moment', 'N m', 0.0, 3.0, 0.1, 0.0),),
        'chamber_speed',
        _starts,
        equation=(
            'Equ. 1 gets `- M_b*w1/sqrt(w1^2 + w_reg^2)` (regularised Coulomb moment, '
            'w_reg = 0.01 rad/s; also inside Q1 of Equ. 6)'
        ),
        suggest=SUGGEST_SPEED,
    )
)
