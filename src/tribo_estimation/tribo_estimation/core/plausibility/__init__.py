"""Plausibility of rig records before any fit: units, time base, spikes (no rclpy).

Each input channel is compared with what the rig's physics allows (symbols of
the paper, units SI; see ``docs/physics.md``):

* torsion moment ``C1 phi1`` [N m]: of the order of the friction moment
  ``F_N R mu`` (Equ. 8 with mu0/mu_inf of RIG.yaml); a 1000-fold larger median
  says N mm;
* shaft speed ``w2`` [rad/s]: near ``nominal_speed`` of the drive; 30/pi = 9.55
  times larger says rpm; a > 5 % difference of the median over the second half
  of the checked samples (past the start-up ramp) is a warning (a RIG.yaml describing
  another run), a speed channel at rest under a driven RIG.yaml an error;
* chamber acceleration ``w1'`` [rad/s^2]: bounded by torque over inertia
  ``|C1 phi1 - M_R| / I1`` (Equ. 1); far larger says deg/s^2 or mrad/s^2;
* time base: 0.1-100 kHz sampling, fast enough for the stick-slip frequency
  ``sqrt(C1/I1)/(2 pi)``; 1000 times slower says the time column is in ms.

A likely unit error raises :class:`~tribo_estimation.errors.UnitError`, a time
base that cannot be analysed :class:`~tribo_estimation.errors.TimeBaseError`;
both name the channel, the measured value and what was expected (CLI exit 2).

Isolated spikes (a sample or two far off a 5-sample running median, compared
with the MAD noise level of that residual), samples beyond any physical
bound and bursts (runs of up to :data:`BURST_MAX` samples that enter and leave
with a step no physical signal makes: a saturating channel, an ADC glitch;
:func:`find_bursts`) are replaced by linear interpolation of their good
neighbours and counted; the block fit leaves the replaced samples out of its
residuals, so they never bias a fit and never disturb neighbouring blocks.
"""

from __future__ import annotations

from tribo_estimation.core.plausibility.checks import (
    ACCEL_RATIO,
    FS_MAX,
    FS_MIN,
    SPEED_WARN,
    UNIT_RATIO,
    check_channels,
    check_time_base,
)
from tribo_estimation.core.plausibility.scales import (
    ABSURD,
    Scales,
    amplitude,
)
from tribo_estimation.core.plausibility.spikes import (
    BURST_MAX,
    BURST_SCALES,
    EDGE_HOLD,
    GROSS_FACTOR,
    MEDIAN_WIDTH,
    SPIKE_RANGE,
    SPIKE_SIGMA,
    SpikeLog,
    despike,
    despike_chunk,
    find_bursts,
    find_spikes,
    repair,
    running_median,
)
from tribo_estimation.core.plausibility.stream import (
    IDLE_RELEASE_S,
    CheckedStream,
    ChunkChecker,
    checked_chunks,
)
from tribo_estimation.core.signal import mad_sigma

__all__ = [
    'ABSURD',
    'ACCEL_RATIO',
    'BURST_MAX',
    'BURST_SCALES',
    'EDGE_HOLD',
    'FS_MAX',
    'FS_MIN',
    'GROSS_FACTOR',
    'IDLE_RELEASE_S',
    'MEDIAN_WIDTH',
    'SPEED_WARN',
    'SPIKE_RANGE',
    'SPIKE_SIGMA',
    'UNIT_RATIO',
    'CheckedStream',
    'ChunkChecker',
    'Scales',
    'SpikeLog',
    'amplitude',
    'check_channels',
    'check_time_base',
    'checked_chunks',
    'despike',
    'despike_chunk',
    'find_bursts',
    'find_spikes',
    'mad_sigma',
    'repair',
    'running_median',
]
