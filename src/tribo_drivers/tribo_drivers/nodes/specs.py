"""Parameter specs of the driver nodes (no rclpy: the docs and tests read them too).

The simulated rig takes every rig parameter of the one rig table
(:data:`tribo_estimation.core.rigspec.RIG_SPEC`; tribo_drivers depends on
tribo_estimation, see package.xml) plus its stream settings. The hardware
drivers share :data:`DRIVER_PARAMS` (lifecycle, reconnect, diagnostics); their
parameters stay writable (``read_only=False``), as before.
"""

from __future__ import annotations

import dataclasses

from tribo_common import topics
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


def _rw(*specs: ParamSpec) -> tuple[ParamSpec, ...]:
    return tuple(dataclasses.replace(s, read_only=False) for s in specs)


#: Parameters of every hardware driver (:class:`tribo_drivers.nodes.driver_base.DriverNode`).
DRIVER_PARAMS: tuple[ParamSpec, ...] = _rw(
    ParamSpec(
        'autostart',
        '',
        True,
        description='configure and activate at start (no lifecycle manager)',
        type='bool',
    ),
    ParamSpec('poll_timeout', 's', 0.02, 0.001, 1.0, 'read timeout of one poll'),
    ParamSpec('diagnostic_period', 's', 1.0, 0.05, 60.0, 'period of /diagnostics'),
    ParamSpec('backoff_initial', 's', 0.1, 0.001, 60.0, 'first reconnect delay'),
    ParamSpec('backoff_max', 's', 5.0, 0.001, 600.0, 'largest reconnect delay'),
    ParamSpec('hardware_id', '', '', description='hardware id shown in /diagnostics', type='str'),
)

#: DAQ channels: (key, what, unit, default gain per count).
DAQ_SCALING: tuple[tuple[str, str, str, float], ...] = (
    ('torque', 'torsion moment', 'N m', 1e-6),
    ('accel', 'angular acceleration', 'rad/s^2', 1e-3),
    ('speed', 'shaft speed', 'rad/s', 1e-4),
)

#: Parameters of ``daq_driver`` (besides :data:`DRIVER_PARAMS`).
DAQ_PARAMS: tuple[ParamSpec, ...] = _rw(
    ParamSpec('port', '', '/dev/ttyUSB0', description='serial device of the DAQ', type='str'),
    ParamSpec('baudrate', 'bit/s', 2_000_000, 1200, 20_000_000, 'serial baud rate', type='int'),
    ParamSpec('sample_rate', 'Hz', 10_000.0, 1.0, 1e6, 'DAQ sample rate'),
    ParamSpec('block_size', '-', 50, 1, 1_000_000, 'samples per published block', type='int'),
    *(
        spec
        for key, what, unit, gain in DAQ_SCALING
        for spec in (
            ParamSpec(f'{key}_offset', 'counts', 0.0, -(2.0**31), 2.0**31, f'{what} offset'),
            ParamSpec(f'{key}_gain', f'{unit}/count', gain, None, None, f'{what} gain'),
        )
    ),
)

#: CAN channel -> its default SampleBlock topic.
CAN_CHANNEL_TOPICS: dict[str, str] = {
    t.channel: t.name
    for t in (
        topics.ANGULAR_ACCELERATION,
        topics.SPEED,
        topics.NORMAL_FORCE,
        topics.OIL_TEMPERATURE,
    )
}

#: Parameters of ``can_driver`` (besides :data:`DRIVER_PARAMS`).
CAN_PARAMS: tuple[ParamSpec, ...] = _rw(
    ParamSpec(
        'interface',
        '',
        'socketcan',
        description='python-can interface (socketcan, slcan, virtual, ...)',
        type='str',
    ),
    ParamSpec(
        'channel', '', 'can0', description='python-can channel (can0, /dev/ttyACM0)', type='str'
    ),
    ParamSpec('bitrate', 'bit/s', 500_000, 10_000, 8_000_000, 'CAN bit rate', type='int'),
    ParamSpec('dbc', '', '', description='DBC file (empty: config/tribo.dbc)', type='str'),
    ParamSpec('blocks_per_second', '1/s', 100.0, 1.0, 10_000.0, 'target blocks per s per channel'),
    *(
        ParamSpec(f'{ch}_topic', '', topic, description=f'SampleBlock topic of {ch}', type='str')
        for ch, topic in CAN_CHANNEL_TOPICS.items()
    ),
)

#: Parameters of ``counter_driver`` (besides :data:`DRIVER_PARAMS`).
COUNTER_PARAMS: tuple[ParamSpec, ...] = _rw(
    ParamSpec('port', '', '/dev/ttyUSB1', description='serial device of the counter', type='str'),
    ParamSpec('baudrate', 'bit/s', 115_200, 300, 4_000_000, 'serial baud rate', type='int'),
    ParamSpec('dwell', 's', 60.0, 0.001, 86_400.0, 'dwell time per count reading'),
    ParamSpec('ack_timeout', 's', 1.0, 0.01, 60.0, 'wait for $ACK after $DWELL'),
    ParamSpec('ack_retries', '-', 3, 1, 100, 'DWELL commands sent before giving up', type='int'),
    ParamSpec('topic', '', topics.NVCT_COUNTS.name, description='DetectorCounts topic', type='str'),
)

#: Parameters of ``sim_detector``.
SIM_DETECTOR_PARAMS: tuple[ParamSpec, ...] = _rw(
    ParamSpec('sim_config', '', '', description='path of sim_detector.yaml (required)', type='str'),
    ParamSpec(
        'nvct_config',
        '',
        '',
        description='NVCT.yaml override (empty: from sim_config)',
        type='str',
    ),
    ParamSpec(
        'time_scale',
        '-',
        0.0,
        0.0,
        1e6,
        'test seconds per wall-clock second (0: from the YAML)',
    ),
    ParamSpec('seed', '-', -1, -1, 2**31 - 1, 'random seed (-1: from the YAML)', type='int'),
    ParamSpec('topic', '', topics.NVCT_COUNTS.name, description='DetectorCounts topic', type='str'),
    ParamSpec(
        'wait_subscribers',
        's',
        0.0,
        0.0,
        600.0,
        'time to wait for a subscriber before the test clock starts',
    ),
)

__all__ = [
    'CAN_CHANNEL_TOPICS',
    'CAN_PARAMS',
    'COUNTER_PARAMS',
    'DAQ_PARAMS',
    'DAQ_SCALING',
    'DRIVER_PARAMS',
    'SIM_DETECTOR_PARAMS',
    'SIM_RIG_PARAMS',
]
