"""Candidate ``drive_speed_ripple``: ``w0 += a*sin(2 pi f t + p)`` (a rad/s, f Hz, p rad)."""

from __future__ import annotations

import math

import numpy as np

from ..candidates import SUGGEST_MORE, Candidate, ParamSpec, StartContext, register
from ..stats import fit_sinusoid, spectral_lines


def ripple_starts(ctx: StartContext) -> list[dict[str, float]]:
    """Ripple frequency/amplitude/phase from the strongest lines of the speed residual.

    A drive speed ripple ``w0 = nominal + a*sin(2*pi*f*t + p)`` shows first in
    the shaft speed; the strongest line of the speed residual gives f, and,
    below the belt resonance, about the amplitude and phase.
    """
    out: list[dict[str, float]] = []
    for resid in (ctx.speed, ctx.torque):
        if resid.size == 0 or not np.all(np.isfinite(resid)):
            continue
        for line in spectral_lines(ctx.time, resid, ctx.fs, max_lines=2, min_prominence=10.0):
            f, a, p = fit_sinusoid(ctx.time, ctx.speed, line.frequency)
            amp = a if a > 0 else 0.01 * max(ctx.nominal_speed, 1e-3)
            out.append({'ripple_freq': f, 'ripple_amp': amp, 'ripple_phase': p})
    return out


CANDIDATE = register(
    Candidate(
        'drive_speed_ripple',
        'periodic drive speed disturbance w0 = w_nom + a*sin(2*pi*f*t + p) (f fitted)',
        (
            ParamSpec('ripple_amp', 'rad/s', 0.0, 100.0, 0.01, 0.0),
            ParamSpec('ripple_freq', 'Hz', 0.05, 2000.0, 1.0, 1.0, log=True),
            ParamSpec('ripple_phase', 'rad', -4 * math.pi, 4 * math.pi, 1.0, 0.0),
        ),
        'spectrum',
        ripple_starts,
        equation=(
            '`w0 += A_r*sin(2 pi f_r t + p)`, '
            '`phi0 += A_r/(2 pi f_r)*(cos p - cos(2 pi f_r t + p))` (A_r, f_r, p = `ripple_amp`, '
            '`ripple_freq`, `ripple_phase`)'
        ),
        suggest=SUGGEST_MORE,
    )
)
