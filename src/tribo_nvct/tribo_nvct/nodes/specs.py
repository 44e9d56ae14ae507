"""Parameter specs of the nVCT nodes (no rclpy: the docs and tests read them too)."""

from __future__ import annotations

from tribo_common.paramspec import ParamSpec
from tribo_common.topics import NVCT_COUNTS, NVCT_WEAR

#: Parameters of ``wear_monitor`` (writable, as before). ``state_file`` defaults to
#: ``$ROS_HOME/tribo_nvct/wear_state.json`` at run time (the node sets it with
#: :meth:`ParamSpec.with_default`); empty: not persisted.
WEAR_MONITOR_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec(
        'nvct_config',
        '',
        '',
        description='path of NVCT.yaml (nVCT configuration)',
        read_only=False,
        type='str',
    ),
    ParamSpec(
        'state_file',
        '',
        '',
        description='evaluator state JSON (default $ROS_HOME/tribo_nvct/wear_state.json, '
        'ROS_HOME defaulting to ~/.ros; empty: not persisted)',
        read_only=False,
        type='str',
    ),
    ParamSpec(
        'rate_window_s',
        's',
        600.0,
        60.0,
        86_400.0,
        'span of the current wear-rate regression',
        read_only=False,
    ),
    ParamSpec(
        'save_interval_s',
        's',
        1.0,
        0.0,
        60.0,
        'least wall time between two writes of the state file',
        read_only=False,
    ),
    ParamSpec(
        'counts_topic',
        '',
        NVCT_COUNTS.name,
        description='DetectorCounts input topic',
        read_only=False,
        type='str',
    ),
    ParamSpec(
        'wear_topic',
        '',
        NVCT_WEAR.name,
        description='WearState output topic',
        read_only=False,
        type='str',
    ),
    ParamSpec(
        'fresh_start',
        '',
        False,
        description='back up any saved state and start anew',
        read_only=False,
        type='bool',
    ),
)

__all__ = ['WEAR_MONITOR_PARAMS']
