"""Output-error fit of the rig model (+ a candidate effect) to a measured record.

The record is cut into *segments*, each starting inside a measured stick phase
where the state is known from the measurements (the discs move together:
``w1 = w2`` = measured shaft speed, ``phi1`` = torsion moment / C1, the belt
deflection from the stuck system's moment balance, Equ. 6). Each segment is
simulated with the compiled kernel (:func:`tribo_estimation.core.kernel.integrate`,
Equ. 1-3, 6, 8 plus the :class:`~tribo_estimation.core.model.Extensions`) from
that re-initialised state, so long records do not drift. A record without
stick-slip starts its segments from the measured sliding state instead. Segments
are grouped into time blocks, which the cross validation holds out.

The fitted values are a mapping ``name -> value`` of ``mu0``, ``mu_inf`` (Equ. 8,
-) and ``Extensions`` fields (their SI units, see
:class:`~tribo_estimation.core.model.Extensions`). The cost is the mean of the
squared, channel-weighted residuals (measured - simulated) of the torsion
moment (N m), the chamber speed (rad/s) and the shaft speed (rad/s).

Modules by job: :mod:`.records` (record, segment and output types, compared
channels, parameter specifications), :mod:`.segments` (stick phases and
segment cutting), :mod:`.instrument` (torsion and speed sensor terms identified
from the record), :mod:`.problem` (simulation, residuals and the least-squares
fit). Every name is re-exported here.
"""

from .instrument import (
    FALSE_STICK_MIN,
    FALSE_STICK_SIGMA,
    HUM_CHANNELS,
    SPEED_GAIN_BOUND,
    SPEED_OFFSET_BOUND,
    AccelSensor,
    Hum,
    SpeedSensor,
    TorsionLag,
    false_stick_phases,
    identify_accel_sensor,
    identify_hum,
    identify_speed_sensor,
    identify_torsion_lag,
    mains_grids,
    speed_offset_bound,
    speed_sensor_output,
    speed_slope,
    stuck_sensor_states,
    torsion_compensated_record,
)
from .problem import Problem
from .records import (
    CHAMBER_I1,
    CHANNEL_UNITS,
    CHANNELS,
    EXT_FIELDS,
    INSTRUMENT,
    INSTRUMENT_FIELDS,
    K_DECAY,
    MEASUREMENT_FIELDS,
    MU0,
    MU_INF,
    RIG_FACTOR_FIELDS,
    RIG_FACTORS,
    SHAFT,
    SHAFT_FIELDS,
    SPEED_LAG,
    SPEED_OFFSET,
    SPEED_SHAPE,
    FitOutcome,
    Record,
    Segments,
    SimulatedRecord,
)
from .segments import (
    CUT_STICK,
    SLIDE_WIN,
    UNKNOWN_DWELL,
    begins_at_drive_start,
    make_segments,
    sliding_chamber_speed,
    sliding_segments,
    sliding_start_states,
    stick_runs,
    stuck_before_onset,
    waits_at_rest,
)

__all__ = [
    'CHAMBER_I1',
    'CHANNELS',
    'CHANNEL_UNITS',
    'CUT_STICK',
    'EXT_FIELDS',
    'FALSE_STICK_MIN',
    'FALSE_STICK_SIGMA',
    'HUM_CHANNELS',
    'INSTRUMENT',
    'INSTRUMENT_FIELDS',
    'K_DECAY',
    'MEASUREMENT_FIELDS',
    'MU0',
    'MU_INF',
    'RIG_FACTORS',
    'RIG_FACTOR_FIELDS',
    'SHAFT',
    'SHAFT_FIELDS',
    'SLIDE_WIN',
    'SPEED_GAIN_BOUND',
    'SPEED_LAG',
    'SPEED_OFFSET',
    'SPEED_OFFSET_BOUND',
    'SPEED_SHAPE',
    'UNKNOWN_DWELL',
    'AccelSensor',
    'FitOutcome',
    'Hum',
    'Problem',
    'Record',
    'Segments',
    'SimulatedRecord',
    'SpeedSensor',
    'TorsionLag',
    'begins_at_drive_start',
    'false_stick_phases',
    'identify_accel_sensor',
    'identify_hum',
    'identify_speed_sensor',
    'identify_torsion_lag',
    'mains_grids',
    'make_segments',
    'sliding_chamber_speed',
    'sliding_segments',
    'sliding_start_states',
    'speed_offset_bound',
    'speed_sensor_output',
    'speed_slope',
    'stick_runs',
    'stuck_before_onset',
    'stuck_sensor_states',
    'torsion_compensated_record',
    'waits_at_rest',
]
