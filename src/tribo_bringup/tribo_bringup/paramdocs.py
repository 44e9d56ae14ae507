"""The parameter reference ``docs/parameters.md``, rendered from the specs (no rclpy).

``python -m tribo_bringup.paramdocs > docs/parameters.md`` writes it; a test
keeps the file equal to :func:`render`. The tables are those the nodes
declare from and the RIG.yaml loader validates with: the rig's
(:data:`tribo_estimation.core.rigspec.RIG_SPEC`) and one per node
(:data:`NODE_PARAMS`).
"""

from __future__ import annotations

from tribo_bringup.nodes.specs import LIVE_BRIDGE_PARAMS
from tribo_common.paramspec import ParamSpec, markdown_table
from tribo_drivers.nodes.specs import (
    CAN_PARAMS,
    COUNTER_PARAMS,
    DAQ_PARAMS,
    DRIVER_PARAMS,
    SIM_DETECTOR_PARAMS,
    SIM_RIG_PARAMS,
)
from tribo_estimation.core.rigspec import RIG_OPTIONAL, RIG_REQUIRED, RIG_SPEC
from tribo_estimation.nodes.specs import FRICTION_ESTIMATOR_PARAMS, MODEL_MONITOR_PARAMS
from tribo_nvct.nodes.specs import WEAR_MONITOR_PARAMS

#: Node name -> the parameters it declares from a spec.
NODE_PARAMS: dict[str, tuple[ParamSpec, ...]] = {
    'sim_rig': SIM_RIG_PARAMS,
    'friction_estimator': FRICTION_ESTIMATOR_PARAMS,
    'model_monitor': MODEL_MONITOR_PARAMS,
    'wear_monitor': WEAR_MONITOR_PARAMS,
    'sim_detector': SIM_DETECTOR_PARAMS,
    'daq_driver': (*DRIVER_PARAMS, *DAQ_PARAMS),
    'can_driver': (*DRIVER_PARAMS, *CAN_PARAMS),
    'counter_driver': (*DRIVER_PARAMS, *COUNTER_PARAMS),
    'live_bridge': LIVE_BRIDGE_PARAMS,
}


def render() -> str:
    """Render the Markdown text of ``docs/parameters.md``."""
    parts = [
        '# Parameters\n',
        'Generated from the parameter specs by `python -m tribo_bringup.paramdocs > '
        'docs/parameters.md` (a test keeps this file current). SI units; ranges are '
        "inclusive; defaults of the rig are the paper's Tab. 1 (`config/rig.yaml`).\n",
        '## Rig (RIG.yaml, `tribo_estimation.core.rigspec`)\n',
        f'Required: {", ".join(f"`{k}`" for k in RIG_REQUIRED)}; optional (absent: 0): '
        f'{", ".join(f"`{k}`" for k in RIG_OPTIONAL)} and `effects` (hidden model '
        'extensions, fields of `tribo_estimation.core.model.Extensions`).\n',
        markdown_table(RIG_SPEC),
    ]
    for node, specs in NODE_PARAMS.items():
        rig = [s.name for s in specs if s.name in RIG_SPEC]
        own = [s for s in specs if s.name not in RIG_SPEC]
        parts.append(f'## Node `{node}`\n')
        if rig:
            parts.append(f'Rig parameters (as above): {", ".join(f"`{n}`" for n in rig)}.\n')
        if node == 'sim_rig':
            parts.append('Also `effects.<name>` for every hidden extension (default 0).\n')
        parts.append(markdown_table(own))
    return '\n'.join(parts)


if __name__ == '__main__':
    print(render(), end='')
