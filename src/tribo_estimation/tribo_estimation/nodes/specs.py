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
        'wall time per window after which no further candidate form is fitted (a window cut '
        'short is investigated with every family on a second thread, one at a time)',
    ),
    ParamSpec(
        'alpha',
        '-',
        _MONITOR.alpha,
        1e-4,
        0.2,
        'false-alarm rate of the adequacy decisions (a window with nothing missing names '
        'an effect at most this often)',
    ),
    ParamSpec(
        'replicas',
        '-',
        _MONITOR.replicas,
        3,
        100,
        "bootstrap replicas of each window's null law",
        type='int',
    ),
    ParamSpec(
        'candidates',
        '',
        _MONITOR.candidates,
        description='effect families screened (names of the discrepancy library; empty: all)',
        type='str_list',
    ),
    CHECK_INPUT,
)

__all__ = ['ESTIMATOR_RIG_PARAMS', 'FRICTION_ESTIMATOR_PARAMS', 'MODEL_MONITOR_PARAMS']
