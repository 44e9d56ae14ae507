"""Fixtures of the cross-package tests (the helpers are in support.py).

Tests that use DDS get their own ROS_DOMAIN_ID and localhost-only discovery
(root conftest.py).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from support import ROOT as ROOT
from support import Proc as Proc
from support import bag_so_far as bag_so_far
from support import make_rig_bag as make_rig_bag
from support import requires_ros as requires_ros
from support import tribo_cmd as tribo_cmd
from support import wait_for as wait_for


@pytest.fixture
def procs(tmp_path: Path) -> Iterator[list[Proc]]:
    """Start processes with ``procs.append(Proc(...))``; all are stopped at the end."""
    started: list[Proc] = []
    yield started
    for p in reversed(started):
        p.stop()
