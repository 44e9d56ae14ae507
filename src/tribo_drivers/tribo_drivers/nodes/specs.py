"""Parameter specs of the driver nodes (no rclpy: the docs and tests read them too).

The simulated rig takes every rig parameter of the one rig table
(:data:`tribo_estimation.core.rigspec.RIG_SPEC`; tribo_drivers depends on
tribo_estimation, see package.xml) plus its stream settings.
"""

from __future__ import annotations

from tribo_common.paramspec import ParamSpec
from tribo_estimation.core.rigspec import RIG_SPEC

#: Parameters of ``sim_rig`` (besides ``effects.<name>``, one per hidden extension).
SIM_RIG_PARAMS: tuple[ParamSpec, ...] = (
    *RIG_SPEC.values(),
    ParamSpec('sample_rate', 'Hz', 10000.0, 100.0, 100000.0, 'sample rate'),
    ParamSpec('block_size', '-', 100, 10, 10000, 'samples per published block', type='int'),
    ParamSpec('duration', 's', 0.0, 0.0, None, 'simulated time to run (0: until stopped)'),
    ParamSpec('seed', '-', 0, 0, None, 'seed of the measurement noise', type='int'),
    ParamSpec(
        'min_subscribers',
        '-',
        0,
        0,
        100,
        'subscriptions each rig topic must have before the stream starts (e.g. 2: '
        'estimator and recorder, so that a recording holds the first sample)',
        type='int',
    ),
    ParamSpec(
        'wait_subscribers',
        's',
        30.0,
        0.0,
        3600.0,
        'longest wait for min_subscribers before streaming anyway',
    ),
)

__all__ = ['SIM_RIG_PARAMS']
