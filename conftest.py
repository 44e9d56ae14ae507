"""Test-session settings shared by every test directory of the workspace.

Tests that use DDS run on their own ROS_DOMAIN_ID (11-40, varied by the
process id so that parallel runs of the suite on one machine rarely meet; a
pytest-xdist worker N is moved by 40*N) with localhost-only discovery.
"""

from __future__ import annotations

import os

_worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
_index = int(_worker[2:]) if _worker.startswith('gw') and _worker[2:].isdigit() else 0
os.environ['ROS_DOMAIN_ID'] = str(11 + 40 * (_index % 3) + os.getpid() % 30)
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
