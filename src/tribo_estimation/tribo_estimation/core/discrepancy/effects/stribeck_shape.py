"""Candidate ``stribeck_shape``: the shape exponent of the Stribeck curve.

Generalises Equ. 8 to ``mu = (mu0 - mu_inf)*exp(-(k*|v|)**delta) + mu_inf``
[-] (v slip speed [rad/s], k [s/rad]); ``delta = 1`` is Equ. 8. The fitted
``Extensions`` field is the kernel's generic friction-shape hook
``stribeck_shape = delta - 1`` [-] (nested: 0 gives the paper's model). A
delta below 1 makes the friction fall faster right after breakaway and level
off later, so its residual shows against the slip speed.
"""

from __future__ import annotations

from ..candidates import SUGGEST_MORE, Candidate, ParamSpec, StartContext, register


def _starts(_ctx: StartContext) -> list[dict[str, float]]:
    """Exponents either side of Equ. 8 (delta = 0.5 and 2)."""
    return [{'stribeck_shape': v} for v in (-0.5, 1.0)]


CANDIDATE = register(
    Candidate(
        'stribeck_shape',
        'shape exponent delta of the Stribeck curve: '
        'mu = (mu0 - mu_inf)*exp(-(k|v|)^delta) + mu_inf, fitted as stribeck_shape = '
        'delta - 1 (0: Equ. 8)',
        (ParamSpec('stribeck_shape', '-', -0.8, 2.0, 0.1, 0.0),),
        'slip_speed',
        _starts,
        demo_effects={'stribeck_shape': -0.4},
        equation=(
            '`mu = (mu0 - mu_inf)*exp(-(k|v|)^delta) + mu_inf`, delta = 1 + `stribeck_shape` '
            '(0: Equ. 8; kernel shape hook P_SHAPE)'
        ),
        suggest=SUGGEST_MORE,
    )
)
