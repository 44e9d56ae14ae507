"""Helpers of the cross-package tests: processes, the CLI, waiting, rig bags.

Imported as ``from support import ...`` (a module name of its own: every test
folder has a conftest.py, and which one ``import conftest`` finds depends on the
collection order). Processes started for a test run in their own session and
are stopped with SIGINT to the process group, then waited for.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]

# ROS_DOMAIN_ID and localhost discovery: set per test worker by the root conftest.py


def have_ros() -> bool:
    """True when rclpy and the built tribo_msgs are importable (env.sh sourced)."""
    try:
        import rclpy  # noqa: F401

        import tribo_msgs.msg  # noqa: F401
    except ImportError:
        return False
    return True


requires_ros = pytest.mark.skipif(
    not have_ros(), reason='needs rclpy and the built workspace: run under `make test`'
)


class Proc:
    """A process started in its own session; stopped with SIGINT to its group."""

    def __init__(self, args: list[str], log: Path, env: dict[str, str] | None = None) -> None:
        self.log_path = log
        self._log = log.open('wb')
        self.popen = subprocess.Popen(
            args,
            stdout=self._log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            env={**os.environ, **(env or {})},
            cwd=ROOT,
        )

    def stop(self, timeout: float = 20.0) -> int:
        """SIGINT the process group, wait; SIGKILL if it does not end."""
        if self.popen.poll() is None:
            try:
                os.killpg(self.popen.pid, signal.SIGINT)
            except ProcessLookupError:
                pass
            try:
                self.popen.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                os.killpg(self.popen.pid, signal.SIGKILL)
                self.popen.wait()
        self._log.close()
        return int(self.popen.returncode)

    def wait(self, timeout: float) -> int:
        """Wait for the process to end by itself."""
        try:
            return int(self.popen.wait(timeout=timeout))
        finally:
            self._log.close()

    def output(self) -> str:
        """Everything the process printed so far."""
        return self.log_path.read_text(errors='replace')


def tribo_cmd(*args: str) -> list[str]:
    """Command line of the tribo CLI in this interpreter."""
    return [sys.executable, '-m', 'tribo_bringup.cli', *args]


def wait_for(pred, timeout: float, interval: float = 0.1) -> bool:  # type: ignore[no-untyped-def]
    """Poll ``pred()`` until true or ``timeout`` [s]."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(interval)
    return False


def bag_so_far(path: Path, topics: list[str] | None = None) -> list[Any]:
    """The messages a bag being recorded holds on disk now (the recorder flushes
    every second); [] before the first flush. A torn last record is ignored."""
    import warnings

    from tribo_bringup import bagio
    from tribo_bringup.errors import BagError

    if not path.is_dir() or not any(path.glob('*.mcap')):
        return []
    with warnings.catch_warnings():
        warnings.simplefilter('ignore')
        try:
            return [m.msg for m in bagio.iter_messages(path, topics, on_error='warn')]
        except BagError:
            return []


def make_rig_bag(
    path: Path, seconds: float, *, seed: int = 11, block: int = 100, fs: float = 10_000.0
) -> None:
    """A bag of the simulated rig (config/rig.yaml, seeded noise) as the sim_rig node
    would record it: SampleBlocks of ``block`` samples at ``fs`` [Hz] on the three rig
    topics."""
    import numpy as np

    from tribo_bringup import bagio
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.simulate import simulate

    cfg = load_rig_config(ROOT / 'config' / 'rig.yaml')
    res = simulate(cfg.rig, cfg.friction, cfg.drive, seconds, fs, noise=cfg.noise, seed=seed)
    store = bagio.typestore()
    SB = store.types['tribo_msgs/msg/SampleBlock']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    chans = (
        ('/rig/torsion_moment', 'torsion_moment', 'N m', res.torsion_moment),
        ('/rig/angular_acceleration', 'angular_acceleration', 'rad/s^2', res.angular_acceleration),
        ('/rig/speed', 'speed', 'rad/s', res.speed),
    )
    t0 = 1_000_000_000
    with bagio.BagWriter(path) as w:
        for topic, *_ in chans:
            w.add_topic(topic, 'tribo_msgs/msg/SampleBlock')
        for start in range(0, len(res.time), block):
            stamp = t0 + round(start * 1e9 / fs)
            for topic, name, unit, data in chans:
                msg = SB(
                    header=Header(
                        stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=name
                    ),
                    sample_rate=fs,
                    first_index=start,
                    unit=unit,
                    data=np.ascontiguousarray(data[start : start + block]),
                )
                w.write_msg(topic, stamp, msg)
