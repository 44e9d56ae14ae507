"""Form ``drive_speed_ripple_angle_harmonic`` of the family ``drive_speed_ripple``.

The ripple locked to the drive angle with its second harmonic:
``w0 = w_n*(1 + r*sin(n*theta + p) + r2*sin(2n*theta + p2))`` (r, r2 [-]; n per
revolution [-]; p, p2 [rad]; kernel ``P_RIPA_*``, ``P_RIPA2_*``): a gear mesh or an
eccentric pulley whose disturbance per turn is not a pure sine.
"""

from __future__ import annotations

import math

from ..candidates import SUGGEST_MORE, Candidate, ParamSpec, StartContext, register
from .drive_speed_ripple_angle import CANDIDATE as SINGLE
from .drive_speed_ripple_angle import angle_starts


def _starts(ctx: StartContext) -> list[dict[str, float]]:
    """Return the angle-locked ripple's starts with the speed residual's second harmonic.

    Started at zero amplitude the harmonic's phase would have no gradient.
    """
    return angle_starts(ctx, harmonic=True)


CANDIDATE = register(
    Candidate(
        'drive_speed_ripple_angle_harmonic',
        'drive speed ripple locked to the drive angle with its second harmonic: '
        'w0 = w_n*(1 + r*sin(n*theta + p) + r2*sin(2n*theta + p2))',
        (
            *SINGLE.params,  # the single form's, then the harmonic's
            ParamSpec('ripple2_rel', '-', 0.0, 0.5, 0.01, 0.0),
            ParamSpec('ripple2_angle_phase', 'rad', -4 * math.pi, 4 * math.pi, 1.0, 0.0),
        ),
        'spectrum',
        _starts,
        demo_effects={
            'ripple_rel': 0.03,
            'ripple_order': 6.0,
            'ripple_angle_phase': 0.5,
            'ripple2_rel': 0.012,
            'ripple2_angle_phase': 1.0,
        },
        equation=(
            '`w0 = w_n*(1 + r*sin(n theta + p) + r_2*sin(2n theta + p_2))` (r_2, p_2 = '
            '`ripple2_rel`, `ripple2_angle_phase`), the drive angle its integral'
        ),
        suggest=SUGGEST_MORE,
        family='drive_speed_ripple',
    )
)
