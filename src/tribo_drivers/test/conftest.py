"""Shared fixtures of the tribo_drivers tests (core/ and nodes/ below mirror the package).

The CAN tests get the shipped DBC and its codec; the node tests a listener node and
the driver processes: each driver runs as its own process in its own session on
this worker's ROS_DOMAIN_ID with localhost discovery (root conftest.py) and is
stopped with SIGINT to its process group, then waited for. One conftest for the
whole folder: a conftest.py in a subfolder would be imported during collection and
shadow tests/conftest.py for the cross-package tests that import from it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tribo_drivers.core.can_protocol import CanCodec

ROOT = Path(__file__).resolve().parents[3]
DOMAIN = os.environ['ROS_DOMAIN_ID']  # per test worker (root conftest.py)

#: The shipped DBC of the CAN sensor modules.
DBC = ROOT / 'config' / 'tribo.dbc'


@pytest.fixture
def dbc() -> Path:
    """Path of the shipped DBC."""
    return DBC


@pytest.fixture(scope='module')
def codec() -> CanCodec:
    """The codec of the shipped DBC."""
    return CanCodec(DBC)


@pytest.fixture
def dbc_with(tmp_path: Path) -> Callable[[str], Path]:
    """Write config/tribo.dbc without its frame-rate attributes, plus ``extra`` lines."""

    def write(extra: str) -> Path:
        lines = [ln for ln in DBC.read_text().splitlines() if 'TriboFrameRate' not in ln]
        path = tmp_path / 'rates.dbc'
        path.write_text('\n'.join(lines) + '\n' + extra + '\n')
        return path

    return write


def _ros_env() -> dict[str, str]:
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = DOMAIN
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['TRIBO_ROOT'] = str(ROOT)
    return env


class DriverRunner:
    """Starts driver executables (``tribo_drivers.nodes.<module>``) and stops them."""

    def __init__(self) -> None:
        self.procs: list[subprocess.Popen[bytes]] = []

    def start(self, module: str, params: dict[str, Any]) -> subprocess.Popen[bytes]:
        args = [sys.executable, '-m', f'tribo_drivers.nodes.{module}', '--ros-args']
        for k, v in params.items():
            args += ['-p', f'{k}:={v}']
        proc = subprocess.Popen(args, env=_ros_env(), start_new_session=True)
        self.procs.append(proc)
        return proc

    @staticmethod
    def stop(proc: subprocess.Popen[bytes]) -> None:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(5)

    @staticmethod
    def spin_until(node: Any, cond: Callable[[], bool], timeout: float) -> None:
        import rclpy

        end = time.monotonic() + timeout
        while time.monotonic() < end and not cond():
            rclpy.spin_once(node, timeout_sec=0.05)


@pytest.fixture
def drivers() -> Iterator[DriverRunner]:
    """Start drivers with ``drivers.start(module, params)``; all are stopped at the end."""
    runner = DriverRunner()
    yield runner
    for proc in runner.procs:
        runner.stop(proc)


@pytest.fixture()
def listener() -> Any:
    """A plain rclpy node in this process (rclpy initialised for the test)."""
    os.environ['ROS_DOMAIN_ID'] = DOMAIN
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    import rclpy

    rclpy.init()
    node = rclpy.create_node('driver_test_listener')
    yield node
    node.destroy_node()
    rclpy.try_shutdown()
