"""ament_python package shell for tribo_drivers (console scripts go to lib/tribo_drivers)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'tribo_drivers'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/launch', glob('launch/*.py')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='tribo developers',
    maintainer_email='tribo@example.org',
    description=open('package.xml').read().split('<description>')[1].split('</description>')[0],
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'sim_rig = tribo_drivers.nodes.sim_rig:main',
            'sim_detector = tribo_drivers.nodes.sim_detector:main',
            'daq_driver = tribo_drivers.nodes.daq_driver:main',
            'counter_driver = tribo_drivers.nodes.counter_driver:main',
            'can_driver = tribo_drivers.nodes.can_driver:main',
        ],
    },
)
