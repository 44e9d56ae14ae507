"""ament_python package shell for tribo_bringup (console scripts go to lib/tribo_bringup)."""

import sys
from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

# the node table (tribo_common.nodes, no rclpy): from the source tree while colcon builds
# the workspace, else from an installed tribo_common
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tribo_common'))
from tribo_common.nodes import console_scripts

PACKAGE = 'tribo_bringup'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/launch', glob('launch/*.py')),
        # the configuration examples (config/ of this package; the workspace's config/
        # is a symlink to it), so that the launch files find them on any install
        ('share/' + PACKAGE + '/config', sorted(glob('config/*'))),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='tribo developers',
    maintainer_email='tribo@example.org',
    description=open('package.xml').read().split('<description>')[1].split('</description>')[0],
    license='Apache-2.0',
    entry_points={
        'console_scripts': ['tribo = tribo_bringup.cli:main', *console_scripts(PACKAGE)],
    },
)
