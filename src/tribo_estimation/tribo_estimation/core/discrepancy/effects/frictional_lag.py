"""Candidate ``frictional_lag``: friction follows Equ. 8 through a first-order lag.

``tau*mu_l' = mu(|v|) - mu_l`` with ``lag_tau`` = tau [s] (kernel ``P_LAG_TAU``).
"""

from __future__ import annotations

from ..candidates import SUGGEST_SPEED, Candidate, ParamSpec, register

CANDIDATE = register(
    Candidate(
        'frictional_lag',
        'friction follows the Stribeck curve (Equ. 8) with a first-order lag tau',
        (ParamSpec('lag_tau', 's', 2e-4, 0.05, 1.0, 1e-3, log=True),),
        'phase',
        lambda ctx: [{'lag_tau': v} for v in (3e-4, 4e-3)],
        equation=(
            "`tau*mu_l' = mu(|v|) - mu_l` with mu from Equ. 8 (deceleration rule included); "
            'mu_l starts at mu_s at breakaway; `M = F_N*R*sgn(v)*mu_l`'
        ),
        suggest=SUGGEST_SPEED,
    )
)
