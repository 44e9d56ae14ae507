"""Launch the tribo graph on the simulated rig.

Full ROS 2 installs: `ros2 launch tribo_bringup sim.launch.py` (`--show-args` lists
the arguments). Equivalent of `tribo run --sim`. The nodes are the rows of
``tribo_common.nodes`` launched by ``'sim'``, each with its parameter file.

Arguments: ``config_dir``, ``namespace`` (moves the whole rig: topics
``/NS/rig/...``), ``record`` (+ ``bag``), ``state_file`` and ``resume`` (a
simulated launch starts a fresh wear test unless ``resume:=true``).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode, Node

from tribo_common.nodes import launched_by
from tribo_common.topics import DIAGNOSTICS, TOPICS, normalize_namespace

TRUE = ('true', '1', 'yes', 'on')


def _config_default() -> str:
    return os.environ.get(
        'TRIBO_CONFIG_DIR', os.path.join(get_package_share_directory('tribo_bringup'), 'config')
    )


def _graph(context: LaunchContext) -> list:
    def arg(name: str) -> str:
        return LaunchConfiguration(name).perform(context)

    config = arg('config_dir')
    ns = normalize_namespace(arg('namespace'))
    record = arg('record').strip().lower() in TRUE
    resume = arg('resume').strip().lower() in TRUE

    def params(name: str) -> str:
        return os.path.join(config, name)

    wear = {'nvct_config': params('nvct.yaml'), 'fresh_start': not resume}
    if arg('state_file'):
        wear['state_file'] = arg('state_file')
    # recording: the rig waits for the estimator and the recorder to match (no lost start)
    rig = {'min_subscribers': 2 if record else 0}
    extra = {
        'sim_rig': rig,
        'sim_detector': {'sim_config': params('sim_detector.yaml')},
        'wear_monitor': wear,
    }

    def parameters(config_file: str, name: str) -> list:
        """Return the node's parameter file in config_dir (if any), then its values here."""
        files = [params(config_file)] if config_file else []
        return files + ([extra[name]] if name in extra else [])

    actions = [
        (LifecycleNode if n.lifecycle else Node)(
            package=n.package, executable=n.name, name=n.name, namespace=ns,
            parameters=parameters(n.config, n.name),
        )
        for n in launched_by('sim')
    ]  # fmt: skip
    if record:
        topics = [t.resolve(ns) for t in TOPICS if t is not DIAGNOSTICS]
        out = ['-o', arg('bag')] if arg('bag') else []
        actions.append(ExecuteProcess(cmd=['ros2', 'bag', 'record', '-s', 'mcap', *out, *topics]))
    return actions


def generate_launch_description() -> LaunchDescription:
    """Launch the simulated rig + detector, estimator, model and wear monitors (+ recording)."""
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                'config_dir', default_value=_config_default(),
                description='directory of the YAML parameter files (default: '
                '$TRIBO_CONFIG_DIR, else the config/ installed with tribo_bringup)',
            ),
            DeclareLaunchArgument(
                'namespace', default_value='',
                description='namespace of the rig (topics /NS/rig/...); empty: the root',
            ),
            DeclareLaunchArgument(
                'record', default_value='false', choices=['true', 'false'],
                description='record the graph topics with ros2 bag record (MCAP); the rig '
                'waits for the recorder before streaming',
            ),
            DeclareLaunchArgument(
                'bag', default_value='',
                description='output directory of the recording (empty: rosbag2 default name)',
            ),
            DeclareLaunchArgument(
                'state_file', default_value='',
                description='wear monitor state file (empty: '
                '$ROS_HOME/tribo_nvct/wear_state.json, ROS_HOME defaulting to ~/.ros)',
            ),
            DeclareLaunchArgument(
                'resume', default_value='false', choices=['true', 'false'],
                description='resume the saved wear test; false: start a fresh test and keep '
                'the old state as a .bak file',
            ),
            OpaqueFunction(function=_graph),
        ]
    )  # fmt: skip
