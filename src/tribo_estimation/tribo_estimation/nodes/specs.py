"""Parameter specs of the estimation nodes (no rclpy: the docs and tests read them too).

The rig names come from the one rig table
(:data:`tribo_estimation.core.rigspec.RIG_SPEC`: same defaults and bounds
everywhere); only the descriptions say what the node does with them. The node
settings are specified here, their defaults taken from the core settings
objects where one exists (:class:`~tribo_estimation.core.discrepancy.monitor.MonitorConfig`).
"""

from __future__ import annotations

import dataclasses

from tribo_common.paramspec import ParamSpec
from tribo_estimation.core.discrepancy.monitor import MonitorConfig
from tribo_estimation.core.rigspec import ESTIMATOR_RIG_KEYS, RIG_SPEC

_MONITOR = MonitorConfig()


def _estimating(name: str) -> ParamSpec:
    """Return the rig spec of ``name`` as an estimating node reads it."""
    s = RIG_SPEC[name]
    if name in ('mu0', 'mu_inf'):
        return dataclasses.replace(s, description=f'start value of the {s.description}')
    if name == 'nominal_speed':
        return dataclasses.replace(
            s, description=f'{s.description}; 0 = the measured mean speed (tachometer)'
        )
    return s


#: Rig parameters of the friction estimator and the model monitor.
ESTIMATOR_RIG_PARAMS: tuple[ParamSpec, ...] = tuple(_estimating(n) for n in ESTIMATOR_RIG_KEYS)

#: The input checks of the estimator nodes (as the offline commands run them).
CHECK_INPUT = ParamSpec(
    'check_input',
    '',
    True,
    description='check units and time base of the first 2 s and repair spikes '
    '(as the offline tribo friction does)',
    type='bool',
)

#: Parameters of ``friction_estimator``.
FRICTION_ESTIMATOR_PARAMS: tuple[ParamSpec, ...] = (
    *ESTIMATOR_RIG_PARAMS,
    ParamSpec('block_length', 's', 1.0, 0.01, 600.0, 'block length of the fit (paper: 1 s)'),
    ParamSpec('fit_k', '', False, description='also fit k (Equ. 8) per block', type='bool'),
    CHECK_INPUT,
)

#: Parameters of ``model_monitor``.
MODEL_MONITOR_PARAMS: tuple[ParamSpec, ...] = (
    *ESTIMATOR_RIG_PARAMS,
    ParamSpec('window', 's', _MONITOR.window, 0.1, 3600.0, 'length of the evaluated window'),
    ParamSpec('hop', 's', _MONITOR.hop, 0.01, 3600.0, 'time between two evaluations'),
    ParamSpec(
        'time_budget',
        's',
        _MONITOR.time_budget,
        0.001,
        3600.0,
        'wall time per window after which no further candidate is refitted',
    ),
    ParamSpec(
        'ratio_threshold',
        '-',
        _MONITOR.ratio_threshold,
        0.0,
        1e6,
        'try candidates only when the residual rms exceeds this many noise floors',
    ),
    ParamSpec(
        'min_gain',
        '-',
        _MONITOR.min_gain,
        0.0,
        0.99,
        'name a candidate only if it lowers the residual rms by this fraction',
    ),
    ParamSpec(
        'max_rel_se',
        '-',
        _MONITOR.max_rel_se,
        1e-6,
        1e6,
        'identifiable only if every candidate parameter has a relative standard error below',
    ),
    ParamSpec(
        'max_correlation',
        '-',
        _MONITOR.max_correlation,
        1e-6,
        1.0,
        'identifiable only if no candidate parameter correlates more with mu0/mu_inf',
    ),
    ParamSpec(
        'max_candidates',
        '-',
        _MONITOR.max_candidates,
        0,
        20,
        'candidate effects refitted per window, best ranked first',
        type='int',
    ),
    ParamSpec(
        'candidates',
        '',
        _MONITOR.candidates,
        description='candidate effects that may be tried (names of the discrepancy library)',
        type='str_list',
    ),
    CHECK_INPUT,
)

__all__ = ['ESTIMATOR_RIG_PARAMS', 'FRICTION_ESTIMATOR_PARAMS', 'MODEL_MONITOR_PARAMS']
