"""Candidate ``friction_drift``: mu0, mu_inf drift linearly with test time [1/s]."""

from __future__ import annotations

from ..candidates import SUGGEST_LONGER, Candidate, ParamSpec, register

CANDIDATE = register(
    Candidate(
        'friction_drift',
        'mu0 and mu_inf drift linearly with test time (e.g. thermal)',
        (
            ParamSpec('drift_mu0', '1/s', -0.1, 0.1, 1e-3, 0.0),
            ParamSpec('drift_mu_inf', '1/s', -0.1, 0.1, 1e-3, 0.0),
        ),
        'test_time',
        equation=(
            '`mu0(t) = mu0 + d0*t`, `mu_inf(t) = mu_inf + d_inf*t` (t = test time; '
            'd0 = `drift_mu0`, d_inf = `drift_mu_inf`)'
        ),
        suggest=SUGGEST_LONGER,
    )
)
