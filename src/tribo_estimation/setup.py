"""ament_python package shell for tribo_estimation (console scripts go to lib/tribo_estimation)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'tribo_estimation'

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
            'friction_estimator = tribo_estimation.nodes.friction_estimator:main',
            'model_monitor = tribo_estimation.nodes.model_monitor:main',
        ],
    },
)
