"""The project's one stick detector and motion-type classification (measured signals).

Signals: torsion moment ``M_t = C1*phi1`` [N m], chamber acceleration ``a`` [rad/s^2],
shaft speed ``w2`` [rad/s], uniformly sampled. The detector is insensitive to the
speed channel's dynamics (a tachometer lag of several ms): the speed channel sets
the drive-speed level for the first pass and, its lag fitted and inverted, tells a
stick (shaft speed = chamber speed) from the slow end of a slip (step 3).

Criterion. While the discs stick, chamber and shaft move as one body, so Equ. 1 +
Equ. 2 with ``w1 = w2 = w`` and the constant angle difference ``phi2 - phi1`` give
the *stick residual*

    r = (I1 + I2)*a + (K1 + K2)*w + (C1 + C2)*M_t/C1 = K2*w0 + C2*phi0(t) - C2*(phi2 - phi1)

which is a straight line in time with slope ``C2*w0`` (plus ``K2*w0'``). Here ``w``
is the integral of the measured acceleration (:func:`chamber_speed_integral`: the
chamber speed up to a constant, which only shifts each stick's line), never the
speed channel. In general ``r`` = stick line ``- C2*int(v) - I2*v' - K2*v`` with the
slip speed ``v = w2 - w1``.

1. Candidates: the slope of ``r`` over 9 samples gives the slip speed estimate
   ``v ~ w0 - r'/C2``; candidates are the runs with ``|v|`` below 0.4 rad/s (or six
   noise levels of the estimate). ``w0`` is, in a first pass, the shaft speed's
   50 ms moving mean (a lag does not change the mean of a constant speed), in a
   second pass the slopes of the stick lines found by the first (exact through
   start-up ramps and speed steps, free of any speed-channel lag and of a torsion
   gain error).
2. Boundaries: the line (a parabola on longer sticks when its curvature is
   significant) is fitted on the inside of each candidate and the stick grown or
   shrunk to the samples whose residual stays within ``n_sigma`` noise levels of it
   (one sample outside is noise, two in a row end the stick). Sliding friction
   differs from the stick moment, so ``r`` leaves the line by a jump at the stick
   start and by a fast-growing ramp after breakaway; the breakaway instant is found
   by fitting that ramp (hinge fit). When the drive accelerates during a stick (a
   speed step or a ramp's corner inside it) ``r`` is a line up to the corner and a
   parabola after it, ``C2*w0'/2*t^2`` (tens of N m over a 50 ms step), which no single
   line or parabola follows to both ends: the ends of a stick of at least 4 ms are
   therefore placed with a line through its first (last) 2 ms only. Both ends come
   out to a fraction of a millisecond on 10 kHz data with realistic noise (see the
   tests).
3. Plausibility: around the peak of a fast slip, ``-(I2*v'' + K2*v')/C2`` can cancel
   ``v`` and keep ``r`` parallel to a stick line for a few ms; there the chamber has
   sprung far back from the drive (``|w0 - w1|`` large, with ``w1`` from the
   complementary filter of :mod:`.observer`, torsion and acceleration only), unlike in
   a stick. A phase whose median ``|w0 - w1|`` exceeds half the local maximum
   (+-40 ms; at least 1 rad/s) is dropped. Then the speed consistency: in a stick the
   shaft moves with the chamber, ``w2 = w1``. The speed channel ``y`` shows ``w2``
   through a first-order lag ``tau`` and an offset drifting linearly ``c(t)``
   (``y + tau*y' = w2 + c``), both fitted by least squares to the interiors of the
   phases; a phase whose median ``|y + tau*y' - c - w1|`` exceeds 0.5 rad/s is a slip
   (the slow end of a slip after a speed step passed as a 3 ms stick at 0.6-6.4 rad/s
   of slip; true sticks stay within 0.1 rad/s at the noise of config/rig.yaml, with or
   without a 5 ms lag, and with a 10 % speed gain error). When most phases disagree
   the speed channel does not show the shaft speed and the check is skipped.

A first-order lag of the torsion amplifier (relative to the accelerometer) would
bend the stick lines; it is estimated from the record (:func:`estimate_torsion_lag`,
chamber kinematics ``M_t'' = C1*a``) or given, and compensated exactly
(:func:`torsion_lag_compensated`) before the residual is formed.

Phases of at least :data:`MIN_STICK` (1 ms, 10 samples at 10 kHz) are sticks,
shorter ones micro-sticks (:class:`StickReport`, counted apart). Cost: a few vector
passes over the record plus compiled work per candidate (a few ms per 1 s block).

Motion type per block: ``'stick-slip'`` (sticks of at least ``min_duration``),
``'slip-slip'`` (the torsion moment oscillates but slip never stops), ``'steady'``.

A package with one job per module (``from tribo_estimation.core.sticks import X``
gives every public name): :mod:`.detect` (:func:`find_sticks`, :func:`detect_sticks`,
:func:`classify_motion`, the stick residual), :mod:`.bounds` (the compiled boundary
stage), :mod:`.lag` (torsion-amplifier lag estimate and compensation) and
:mod:`.report` (:class:`StickPhase`, :class:`StickReport`).
"""

from __future__ import annotations

from .detect import (
    classify_motion,
    detect_sticks,
    drive_speed_level,
    find_sticks,
    slip_speed,
    speed_mismatch,
    stick_residual,
)
from .lag import (
    MAX_TORSION_LAG,
    TORSION_LAG_SHAPES,
    chamber_speed_integral,
    estimate_torsion_lag,
    fit_torsion_lag,
    kinematic_half,
    kinematic_pair,
    torsion_lag_compensated,
)
from .report import (
    MIN_STICK,
    MOTION_TYPES,
    StickPhase,
    StickReport,
)

__all__ = [
    'MAX_TORSION_LAG',
    'MIN_STICK',
    'MOTION_TYPES',
    'TORSION_LAG_SHAPES',
    'StickPhase',
    'StickReport',
    'chamber_speed_integral',
    'classify_motion',
    'detect_sticks',
    'drive_speed_level',
    'estimate_torsion_lag',
    'find_sticks',
    'fit_torsion_lag',
    'kinematic_half',
    'kinematic_pair',
    'slip_speed',
    'speed_mismatch',
    'stick_residual',
    'torsion_lag_compensated',
]
