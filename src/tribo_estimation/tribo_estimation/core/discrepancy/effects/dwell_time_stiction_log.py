"""Form ``dwell_time_stiction_log`` of the family ``dwell_time_stiction`` (logarithmic).

``mu_s = mu0 + b*ln(1 + t_stick/t0)`` [-] (the Dieterich form; t_stick the duration
of the current stick [s], t0 [s]); enters the breakaway test (kernel ``P_ST_LOG``,
``P_ST_TAU``).
"""

from __future__ import annotations

from ..candidates import SUGGEST_SPEED, Candidate, ParamSpec, StartContext, register
from .dwell_time_stiction import stick_time_starts


def _starts(ctx: StartContext) -> list[dict[str, float]]:
    """Time scales t0 around the observed stick durations (a profile grid, 0.03-3 x)."""
    return stick_time_starts(ctx, (0.03, 0.1, 0.3, 1.0, 3.0))


CANDIDATE = register(
    Candidate(
        'dwell_time_stiction_log',
        'static friction grows with the logarithm of the stick duration: '
        'mu_s = mu0 + b*ln(1 + t_stick/t0)',
        (
            ParamSpec('stiction_log', '-', 0.0, 0.2, 0.005, 0.005),
            ParamSpec('stiction_tau', 's', 1e-5, 10.0, 1.0, 0.003, log=True),
        ),
        'preceding_stick_duration',
        _starts,
        demo_effects={'stiction_log': 0.01, 'stiction_tau': 0.005},
        equation=(
            '`mu_s = mu0 + b*ln(1 + t_stick/t0)` (b = `stiction_log`, t0 = `stiction_tau`); '
            'enters the breakaway test (Equ. 6 vs F_N*R*mu_s)'
        ),
        suggest=SUGGEST_SPEED,
        profile='stiction_tau',
        family='dwell_time_stiction',
    )
)
