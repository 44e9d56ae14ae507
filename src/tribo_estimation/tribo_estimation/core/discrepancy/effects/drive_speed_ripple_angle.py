"""Form ``drive_speed_ripple_angle`` of the family ``drive_speed_ripple``.

A drive-speed ripple locked to the drive angle theta rather than to time:
``w0 = w_n*(1 + r*sin(n*theta + p))`` (r [-], n per revolution [-], p [rad]; kernel
``P_RIPA_*``). A gear mesh, a coupling's misalignment or a pulley out of round
modulates the speed once or n times per turn: its frequency follows the drive
speed through steps, sweeps and stops, where a ripple at one frequency in time
cannot follow.
"""

from __future__ import annotations

import math

import numpy as np

from ..candidates import SUGGEST_MORE, Candidate, ParamSpec, StartContext, register
from ..stats import fit_sinusoid, spectral_lines

#: Fewest drive revolutions the order search looks at [-]: a line needs a few
#: periods in the record to stand out of the periodogram.
_MIN_TURNS = 0.5


def angle_starts(ctx: StartContext, *, harmonic: bool = False) -> list[dict[str, float]]:
    """Orders, relative amplitudes and phases from the residuals' lines over the drive angle.

    The residuals are resampled on an even grid of the drive angle (where the drive
    turns: above a tenth of its level); a line there at ``f`` cycles per radian is the
    order ``n = 2*pi*f`` per revolution. The speed residual's sinusoid over the angle
    gives the amplitude, relative to the drive level, and the phase; with
    ``harmonic`` its sinusoid at ``2n`` those of the second harmonic
    (``ripple2_rel``, ``ripple2_angle_phase``).
    """
    theta = np.asarray(ctx.drive_angle, dtype=np.float64)
    level = abs(ctx.nominal_speed)
    if theta.size < 256 or not np.all(np.isfinite(theta)) or level <= 0.0:
        return []
    rate = np.gradient(theta, ctx.time)
    turning = rate > 0.1 * level
    if np.count_nonzero(turning) < 256:
        return []
    th = theta[turning]
    span = float(th[-1] - th[0])
    if span < _MIN_TURNS * 2.0 * math.pi or np.any(np.diff(th) <= 0.0):
        return []
    grid = np.linspace(float(th[0]), float(th[-1]), th.size)
    per_rad = (th.size - 1) / span  # grid points per radian
    on_grid = {
        name: np.interp(grid, th, resid[turning])
        for name, resid in (('speed', ctx.speed), ('torque', ctx.torque))
        if resid.size == theta.size and np.all(np.isfinite(resid))
    }
    speed = on_grid.get('speed')
    if speed is None:
        return []
    out: list[dict[str, float]] = []
    for residual in on_grid.values():
        for line in spectral_lines(grid, residual, per_rad, max_lines=2, min_prominence=10.0,
                                   fmin=0.0):  # fmt: skip
            f, a, p = fit_sinusoid(grid, speed, line.frequency)
            rel = a / level if a > 0 else 0.01
            start = {'ripple_rel': rel, 'ripple_order': 2.0 * math.pi * f,
                     'ripple_angle_phase': p}  # fmt: skip
            if harmonic:
                _, a2, p2 = fit_sinusoid(grid, speed, 2.0 * f)
                start |= {'ripple2_rel': a2 / level, 'ripple2_angle_phase': p2}
            out.append(start)
    return out


CANDIDATE = register(
    Candidate(
        'drive_speed_ripple_angle',
        'drive speed ripple locked to the drive angle: w0 = w_n*(1 + r*sin(n*theta + p)), '
        'n per revolution',
        (
            ParamSpec('ripple_rel', '-', 0.0, 0.5, 0.01, 0.0),
            ParamSpec('ripple_order', '-', 0.2, 500.0, 1.0, 1.0, log=True),
            ParamSpec('ripple_angle_phase', 'rad', -4 * math.pi, 4 * math.pi, 1.0, 0.0),
        ),
        'spectrum',
        angle_starts,
        demo_effects={'ripple_rel': 0.03, 'ripple_order': 6.0, 'ripple_angle_phase': 0.5},
        equation=(
            '`w0 = w_n*(1 + r*sin(n theta + p))`, `phi0 += r/n*(cos p - cos(n theta + p))` '
            '(r, n, p = `ripple_rel`, `ripple_order`, `ripple_angle_phase`; theta the '
            "ripple-free drive angle from the profile's first knot, w_n its speed)"
        ),
        suggest=SUGGEST_MORE,
        family='drive_speed_ripple',
    )
)
