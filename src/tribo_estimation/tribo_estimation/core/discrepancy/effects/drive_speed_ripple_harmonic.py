"""Form ``drive_speed_ripple_harmonic`` of the family ``drive_speed_ripple``.

A drive-speed ripple with its second harmonic:
``w0 += a*sin(2 pi f t + p) + a2*sin(4 pi f t + p2)`` (a, a2 rad/s; f Hz; p, p2 rad;
kernel ``P_RIP_*``, ``P_RIP2_*``): a belt or gear whose disturbance is not a pure sine.
"""

from __future__ import annotations

import math

from ..candidates import SUGGEST_MORE, Candidate, ParamSpec, StartContext, register
from .drive_speed_ripple import CANDIDATE as SINGLE
from .drive_speed_ripple import ripple_starts


def _starts(ctx: StartContext) -> list[dict[str, float]]:
    """Return the single ripple's starts (strongest residual lines), the harmonic at zero."""
    return [{**s, 'ripple2_amp': 0.0, 'ripple2_phase': 0.0} for s in ripple_starts(ctx)]


CANDIDATE = register(
    Candidate(
        'drive_speed_ripple_harmonic',
        'periodic drive speed disturbance with its second harmonic: '
        'w0 = w_nom + a*sin(2 pi f t + p) + a2*sin(4 pi f t + p2)',
        (
            *SINGLE.params,  # the single form's, then the harmonic's
            ParamSpec('ripple2_amp', 'rad/s', 0.0, 100.0, 0.01, 0.0),
            ParamSpec('ripple2_phase', 'rad', -4 * math.pi, 4 * math.pi, 1.0, 0.0),
        ),
        'spectrum',
        _starts,
        demo_effects={
            'ripple_amp': 0.1,
            'ripple_freq': 13.0,
            'ripple_phase': 0.5,
            'ripple2_amp': 0.04,
            'ripple2_phase': 1.0,
        },
        equation=(
            '`w0 += A_r*sin(2 pi f_r t + p) + A_2*sin(4 pi f_r t + p_2)` (A_2, p_2 = '
            '`ripple2_amp`, `ripple2_phase`), the drive angle its integral'
        ),
        suggest=SUGGEST_MORE,
        family='drive_speed_ripple',
    )
)
