"""Candidate ``dwell_time_stiction``: static friction grows with the stick duration.

``mu_s = mu0 + gain*(1 - exp(-t_stick/tau))`` [-] (t_stick the duration of the
current stick [s]); enters the breakaway test (kernel ``P_ST_GAIN``, ``P_ST_TAU``).
"""

from __future__ import annotations

import numpy as np

from ..candidates import SUGGEST_SPEED, Candidate, ParamSpec, StartContext, register


def stick_time_starts(ctx: StartContext, factors: tuple[float, ...]) -> list[dict[str, float]]:
    """Return ``stiction_tau`` starts at ``factors`` x the baseline's median stick [s].

    The screening holds ``stiction_tau`` fixed at each (``profile``), so the starts
    are the profile of the cost over the family's time scale; none without sticks.
    """
    d = ctx.stick_durations[np.isfinite(ctx.stick_durations)]
    if d.size == 0:
        return []
    med = float(np.median(d))
    return [{'stiction_tau': med * f} for f in factors]


def _starts(ctx: StartContext) -> list[dict[str, float]]:
    """Stiction time constants around the observed stick durations.

    A wide grid (0.1-10 x the baseline's median stick): the baseline's sticks are not
    the record's (its breakaway threshold lacks the effect).
    """
    return stick_time_starts(ctx, (0.1, 0.3, 1.0, 3.0, 10.0))


CANDIDATE = register(
    Candidate(
        'dwell_time_stiction',
        'static friction grows with the preceding stick duration: '
        'mu_s = mu0 + gain*(1 - exp(-t_stick/tau))',
        (
            ParamSpec('stiction_gain', '-', 0.0, 0.5, 0.01, 0.01),
            ParamSpec('stiction_tau', 's', 1e-4, 10.0, 1.0, 0.01, log=True),
        ),
        'preceding_stick_duration',
        _starts,
        equation=(
            '`mu_s = mu0 + g*(1 - exp(-t_stick/tau))` (tau = 0: `mu0 + g`), t_stick the '
            'duration of the current stick [s]; enters the breakaway test (Equ. 6 vs F_N*R*mu_s)'
        ),
        suggest=SUGGEST_SPEED,
        profile='stiction_tau',
    )
)
