"""Launch the tribo graph on the simulated rig.

Full ROS 2 installs: `ros2 launch tribo_bringup sim.launch.py`.

Equivalent of `tribo run --sim`. Arguments: ``config_dir`` (directory with the
YAML parameter files, default: ``$TRIBO_CONFIG_DIR``, else the config/ copy
installed into this package's share directory), ``record`` (true/false:
record all topics with rosbag2).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node

TOPICS = [
    '/rig/torsion_moment',
    '/rig/angular_acceleration',
    '/rig/speed',
    '/nvct/counts',
    '/friction/moment',
    '/friction/estimate',
    '/nvct/wear',
    '/model/discrepancy',
]


def generate_launch_description() -> LaunchDescription:
    """Simulated rig + detector, friction estimator, model and wear monitors (+ rosbag2 record)."""
    default_config = os.environ.get(
        'TRIBO_CONFIG_DIR', os.path.join(get_package_share_directory('tribo_bringup'), 'config')
    )
    config_dir = LaunchConfiguration('config_dir')

    def params(name: str) -> PathJoinSubstitution:
        return PathJoinSubstitution([config_dir, name])

    return LaunchDescription(
        [
            DeclareLaunchArgument('config_dir', default_value=default_config),
            DeclareLaunchArgument('record', default_value='false'),
            Node(
                package='tribo_drivers',
                executable='sim_rig',
                name='sim_rig',
                parameters=[params('sim_rig.yaml')],
            ),
            Node(
                package='tribo_drivers',
                executable='sim_detector',
                name='sim_detector',
                parameters=[{'sim_config': params('sim_detector.yaml')}],
            ),
            Node(
                package='tribo_estimation',
                executable='friction_estimator',
                name='friction_estimator',
                parameters=[params('friction_estimator.yaml')],
            ),
            Node(
                package='tribo_estimation',
                executable='model_monitor',
                name='model_monitor',
                parameters=[params('model_monitor.yaml')],
            ),
            Node(
                package='tribo_nvct',
                executable='wear_monitor',
                name='wear_monitor',
                parameters=[
                    params('wear_monitor.yaml'),
                    {'nvct_config': params('nvct.yaml')},
                ],
            ),
            ExecuteProcess(
                cmd=['ros2', 'bag', 'record', '-s', 'mcap', *TOPICS],
                condition=IfCondition(LaunchConfiguration('record')),
            ),
        ]
    )
