"""Launch the tribo graph on the real rig.

Full ROS 2 installs: `ros2 launch tribo_bringup hardware.launch.py`.

Serial DAQ (torsion, acceleration, speed), CAN sensor modules (normal force,
oil temperature), radiation counter, friction estimator and wear monitor.
The drivers are lifecycle nodes started with ``autostart: true`` from their
parameter files.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node


def generate_launch_description() -> LaunchDescription:
    """Hardware drivers + estimators."""
    default_config = os.environ.get(
        'TRIBO_CONFIG_DIR', os.path.join(get_package_share_directory('tribo_bringup'), 'config')
    )
    config_dir = LaunchConfiguration('config_dir')

    def params(name: str) -> PathJoinSubstitution:
        return PathJoinSubstitution([config_dir, name])

    return LaunchDescription(
        [
            DeclareLaunchArgument('config_dir', default_value=default_config),
            LifecycleNode(
                package='tribo_drivers',
                executable='daq_driver',
                name='daq_driver',
                namespace='',
                parameters=[params('daq_driver.yaml')],
            ),
            LifecycleNode(
                package='tribo_drivers',
                executable='can_driver',
                name='can_driver',
                namespace='',
                parameters=[params('can_driver.yaml')],
            ),
            LifecycleNode(
                package='tribo_drivers',
                executable='counter_driver',
                name='counter_driver',
                namespace='',
                parameters=[params('counter_driver.yaml')],
            ),
            Node(
                package='tribo_estimation',
                executable='friction_estimator',
                name='friction_estimator',
                parameters=[params('friction_estimator.yaml')],
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
        ]
    )
