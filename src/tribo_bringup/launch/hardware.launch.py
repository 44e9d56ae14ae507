"""Launch the tribo graph on the real rig.

Full ROS 2 installs: `ros2 launch tribo_bringup hardware.launch.py` (`--show-args`
lists the arguments).

Serial DAQ (torsion, acceleration, speed), CAN sensor modules (normal force,
oil temperature), radiation counter, friction estimator and wear monitor: the rows
of ``tribo_common.nodes`` launched by ``'hardware'``, each with its parameter file.
The drivers are lifecycle nodes started with ``autostart: true`` from their
parameter files. A real wear test resumes its saved state (``resume:=false``
starts a new one).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode, Node

from tribo_common.nodes import launched_by
from tribo_common.topics import normalize_namespace

TRUE = ('true', '1', 'yes', 'on')


def _graph(context: LaunchContext) -> list:
    def arg(name: str) -> str:
        return LaunchConfiguration(name).perform(context)

    config = arg('config_dir')
    ns = normalize_namespace(arg('namespace'))

    def params(name: str) -> str:
        return os.path.join(config, name)

    wear = {
        'nvct_config': params('nvct.yaml'),
        'fresh_start': arg('resume').strip().lower() not in TRUE,
    }
    if arg('state_file'):
        wear['state_file'] = arg('state_file')
    extra = {'wear_monitor': wear}

    def parameters(config_file: str, name: str) -> list:
        """Return the node's parameter file in config_dir (if any), then its values here."""
        files = [params(config_file)] if config_file else []
        return files + ([extra[name]] if name in extra else [])

    return [
        (LifecycleNode if n.lifecycle else Node)(
            package=n.package, executable=n.name, name=n.name, namespace=ns,
            parameters=parameters(n.config, n.name),
        )
        for n in launched_by('hardware')
    ]  # fmt: skip


def generate_launch_description() -> LaunchDescription:
    """Hardware drivers + estimators."""
    default_config = os.environ.get(
        'TRIBO_CONFIG_DIR', os.path.join(get_package_share_directory('tribo_bringup'), 'config')
    )
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                'config_dir', default_value=default_config,
                description='directory of the YAML parameter files (default: '
                '$TRIBO_CONFIG_DIR, else the config/ installed with tribo_bringup)',
            ),
            DeclareLaunchArgument(
                'namespace', default_value='',
                description='namespace of the rig (topics /NS/rig/...); empty: the root',
            ),
            DeclareLaunchArgument(
                'state_file', default_value='',
                description='wear monitor state file (empty: '
                '$ROS_HOME/tribo_nvct/wear_state.json, ROS_HOME defaulting to ~/.ros)',
            ),
            DeclareLaunchArgument(
                'resume', default_value='true', choices=['true', 'false'],
                description='resume the saved wear test; false: start a new test and keep '
                'the old state as a .bak file',
            ),
            OpaqueFunction(function=_graph),
        ]
    )  # fmt: skip
