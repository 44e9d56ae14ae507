"""Parameter specs of the bringup nodes (no rclpy: the docs and tests read them too).

``C1`` is the rig's (:data:`tribo_estimation.core.rigspec.RIG_SPEC`: Tab. 1
default and bounds); the bridge uses it for the stick flag only.
"""

from __future__ import annotations

import dataclasses

from tribo_common.paramspec import ParamSpec
from tribo_estimation.core.rigspec import RIG_SPEC

#: Parameters of ``live_bridge``.
LIVE_BRIDGE_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec(
        'host', '', '127.0.0.1', description='address to bind (127.0.0.1: local only)', type='str'
    ),
    ParamSpec('port', '-', 8765, 0, 65535, 'WebSocket TCP port (0: any free port)', type='int'),
    ParamSpec(
        'downsample_rate',
        'Hz',
        200.0,
        1.0,
        100_000.0,
        'output rate of the down-sampled 10 kHz streams',
    ),
    ParamSpec(
        'downsample_mode',
        '',
        'minmax',
        description='minmax (bin mean + envelope) or decimate',
        type='str',
    ),
    dataclasses.replace(
        RIG_SPEC['C1'], description='torsion element stiffness C1, for the stick flag'
    ),
    ParamSpec(
        'stick_tolerance', 'rad/s', 0.05, 0.0, 100.0, 'largest |w2 - w1| counted as sticking'
    ),
    ParamSpec(
        'message_backlog',
        '-',
        4096,
        16,
        1_000_000,
        'messages buffered per client before the oldest is dropped',
        type='int',
    ),
)

__all__ = ['LIVE_BRIDGE_PARAMS']
